#include "biodyn/models/mjcf.h"

#include <tinyxml2.h>

#include <algorithm>
#include <cmath>
#include <initializer_list>
#include <iomanip>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>

#include "biodyn/sim/errors.h"
#include "biodyn/sim/units.h"

namespace biodyn::models {
namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;

// Collision filtering: the floor collides with every body geom, body geoms never with each
// other (contype/conaffinity bits, MuJoCo: collide if (ct1 & ca2) || (ct2 & ca1)).
constexpr int kFloorContype = 1, kFloorConaffinity = 2;
constexpr int kBodyContype = 2, kBodyConaffinity = 1;
constexpr int kMarkerSiteGroup = 4;            // hidden in the viewer unless group 4 is shown
constexpr double kMarkerSiteRadius = 0.01;     // m
constexpr double kOffDiagonalEpsilon = 1e-12;  // kg m^2: below this the inertia is diagonal
constexpr double kMuscleSiteRadius = 0.005;    // m
constexpr double kMusclePathWidth = 0.006;     // m, drawn tendon radius
constexpr int kWrapGeomGroup = 3;              // wrapping cylinders: hidden unless group 3 is shown

std::string fmt(double v) {
  std::ostringstream s;
  s << std::setprecision(12) << (std::abs(v) < 1e-15 ? 0.0 : v);
  return s.str();
}
std::string fmt(const Vector3d& v) { return fmt(v.x()) + " " + fmt(v.y()) + " " + fmt(v.z()); }

using Attributes = std::initializer_list<std::pair<const char*, std::string>>;

/// Appends <name attr="value" ...> to `parent` and returns it.
tinyxml2::XMLElement* child(tinyxml2::XMLElement* parent, const char* name, Attributes attrs = {}) {
  tinyxml2::XMLElement* e = parent->GetDocument()->NewElement(name);
  parent->InsertEndChild(e);
  for (const auto& [key, value] : attrs) e->SetAttribute(key, value.c_str());
  return e;
}

void set(tinyxml2::XMLElement* e, const char* attr, const std::string& value) {
  e->SetAttribute(attr, value.c_str());
}

// A solref time constant as written: at least 2 timesteps, because MuJoCo 2.2.2 silently
// stiffens a faster one to that (mujoco-2.2.2.md), so the file says what the solver does.
double solref_time_constant(const PhysicsOptions& o, double time_constant_s) {
  return std::max(time_constant_s, 2 * o.timestep_s);
}

/// The model's name and the <compiler>, <option>, <size>, <visual> and <statistic> elements.
void add_settings(tinyxml2::XMLElement* root, const Character& c, const PhysicsOptions& o) {
  std::ostringstream model_name;
  model_name << "biodyn_" << to_string(c.spec.sex) << "_" << fmt(c.spec.height_m) << "m_"
             << fmt(c.spec.mass_kg) << "kg_" << to_string(c.spec.detail);
  set(root, "model", model_name.str());

  child(root, "compiler",
        {{"angle", "radian"}, {"inertiafromgeom", "false"}});  // explicit <inertial>
  // 2.2.2's Euler already integrates joint damping implicitly; its "implicit" integrator adds
  // only actuator-velocity derivatives (none for motors) at the cost of a dense nv x nv
  // factorisation: measured 180-230 us/step against 70-85 us for Euler on the full body.
  child(root, "option",
        {{"timestep", fmt(o.timestep_s)},
         {"integrator", "Euler"},
         {"cone", o.elliptic_cone ? "elliptic" : "pyramidal"},
         {"impratio", fmt(o.impratio)},
         {"solver", "Newton"},
         {"jacobian", o.sparse_jacobian ? "sparse" : "dense"},
         {"iterations", std::to_string(o.solver_iterations)},
         {"tolerance", fmt(o.solver_tolerance)}});
  child(root, "size", {{"nconmax", std::to_string(o.nconmax)}, {"njmax", std::to_string(o.njmax)}});
  child(child(root, "visual"), "global", {{"offwidth", "1280"}, {"offheight", "720"}});
  // Frame the character, not the 100 m floor, in MuJoCo's default free camera (simulate).
  child(root, "statistic",
        {{"center", fmt(Vector3d(0, 0, 0.5 * c.standing_height_m))},
         {"extent", fmt(c.standing_height_m)}});
}

/// <asset>: the floor's checker texture and material, and the body material.
void add_assets(tinyxml2::XMLElement* root) {
  tinyxml2::XMLElement* asset = child(root, "asset");
  child(asset, "texture",
        {{"name", "grid"},
         {"type", "2d"},
         {"builtin", "checker"},
         {"rgb1", "0.2 0.3 0.4"},
         {"rgb2", "0.3 0.4 0.5"},
         {"width", "512"},
         {"height", "512"}});
  child(asset, "material",
        {{"name", "grid"},
         {"texture", "grid"},
         {"texrepeat", "1 1"},
         {"texuniform", "true"},
         {"reflectance", "0.1"}});
  child(asset, "material", {{"name", "body"}, {"rgba", "0.8 0.6 0.45 1"}});
}

/// <default>: body geoms' collision bits and friction, joint limits' solref, marker sites and
/// motors.
void add_defaults(tinyxml2::XMLElement* root, const PhysicsOptions& o) {
  tinyxml2::XMLElement* defaults = child(root, "default");
  child(defaults, "geom",
        {{"contype", std::to_string(kBodyContype)},
         {"conaffinity", std::to_string(kBodyConaffinity)},
         {"condim", "3"},
         {"friction", fmt(o.friction) + " 0.005 0.0001"},
         {"material", "body"}});
  child(defaults, "joint",
        {{"solreflimit", fmt(solref_time_constant(o, o.limit_time_constant_s)) + " 1"}});
  child(defaults, "site",
        {{"size", fmt(kMarkerSiteRadius)},
         {"group", std::to_string(kMarkerSiteGroup)},
         {"rgba", "0.1 0.3 1 1"}});
  child(defaults, "motor", {{"ctrllimited", "true"}});
}

/// A static box of the ground: half sizes, centre, pitch about +y (rad).
void add_ground_box(tinyxml2::XMLElement* world, const std::string& name, const Vector3d& half,
                    const Vector3d& centre, double pitch_rad) {
  child(world, "geom",
        {{"name", name},
         {"type", "box"},
         {"size", fmt(half)},
         {"pos", fmt(centre)},
         {"euler", "0 " + fmt(pitch_rad) + " 0"},
         {"material", "grid"},
         {"contype", std::to_string(kFloorContype)},
         {"conaffinity", std::to_string(kFloorConaffinity)}});
}

/// The terrain's boxes (Terrain): ramps as thin boxes pitched about +y whose top faces run from
/// the floor to the plateau; plateaus and steps as boxes standing on the floor.
void add_terrain(tinyxml2::XMLElement* world, const Terrain& t) {
  constexpr double kHalfWidth_m = 2.0, kRampHalfThickness_m = 0.1;
  if (t.kind == Terrain::Kind::kFlat) return;
  const bool hill = t.kind == Terrain::Kind::kHill;
  const double slope = t.slope_deg * kRadPerDeg;
  const double ramp = t.ramp_length_m(), height = t.plateau_height_m();
  const double x_plateau = t.start_m + ramp;
  add_ground_box(world, "terrain_plateau", Vector3d(t.plateau_m / 2, kHalfWidth_m, height / 2),
                 Vector3d(x_plateau + t.plateau_m / 2, 0, height / 2), 0);
  if (!hill) return;
  const double half_length = ramp / std::cos(slope) / 2;
  for (const double sign : {1.0, -1.0}) {
    // Up (sign +1) before the plateau, down after it: the top face's middle, less the half
    // thickness along its normal.
    const double x_mid = sign > 0 ? t.start_m + ramp / 2 : x_plateau + t.plateau_m + ramp / 2;
    const Vector3d normal(-sign * std::sin(slope), 0, std::cos(slope));
    const Vector3d centre = Vector3d(x_mid, 0, height / 2) - kRampHalfThickness_m * normal;
    add_ground_box(world, sign > 0 ? "terrain_ramp_up" : "terrain_ramp_down",
                   Vector3d(half_length, kHalfWidth_m, kRampHalfThickness_m), centre,
                   -sign * slope);
  }
}

/// <worldbody> with the light and the floor; the segments' bodies go in it.
tinyxml2::XMLElement* add_world(tinyxml2::XMLElement* root) {
  tinyxml2::XMLElement* world = child(root, "worldbody");
  child(world, "light",
        {{"name", "sun"},
         {"directional", "true"},
         {"pos", "0 0 5"},
         {"dir", "-0.3 0.3 -1"},
         {"diffuse", "0.8 0.8 0.8"}});
  child(world, "geom",
        {{"name", "floor"},
         {"type", "plane"},
         {"size", "50 50 0.05"},
         {"material", "grid"},
         {"contype", std::to_string(kFloorContype)},
         {"conaffinity", std::to_string(kFloorConaffinity)}});
  return world;
}

/// The segment's <inertial>: diagonal when the products of inertia vanish.
void add_inertial(tinyxml2::XMLElement* body, const Segment& s) {
  tinyxml2::XMLElement* inertial = child(body, "inertial");
  set(inertial, "pos", fmt(s.com_B));
  set(inertial, "mass", fmt(s.mass_kg));
  const Matrix3d& I = s.inertia_B;
  if (std::abs(I(0, 1)) < kOffDiagonalEpsilon && std::abs(I(0, 2)) < kOffDiagonalEpsilon &&
      std::abs(I(1, 2)) < kOffDiagonalEpsilon) {
    set(inertial, "diaginertia", fmt(Vector3d(I(0, 0), I(1, 1), I(2, 2))));
  } else {
    set(inertial, "fullinertia",
        fmt(Vector3d(I(0, 0), I(1, 1), I(2, 2))) + " " + fmt(Vector3d(I(0, 1), I(0, 2), I(1, 2))));
  }
}

/// The segment's joints, and one motor per actuated axis in `actuators` (a ball joint's three
/// motors turn it about x, y and z by their gears).
void add_joints(tinyxml2::XMLElement* body, const Segment& s, tinyxml2::XMLElement* actuators) {
  for (const Joint& j : s.joints) {
    tinyxml2::XMLElement* je = child(body, "joint");
    set(je, "name", j.name);
    set(je, "type", j.type == JointType::kBall ? "ball" : "hinge");
    set(je, "pos", fmt(j.anchor_B));
    if (j.type == JointType::kHinge) set(je, "axis", fmt(j.axis_B));
    set(je, "limited", "true");
    set(je, "range", fmt(j.min_rad) + " " + fmt(j.max_rad));
    set(je, "armature", fmt(j.armature));
    set(je, "damping", fmt(j.damping));
    const std::vector<std::string> names = actuator_names(j);
    for (size_t k = 0; k < names.size(); ++k) {
      tinyxml2::XMLElement* motor = child(actuators, "motor");
      set(motor, "name", names[k]);
      set(motor, "joint", j.name);
      if (j.type == JointType::kBall) {
        Eigen::Matrix<double, 6, 1> gear = Eigen::Matrix<double, 6, 1>::Zero();
        gear[static_cast<int>(k)] = 1;
        set(motor, "gear", fmt(gear.head<3>()) + " 0 0 0");
      }
      const double tau = j.tau_max_Nm[static_cast<int>(k)];
      set(motor, "ctrlrange", fmt(-tau) + " " + fmt(tau));
    }
  }
}

/// The segment's collision geoms, named after it (the second and later with _1, _2, ...).
void add_geoms(tinyxml2::XMLElement* body, const Segment& s) {
  int gi = 0;
  for (const Geom& g : s.geoms) {
    tinyxml2::XMLElement* ge = child(body, "geom");
    set(ge, "name", s.name + (gi ? "_" + std::to_string(gi) : std::string()));
    ++gi;
    switch (g.type) {
      case GeomType::kBox:
        set(ge, "type", "box");
        set(ge, "pos", fmt(g.center_B));
        set(ge, "size", fmt(g.half_extents));
        break;
      case GeomType::kSphere:
        set(ge, "type", "sphere");
        set(ge, "pos", fmt(g.center_B));
        set(ge, "size", fmt(g.radius));
        break;
      case GeomType::kCapsule:
        set(ge, "type", "capsule");
        set(ge, "fromto", fmt(g.from_B) + " " + fmt(g.to_B));
        set(ge, "size", fmt(g.radius));
        break;
    }
  }
}

/// The body of segment `s` in `parent_el` (relative to its parent's origin; the root with the
/// tracking camera and the free joint): inertial, joints (motors into `actuators`), geoms and
/// the character's marker sites on it.
tinyxml2::XMLElement* add_body(tinyxml2::XMLElement* parent_el, const Segment& s,
                               const Segment* parent, const std::vector<Marker>& markers,
                               tinyxml2::XMLElement* actuators) {
  tinyxml2::XMLElement* body = child(parent_el, "body");
  set(body, "name", s.name);
  const Vector3d pos = parent == nullptr ? s.origin_W : s.origin_W - parent->origin_W;
  set(body, "pos", fmt(pos));
  if (parent == nullptr) {
    // Follows the character's centre of mass, looking at it from its left-front.
    child(body, "camera",
          {{"name", "tracking"},
           {"mode", "trackcom"},
           {"pos", fmt(Vector3d(2.5, 2.5, 0.6))},
           {"xyaxes", "-1 1 0 -0.1 -0.1 1"}});
    child(body, "freejoint", {{"name", "root"}});
  }
  add_inertial(body, s);
  add_joints(body, s, actuators);
  add_geoms(body, s);
  for (const Marker& m : markers) {
    if (m.segment != s.name) continue;
    tinyxml2::XMLElement* site = child(body, "site");
    set(site, "name", "marker_" + m.name);
    set(site, "pos", fmt(m.position_B));
  }
  return body;
}

/// The muscles' paths (muscle_anatomy.h): sites on the segments' bodies, wrapping cylinders (no
/// mass: explicit <inertial>; no contacts) and one spatial tendon per muscle. The tendons carry
/// no actuator: biodyn's Hill model computes each force and applies it through the tendon's
/// Jacobian, and stock MuJoCo loads the file and draws the paths.
void add_muscles(tinyxml2::XMLElement* root,
                 const std::map<std::string, tinyxml2::XMLElement*>& bodies, const Character& c) {
  if (c.muscles.empty()) return;
  tinyxml2::XMLElement* tendons = child(root, "tendon");
  std::map<std::string, bool> wrap_written;
  // The wrapping cylinders ride on a massless, jointless child body per segment
  // ("<segment>_wraps", fixed at the segment's origin): geoms that never collide still cost
  // MuJoCo 2.2.2's collision pass per body they sit on (measured: +59% of mj_collision's
  // instructions with the cylinders on the segments, +15% on child bodies).
  std::map<std::string, tinyxml2::XMLElement*> wrap_bodies;
  const auto wrap_body = [&](const std::string& segment) {
    tinyxml2::XMLElement*& b = wrap_bodies[segment];
    if (b == nullptr) b = child(bodies.at(segment), "body", {{"name", segment + "_wraps"}});
    return b;
  };
  for (const MuscleDefinition& m : c.muscles) {
    tinyxml2::XMLElement* spatial =
        child(tendons, "spatial",
              {{"name", m.name}, {"width", fmt(kMusclePathWidth)}, {"rgba", "0.75 0.15 0.15 1"}});
    for (size_t i = 0; i < m.path.size(); ++i) {
      const std::string site = "muscle_" + m.name + "_" + std::to_string(i);
      child(bodies.at(m.path[i].segment), "site",
            {{"name", site}, {"pos", fmt(m.path[i].position_B)}, {"size", fmt(kMuscleSiteRadius)}});
      child(spatial, "site", {{"site", site}});
      for (const MuscleWrapCylinder& w : m.wraps) {
        if (w.after_point != static_cast<int>(i)) continue;
        const std::string geom = "wrap_" + w.name, side = "wrapside_" + m.name + "_" + w.name;
        if (!wrap_written[geom]) {
          wrap_written[geom] = true;
          child(wrap_body(w.segment), "geom",
                {{"name", geom},
                 {"type", "cylinder"},
                 {"fromto", fmt(w.center_B - w.half_length_m * w.axis_B) + " " +
                                fmt(w.center_B + w.half_length_m * w.axis_B)},
                 {"size", fmt(w.radius_m)},
                 {"contype", "0"},
                 {"conaffinity", "0"},
                 {"group", std::to_string(kWrapGeomGroup)},
                 {"rgba", "0.9 0.85 0.6 0.35"}});
        }
        tinyxml2::XMLElement* wrap = child(spatial, "geom", {{"geom", geom}});
        if (w.has_side) {
          child(bodies.at(w.segment), "site",
                {{"name", side}, {"pos", fmt(w.side_B)}, {"size", fmt(kMuscleSiteRadius)}});
          set(wrap, "sidesite", side);
        }
      }
    }
  }
}

}  // namespace

std::vector<std::string> actuator_names(const Joint& joint) {
  if (joint.type == JointType::kHinge) return {joint.name};
  return {joint.name + "_x", joint.name + "_y", joint.name + "_z"};
}

std::string to_mjcf(const Character& c, const PhysicsOptions& o) {
  tinyxml2::XMLDocument doc;
  tinyxml2::XMLElement* root = doc.NewElement("mujoco");
  doc.InsertEndChild(root);
  add_settings(root, c, o);
  add_assets(root);
  add_defaults(root, o);
  tinyxml2::XMLElement* world = add_world(root);
  add_terrain(world, o.terrain);

  // Segments come parents first: each body nests in its parent's.
  std::map<std::string, tinyxml2::XMLElement*> body_elements;
  std::map<std::string, const Segment*> by_name;
  for (const Segment& s : c.segments) by_name[s.name] = &s;
  tinyxml2::XMLElement* actuators = child(root, "actuator");
  for (const Segment& s : c.segments) {
    tinyxml2::XMLElement* parent_el = s.parent.empty() ? world : body_elements.at(s.parent);
    const Segment* parent = s.parent.empty() ? nullptr : by_name.at(s.parent);
    body_elements[s.name] = add_body(parent_el, s, parent, c.markers, actuators);
  }

  add_muscles(root, body_elements, c);

  // Foot-contact welds (paper §4.1), off until a controller switches one on at foot strike
  // and sets its pose from the foot's current pose (controllers/foot_contact.h).
  tinyxml2::XMLElement* equality = child(root, "equality");
  for (const char* side : {"l", "r"}) {
    const std::string foot = std::string("foot_") + side;
    if (!by_name.count(foot)) continue;
    child(equality, "weld",
          {{"name", std::string(kFootWeldPrefix) + side},
           {"body1", foot},
           {"active", "false"},
           {"solref", fmt(solref_time_constant(o, o.weld_time_constant_s)) + " 1"}});
  }

  tinyxml2::XMLPrinter printer;
  doc.Print(&printer);
  return std::string(
             "<!-- Generated by biodyn (models/src/mjcf.cc). Anthropometry: de Leva 1996; "
             "see models/data/ for every table and its source. -->\n") +
         printer.CStr();
}

std::string summary_json(const Character& c) {
  using nlohmann::json;
  const auto vec = [](const Vector3d& v) { return json::array({v.x(), v.y(), v.z()}); };
  json j;
  j["inputs"] = {{"height_m", c.spec.height_m},
                 {"mass_kg", c.spec.mass_kg},
                 {"sex", to_string(c.spec.sex)},
                 {"detail", to_string(c.spec.detail)}};
  json overrides = json::object();
  for (const auto& [name, o] : c.spec.overrides) {
    json entry = json::object();
    if (o.mass_kg) entry["mass_kg"] = *o.mass_kg;
    if (o.length_m) entry["length_m"] = *o.length_m;
    if (o.width_m) entry["width_m"] = *o.width_m;
    overrides[name] = entry;
  }
  j["inputs"]["overrides"] = overrides;
  j["total_mass_kg"] = c.total_mass_kg();
  j["standing_height_m"] = c.standing_height_m;
  j["lowest_point_m"] = c.lowest_point_m;
  j["actuated_dof"] = c.actuated_dof_count();
  j["dof"] = c.actuated_dof_count() + 6;
  j["torque_scale"] = c.torque_scale;
  j["torque_scale_rule"] =
      "tau_max = tau_paper * (mass / 82.2 kg) * (height / 1.799 m) (paper §5.1: proportional)";
  json segments = json::array();
  for (const Segment& s : c.segments) {
    json seg;
    seg["name"] = s.name;
    seg["parent"] = s.parent;
    seg["mass_kg"] = s.mass_kg;
    seg["mass_fraction"] = s.mass_kg / c.total_mass_kg();
    seg["table_mass_fraction"] = s.table_mass_fraction;
    seg["table"] = s.table_parts;
    seg["length_m"] = s.length_m;
    seg["origin_m"] = vec(s.origin_W);
    seg["com_m"] = vec(s.com_B);
    seg["com_frame"] = "body (origin at the proximal joint, axes x forward, y left, z up)";
    seg["inertia_kg_m2"] = {{"xx", s.inertia_B(0, 0)}, {"yy", s.inertia_B(1, 1)},
                            {"zz", s.inertia_B(2, 2)}, {"xy", s.inertia_B(0, 1)},
                            {"xz", s.inertia_B(0, 2)}, {"yz", s.inertia_B(1, 2)}};
    json joints = json::array();
    for (const Joint& jt : s.joints) {
      joints.push_back({{"name", jt.name},
                        {"type", jt.type == JointType::kBall ? "ball" : "hinge"},
                        {"axis", vec(jt.axis_B)},
                        {"range_deg", {jt.min_rad * 180 / kPi, jt.max_rad * 180 / kPi}},
                        {"tau_max_Nm", jt.type == JointType::kBall ? vec(jt.tau_max_Nm)
                                                                   : json(jt.tau_max_Nm.x())},
                        {"tau_source", jt.tau_source},
                        {"actuators", actuator_names(jt)}});
    }
    seg["joints"] = joints;
    segments.push_back(seg);
  }
  j["segments"] = segments;
  json markers = json::array();
  for (const Marker& m : c.markers) {
    markers.push_back(
        {{"name", m.name}, {"segment", m.segment}, {"position_m", vec(m.position_B)}});
  }
  j["markers"] = markers;
  if (!c.muscles.empty()) {
    json muscles = json::array();
    for (const MuscleDefinition& m : c.muscles) {
      json path = json::array();
      for (const MusclePathPoint& p : m.path)
        path.push_back({{"segment", p.segment}, {"position_m", vec(p.position_B)}});
      json wraps = json::array();
      for (const MuscleWrapCylinder& w : m.wraps)
        wraps.push_back({{"name", w.name}, {"segment", w.segment}, {"radius_m", w.radius_m}});
      muscles.push_back({{"name", m.name},
                         {"description", m.description},
                         {"compartments", m.compartments},
                         {"parameters_from", m.parameters_from},
                         {"max_isometric_force_N", m.max_isometric_force_N},
                         {"optimal_fiber_length_m", m.optimal_fiber_length_m},
                         {"tendon_slack_length_m", m.tendon_slack_length_m},
                         {"pennation_at_optimal_deg", m.pennation_at_optimal_rad * 180 / kPi},
                         {"tendon", m.tendon},
                         {"path_length_standing_m", m.path_length_m},
                         {"source_path_length_m", m.source_path_length_m},
                         {"path", path},
                         {"wraps", wraps}});
    }
    j["muscles"] = muscles;
    j["muscle_source"] = muscle_table_source();
    j["muscle_scaling_rule"] =
        "path points by segment length ratios; l_opt and l_slack by path length / source path "
        "length (standing pose); F_max by body mass / 75.337 kg (README, Muscles)";
  }
  return j.dump(2) + "\n";
}

double Terrain::ramp_length_m() const { return kind == Kind::kHill ? ramp_m : 0.0; }

double Terrain::plateau_height_m() const {
  switch (kind) {
    case Kind::kHill:
      return ramp_m * std::tan(slope_deg * kRadPerDeg);
    case Kind::kSteps:
      return step_m;
    case Kind::kFlat:
      break;
  }
  return 0;
}

double Terrain::height_at(double x) const {
  if (kind == Kind::kFlat) return 0;
  const double ramp = ramp_length_m(), height = plateau_height_m();
  const double x_top = start_m + ramp, x_down = x_top + plateau_m;
  if (x < start_m || x > x_down + ramp) return 0;
  if (x < x_top) return height * (x - start_m) / ramp;  // (a step has no ramp: x_top = start)
  if (x <= x_down) return height;
  return height * (x_down + ramp - x) / ramp;
}

void Terrain::validate() const {
  const auto check = [](bool ok, const std::string& field, const std::string& rule, double v) {
    if (!ok) {
      std::ostringstream s;
      s << "terrain " << field << ": " << rule << ", got " << v;
      throw sim::InvalidArgument(s.str());
    }
  };
  check(start_m >= 1 && start_m <= 100, "start", "must be in [1, 100] m", start_m);
  check(slope_deg > 0 && slope_deg <= 20, "slope", "must be in (0, 20] deg", slope_deg);
  check(ramp_m > 0 && ramp_m <= 20, "ramp", "must be in (0, 20] m", ramp_m);
  check(step_m > 0 && step_m <= 0.3, "step", "must be in (0, 0.3] m", step_m);
  check(plateau_m >= 0.5 && plateau_m <= 50, "plateau", "must be in [0.5, 50] m", plateau_m);
}

Terrain::Kind parse_terrain_kind(const std::string& text, const std::string& field) {
  if (text == "flat") return Terrain::Kind::kFlat;
  if (text == "hill") return Terrain::Kind::kHill;
  if (text == "steps") return Terrain::Kind::kSteps;
  throw sim::InvalidArgument(field + ": expected flat, hill or steps, got '" + text + "'");
}

}  // namespace biodyn::models
