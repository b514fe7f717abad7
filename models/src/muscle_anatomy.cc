#include "biodyn/models/muscle_anatomy.h"

#include <Eigen/Geometry>
#include <cmath>
#include <nlohmann/json.hpp>
#include <string>

#include "biodyn/models/character.h"
#include "biodyn/models/tables.h"
#include "biodyn/sim/errors.h"

namespace biodyn::models {
namespace {

using Eigen::Vector3d;
using nlohmann::json;

constexpr const char* kTableFile = "muscles_rajagopal2016.json";

const json& muscle_table() {
  static const json table = [] {
    try {
      return json::parse(embedded_data_file(kTableFile));
    } catch (const json::exception& e) {
      throw sim::Error(std::string(kTableFile) + ": " + e.what());
    }
  }();
  return table;
}

Vector3d vec3(const json& j, const std::string& field) {
  if (!j.is_array() || j.size() != 3) {
    throw sim::Error(std::string(kTableFile) + ": " + field + ": expected 3 numbers");
  }
  return {j[0].get<double>(), j[1].get<double>(), j[2].get<double>()};
}

// From the source model's OpenSim frames to one side of the generated character: per body, the
// origin's place in the source (its joint), the generated segment and the per-axis scale.
struct SideMap {
  double side_sign = 1;  // y = side_sign * z_osim: -1 right (z right, y left), +1 left (mirrored)
  struct BodyMap {
    std::string segment;
    Vector3d source_origin;  // the body's joint in the source body's own frame (subtracted)
    Vector3d scale;          // per axis of the generated frame
    Vector3d source_world;   // the body's origin in the source pelvis frame, default pose
  };
  std::map<std::string, BodyMap> bodies;

  // OpenSim (x anterior, y up, z right) -> generated (x forward, y left, z up), mirrored left.
  Vector3d axes(const Vector3d& v) const { return {v.x(), side_sign * v.z(), v.y()}; }

  const BodyMap& body(const std::string& name) const {
    const auto it = bodies.find(name);
    if (it == bodies.end()) {
      throw sim::Error(std::string(kTableFile) + ": no generated segment for body '" + name + "'");
    }
    return it->second;
  }
  Vector3d point(const std::string& b, const Vector3d& p) const {
    const BodyMap& m = body(b);
    return m.scale.cwiseProduct(axes(p - m.source_origin));
  }
  Vector3d source_world(const std::string& b, const Vector3d& p) const {
    return body(b).source_world + p;
  }
};

SideMap side_map(const Character& c, const json& model, const std::string& side) {
  const auto seg = [&](const std::string& n) -> const Segment& {
    const Segment* s = c.find(n);
    if (!s) throw sim::Error("generate_muscles: the character has no segment '" + n + "'");
    return *s;
  };
  const Segment &thigh = seg("thigh_" + side), &shank = seg("shank_" + side),
                &foot = seg("foot_" + side), &toes = seg("toes_" + side);
  const Segment& other_thigh = seg(side == "l" ? "thigh_r" : "thigh_l");
  const Vector3d hip = vec3(model["hip_in_pelvis"], "hip_in_pelvis");
  const Vector3d knee_f = vec3(model["knee_in_femur"], "knee_in_femur");
  const Vector3d knee_t = vec3(model["knee_in_tibia"], "knee_in_tibia");
  const Vector3d ankle = vec3(model["ankle_in_tibia"], "ankle_in_tibia");
  const Vector3d subtalar = vec3(model["subtalar_in_talus"], "subtalar_in_talus");
  const Vector3d mtp = vec3(model["mtp_in_calcn"], "mtp_in_calcn");

  SideMap m;
  m.side_sign = side == "l" ? 1.0 : -1.0;
  const double height_ratio = c.spec.height_m / model["height_m"].get<double>();
  const double hip_ratio =
      std::abs(thigh.origin_W.y() - other_thigh.origin_W.y()) / (2.0 * std::abs(hip.z()));
  const Vector3d hip_mid(hip.x(), hip.y(), 0.0);
  m.bodies["pelvis"] = {
      "pelvis", hip_mid, {height_ratio, hip_ratio, height_ratio}, Vector3d::Zero()};
  const double thigh_ratio = (shank.origin_W - thigh.origin_W).norm() / knee_f.norm();
  const Vector3d femur_world(hip.x(), hip.y(), hip.z());
  m.bodies["femur"] = {"thigh_" + side, Vector3d::Zero(), Vector3d::Constant(thigh_ratio),
                       femur_world};
  const double shank_ratio = (foot.origin_W - shank.origin_W).norm() / (ankle - knee_t).norm();
  const Vector3d tibia_world = femur_world + knee_f - knee_t;
  m.bodies["tibia"] = {"shank_" + side, knee_t, Vector3d::Constant(shank_ratio), tibia_world};
  // The foot's origin is the ankle (the source's talus); calcn points are offset by the subtalar.
  const Vector3d toe_joint = subtalar + mtp;  // source: MTP relative to the ankle
  const Vector3d toe_here = toes.origin_W - foot.origin_W;
  const double along = toe_here.x() / toe_joint.x(), up = toe_here.z() / toe_joint.y();
  const Vector3d talus_world = tibia_world + ankle;
  m.bodies["calcn"] = {"foot_" + side, -subtalar, {along, along, up}, talus_world + subtalar};
  // The toes' origin is the MTP joint in both models.
  m.bodies["toes"] = {
      "toes_" + side, Vector3d::Zero(), {along, along, up}, talus_world + subtalar + mtp};
  return m;
}

MuscleWrapCylinder map_wrap(const json& w, const SideMap& m, const std::string& side) {
  const std::string body = w["body"].get<std::string>();
  const SideMap::BodyMap& b = m.body(body);
  const Vector3d rot = vec3(w["xyz_body_rotation"], "xyz_body_rotation");
  // OpenSim's body-fixed X-Y-Z rotation; the cylinder's axis is its local z.
  const Eigen::Matrix3d R = (Eigen::AngleAxisd(rot.x(), Vector3d::UnitX()) *
                             Eigen::AngleAxisd(rot.y(), Vector3d::UnitY()) *
                             Eigen::AngleAxisd(rot.z(), Vector3d::UnitZ()))
                                .toRotationMatrix();
  MuscleWrapCylinder out;
  out.name = w["name"].get<std::string>() + "_" + side;
  out.segment = b.segment;
  out.center_B = m.point(body, vec3(w["translation"], "translation"));
  out.axis_B = m.axes(R * Vector3d::UnitZ()).normalized();
  const double scale = b.scale.x();  // the segment's length ratio (pelvis: height)
  // "radius_used": the table's documented adjustment of the source radius (its "adjustment").
  out.radius_m = w.value("radius_used", w["radius"].get<double>()) * scale;
  out.half_length_m = 0.5 * w["length"].get<double>() * scale;
  if (w.contains("side")) {  // else no side site: MuJoCo wraps the shorter way round
    Vector3d side_dir = m.axes(vec3(w["side"], "side"));
    side_dir -= side_dir.dot(out.axis_B) * out.axis_B;
    out.side_B = out.center_B + 2.0 * out.radius_m * side_dir.normalized();
    out.has_side = true;
  }
  out.after_point = w["after_point"].get<int>();
  return out;
}

double straight_length(const std::vector<Vector3d>& points) {
  double sum = 0;
  for (std::size_t i = 1; i < points.size(); ++i) sum += (points[i] - points[i - 1]).norm();
  return sum;
}

MuscleDefinition make_muscle(const json& j, const SideMap& m, const Character& c,
                             const std::string& side) {
  MuscleDefinition d;
  d.base_name = j["name"].get<std::string>();
  d.name = d.base_name + "_" + side;
  d.description = j["description"].get<std::string>();
  for (const json& comp : j["compartments"])
    d.compartments += (d.compartments.empty() ? "" : "+") + comp.get<std::string>();
  d.parameters_from = j["parameters_from"].get<std::string>();
  d.tendon = j["tendon"].get<std::string>();
  d.passive_strain_at_fmax = muscle_table()["passive_strain_at_fmax"].get<double>();
  std::vector<Vector3d> here, source;
  for (const json& p : j["path"]) {
    const std::string body = p["body"].get<std::string>();
    // "location_used": the table's documented adjustment of the source point (its "adjustment").
    const Vector3d loc =
        vec3(p.contains("location_used") ? p["location_used"] : p["location"], "location");
    MusclePathPoint point{m.body(body).segment, m.point(body, loc)};
    const Segment* seg = c.find(point.segment);
    here.push_back(seg->origin_W + point.position_B);  // standing pose: frames parallel to world
    source.push_back(m.source_world(body, loc));
    d.path.push_back(point);
  }
  for (const json& w : j["wraps"]) d.wraps.push_back(map_wrap(w, m, side));
  d.path_length_m = straight_length(here);
  d.source_path_length_m = straight_length(source);
  const double length_ratio = d.path_length_m / d.source_path_length_m;
  d.optimal_fiber_length_m = j["optimal_fiber_length_m"].get<double>() * length_ratio;
  d.tendon_slack_length_m = j["tendon_slack_length_m"].get<double>() * length_ratio;
  d.pennation_at_optimal_rad = j["pennation_at_optimal_rad"].get<double>();
  d.max_isometric_force_N =
      j["max_isometric_force_N"].get<double>() * c.spec.mass_kg / kMuscleModelMass_kg;
  return d;
}

}  // namespace

std::vector<MuscleDefinition> generate_muscles(const Character& c) {
  const json& table = muscle_table();
  std::vector<MuscleDefinition> out;
  try {
    for (const std::string side : {"l", "r"}) {
      const SideMap m = side_map(c, table["generic_model"], side);
      for (const json& j : table["muscles"]) out.push_back(make_muscle(j, m, c, side));
    }
  } catch (const json::exception& e) {
    throw sim::Error(std::string(kTableFile) + ": " + e.what());
  }
  return out;
}

std::string muscle_table_source() { return muscle_table()["source"].get<std::string>(); }

}  // namespace biodyn::models
