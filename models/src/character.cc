#include "biodyn/models/character.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <set>
#include <sstream>
#include <tuple>

#include "biodyn/models/tables.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/units.h"

namespace biodyn::models {
namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;
using sim::InvalidArgument;

// Capsule radii never exceed this share of the capsule's length (keeps short, heavy segments
// such as the hand of a 150 kg body from turning into spheres).
constexpr double kMaxRadiusPerLength = 0.3;
// Trunk boxes: depth derived from mass/(density*width*length), kept within these bounds (m per
// m of height) so extreme masses still give a plausible shape.
constexpr double kMinTrunkDepthPerHeight = 0.06;
constexpr double kMaxTrunkDepthPerHeight = 0.2;

const char* kSides[] = {"l", "r"};
double side_sign(const std::string& side) { return side == "l" ? 1.0 : -1.0; }

/// Splits "thigh_l" into ("thigh", "l"); a name without a side gives (name, "").
std::pair<std::string, std::string> split_side(const std::string& name) {
  const size_t us = name.rfind('_');
  if (us != std::string::npos && (name.substr(us + 1) == "l" || name.substr(us + 1) == "r")) {
    return {name.substr(0, us), name.substr(us + 1)};
  }
  return {name, ""};
}

/// Mirror a left-side axis to the right side: x and z flip, y stays (sagittal symmetry).
Vector3d mirror(const Vector3d& axis_left, double sign) {
  return sign > 0 ? axis_left : Vector3d(-axis_left.x(), axis_left.y(), -axis_left.z());
}

/// A piece of the full-detail body, laid out in the world frame of the standing pose.
struct Part {
  std::string name;                        // full-detail segment name, e.g. "thigh_l"
  std::string kind;                        // name without side, e.g. "thigh"
  std::string side;                        // "l", "r" or ""
  std::string table_parts;                 // human-readable provenance for the summary
  double table_fraction = 0;               // share of body mass by the tables
  double length = 0;                       // m
  double mass = 0;                         // kg
  Vector3d proximal_W = Vector3d::Zero();  // joint to the parent (body origin)
  Vector3d distal_W = Vector3d::Zero();    // distal landmark
  Vector3d com_W = Vector3d::Zero();
  Matrix3d inertia = Matrix3d::Zero();      // about com, world axes
  std::vector<Geom> geoms_W;                // centres/endpoints in world coordinates
  Vector3d half_extent = Vector3d::Zero();  // surface distance along x, y, z (markers)
};

/// Detail-level segment: the body in the MJCF, made of one or more parts.
struct SegmentPlan {
  std::string name;
  std::vector<std::string> parts;
};

std::vector<std::string> full_part_names() {
  std::vector<std::string> names = {"pelvis", "lumbar", "thorax", "neck", "head"};
  for (const char* s : kSides) {
    for (const char* k : {"clavicle", "upper_arm", "forearm", "hand"}) {
      names.push_back(std::string(k) + "_" + s);
    }
  }
  for (const char* s : kSides) {
    for (const char* k : {"thigh", "shank", "foot", "toes"})
      names.push_back(std::string(k) + "_" + s);
  }
  return names;
}

std::vector<SegmentPlan> plan_segments(Detail detail) {
  std::vector<SegmentPlan> plan;
  if (detail == Detail::kFull) {
    for (const std::string& n : full_part_names()) plan.push_back({n, {n}});
    return plan;
  }
  // Paper §5.1 gait model: the trunk carries head, arms and the upper spine as one rigid body.
  plan.push_back({"pelvis", {"pelvis"}});
  SegmentPlan trunk{"trunk", {"lumbar", "thorax", "neck", "head"}};
  for (const char* s : kSides) {
    for (const char* k : {"clavicle", "upper_arm", "forearm", "hand"}) {
      trunk.parts.push_back(std::string(k) + "_" + s);
    }
  }
  plan.push_back(trunk);
  for (const char* s : kSides) {
    for (const char* k : {"thigh", "shank", "foot", "toes"}) {
      const std::string n = std::string(k) + "_" + s;
      plan.push_back({n, {n}});
    }
  }
  return plan;
}

std::string parent_of(const std::string& part, Detail detail) {
  static const std::map<std::string, std::string> kParentKind = {
      {"lumbar", "pelvis"},     {"thorax", "lumbar"},   {"neck", "thorax"},
      {"head", "neck"},         {"clavicle", "thorax"}, {"upper_arm", "clavicle"},
      {"forearm", "upper_arm"}, {"hand", "forearm"},    {"thigh", "pelvis"},
      {"shank", "thigh"},       {"foot", "shank"},      {"toes", "foot"}};
  if (part == "pelvis") return "";
  if (detail == Detail::kGait && part == "trunk") return "pelvis";
  const auto [kind, side] = split_side(part);
  const std::string& parent_kind = kParentKind.at(kind);
  const bool parent_central = parent_kind == "pelvis" || parent_kind == "lumbar" ||
                              parent_kind == "thorax" || parent_kind == "neck";
  return parent_central ? parent_kind : parent_kind + "_" + side;
}

Matrix3d diag_inertia(double mass, double rx, double ry, double rz) {
  Matrix3d I = Matrix3d::Zero();
  I(0, 0) = mass * rx * rx;
  I(1, 1) = mass * ry * ry;
  I(2, 2) = mass * rz * rz;
  return I;
}

/// Inertia of `mass` about `com_total` from a part's inertia about its own com (parallel axis).
Matrix3d shifted(const Matrix3d& I, double mass, const Vector3d& d) {
  return I + mass * (d.squaredNorm() * Matrix3d::Identity() - d * d.transpose());
}

double capsule_radius(double mass, double length, double density) {
  const double r = std::sqrt(mass / (density * kPi * length));
  return std::min(r, kMaxRadiusPerLength * length);
}

Geom capsule_between(const Vector3d& a, const Vector3d& b, double r) {
  // Endpoints inset by r so the capsule spans exactly a..b.
  const Vector3d dir = (b - a).normalized();
  Geom g;
  g.type = GeomType::kCapsule;
  g.from_B = a + r * dir;
  g.to_B = b - r * dir;
  g.radius = r;
  return g;
}

Geom box(const Vector3d& lo, const Vector3d& hi) {
  Geom g;
  g.type = GeomType::kBox;
  g.center_B = 0.5 * (lo + hi);
  g.half_extents = 0.5 * (hi - lo);
  return g;
}

void geom_z_range(const Geom& g, double* lo, double* hi) {
  switch (g.type) {
    case GeomType::kBox:
      *lo = g.center_B.z() - g.half_extents.z();
      *hi = g.center_B.z() + g.half_extents.z();
      return;
    case GeomType::kSphere:
      *lo = g.center_B.z() - g.radius;
      *hi = g.center_B.z() + g.radius;
      return;
    case GeomType::kCapsule:
      *lo = std::min(g.from_B.z(), g.to_B.z()) - g.radius;
      *hi = std::max(g.from_B.z(), g.to_B.z()) + g.radius;
      return;
  }
}

std::string names_list(const std::vector<SegmentPlan>& plan) {
  std::string s;
  for (const SegmentPlan& p : plan) s += (s.empty() ? "" : ", ") + p.name;
  return s;
}

void check_range(const char* field, double value, double lo, double hi, const char* unit) {
  if (!std::isfinite(value) || value < lo || value > hi) {
    std::ostringstream msg;
    msg << field << ": must be within [" << lo << ", " << hi << "] " << unit << ", got " << value;
    throw InvalidArgument(msg.str());
  }
}

}  // namespace

double torque_scale(const CharacterSpec& spec) {
  return (spec.mass_kg / kPaperMass_kg) * (spec.height_m / kPaperHeight_m) * spec.tau_max_factor;
}

void CharacterSpec::validate() const {
  check_range("height", height_m, kMinHeight, kMaxHeight, "m");
  check_range("mass", mass_kg, kMinMass, kMaxMass, "kg");
  check_range("tau_max_factor", tau_max_factor, 1e-3, 10.0, "");
  for (const auto& [name, o] : overrides) {
    if (o.mass_kg && !(std::isfinite(*o.mass_kg) && *o.mass_kg > 0)) {
      throw InvalidArgument("overrides." + name + ".mass_kg: must be > 0, got " +
                            std::to_string(*o.mass_kg));
    }
    if (o.length_m && !(std::isfinite(*o.length_m) && *o.length_m > 0 && *o.length_m < 1.5)) {
      throw InvalidArgument("overrides." + name + ".length_m: must be within (0, 1.5) m, got " +
                            std::to_string(*o.length_m));
    }
    if (o.width_m && name != "pelvis") {
      throw InvalidArgument("overrides." + name +
                            ".width_m: only the pelvis has a width (the "
                            "distance between the hip joint centres)");
    }
    if (o.width_m && !(std::isfinite(*o.width_m) && *o.width_m > 0 && *o.width_m < 0.6)) {
      throw InvalidArgument("overrides." + name + ".width_m: must be within (0, 0.6) m, got " +
                            std::to_string(*o.width_m));
    }
  }
  std::set<std::string> names;
  for (const MarkerPlacement& m : markers) {
    if (m.name.empty()) throw InvalidArgument("markers: a marker has an empty name");
    if (!names.insert(m.name).second) {
      throw InvalidArgument("markers: names must be unique, got '" + m.name + "' twice");
    }
    for (double v : {m.along, m.ant, m.lat, m.sup}) {
      if (!std::isfinite(v)) {
        throw InvalidArgument("markers." + m.name + ": along/ant/lat/sup must be finite numbers");
      }
    }
  }
}

double Character::total_mass_kg() const {
  double m = 0;
  for (const Segment& s : segments) m += s.mass_kg;
  return m;
}

int Character::actuated_dof_count() const {
  int n = 0;
  for (const Segment& s : segments) {
    for (const Joint& j : s.joints) n += j.type == JointType::kBall ? 3 : 1;
  }
  return n;
}

const Segment* Character::find(const std::string& name) const {
  for (const Segment& s : segments) {
    if (s.name == name) return &s;
  }
  return nullptr;
}

namespace {

/// What the build stages share for one character: the tables, the inputs and the parts.
struct Build {
  Build(const Tables& tables, const CharacterSpec& character) : T(tables), spec(character) {}
  const Tables& T;
  const CharacterSpec& spec;
  double H = 0;        // m, standing height
  double ankle_h = 0;  // m, ankle above the sole (Winter)
  double density = 0;  // kg/m^3, only to size collision geoms
  std::map<std::string, Part> parts;

  const DeLevaRow& row(const char* segment) const { return T.de_leva_row(segment, spec.sex); }
  /// de Leva's reference length scaled to this height, m.
  double table_length(const char* segment) const {
    return row(segment).length_mm / 1000.0 / de_leva_reference_height_m(spec.sex) * H;
  }
  double radius_of(const std::string& part) const {
    return capsule_radius(parts.at(part).mass, parts.at(part).length, density);
  }
};

/// Mass shares of every full-detail part (de Leva Table 4, normalised to sum to exactly 1: the
/// female column sums to 99.99% by rounding) and their provenance.
void assign_mass_shares(Build& b) {
  const char* kCentral[] = {"head", "upper_trunk", "middle_trunk", "lower_trunk"};
  const char* kBilateral[] = {"upper_arm", "forearm", "hand", "thigh", "shank", "foot"};
  double pct_sum = 0;
  for (const char* seg : kCentral) pct_sum += b.row(seg).mass_pct;
  for (const char* seg : kBilateral) pct_sum += 2 * b.row(seg).mass_pct;
  const auto frac = [&](const char* seg) { return b.row(seg).mass_pct / pct_sum; };
  const double neck = b.T.proportion("neck_mass_share");
  const double girdle = b.T.proportion("shoulder_girdle_mass_share");
  const double toe = b.T.proportion("toe_mass_share");
  const auto set = [&](const std::string& part, double fraction, const std::string& what) {
    b.parts.at(part).table_fraction = fraction;
    b.parts.at(part).table_parts = what;
  };
  set("pelvis", frac("lower_trunk"), "de Leva lower_trunk (OMPH-MIDH)");
  set("lumbar", frac("middle_trunk"), "de Leva middle_trunk (XYPH-OMPH)");
  set("thorax", frac("upper_trunk") * (1 - 2 * girdle),
      "de Leva upper_trunk less both shoulder girdles");
  set("neck", frac("head") * neck, "share neck_mass_share of de Leva head");
  set("head", frac("head") * (1 - neck), "de Leva head less the neck share");
  for (const char* s : kSides) {
    const std::string sd = std::string("_") + s;
    set("clavicle" + sd, frac("upper_trunk") * girdle,
        "share shoulder_girdle_mass_share of de Leva upper_trunk");
    for (const char* seg : {"upper_arm", "forearm", "hand", "thigh", "shank"}) {
      set(seg + sd, frac(seg), std::string("de Leva ") + seg);
    }
    set("foot" + sd, frac("foot") * (1 - toe), "de Leva foot less the toe share");
    set("toes" + sd, frac("foot") * toe, "share toe_mass_share of de Leva foot");
  }
}

/// Table lengths of every part, m. The neck takes what is left of the stature, so the standing
/// height is exactly H; the clavicle is derived from the shoulder breadth in lay_out_arms.
void assign_table_lengths(Build& b) {
  std::map<std::string, Part>& p = b.parts;
  p.at("pelvis").length = b.table_length("lower_trunk");
  p.at("lumbar").length = b.table_length("middle_trunk");
  p.at("thorax").length = b.table_length("upper_trunk");
  p.at("head").length = b.table_length("head");
  p.at("neck").length =
      b.H - (b.ankle_h + b.table_length("shank") + b.table_length("thigh") + p.at("pelvis").length +
             p.at("lumbar").length + p.at("thorax").length + p.at("head").length);
  if (!(p.at("neck").length > 0.01 * b.H)) {
    throw sim::Error("tables: segment lengths leave no room for the neck (" +
                     std::to_string(p.at("neck").length) + " m)");
  }
  const double foot_total = b.table_length("foot");
  const double toe_share = b.T.proportion("toe_length_share");
  for (const char* s : kSides) {
    const std::string sd = std::string("_") + s;
    for (const char* seg : {"upper_arm", "forearm", "hand", "thigh", "shank"}) {
      p.at(seg + sd).length = b.table_length(seg);
    }
    p.at("foot" + sd).length = foot_total * (1 - toe_share);
    p.at("toes" + sd).length = foot_total * toe_share;
  }
}

/// The override of each segment of the plan: exact names, and names without a side for both
/// sides (a side-specific entry wins).
std::map<std::string, SegmentOverride> resolve_overrides(const CharacterSpec& spec,
                                                         const std::vector<SegmentPlan>& plan) {
  check_override_names(spec.overrides, spec.detail, "overrides");
  std::map<std::string, SegmentOverride> resolved;
  for (const auto& [key, o] : spec.overrides) {
    for (const SegmentPlan& p : plan) {
      if (p.name == key) {
        resolved[key] = o;
      } else if ((p.name == key + "_l" || p.name == key + "_r") && !spec.overrides.count(p.name)) {
        resolved[p.name] = o;
      }
    }
  }
  return resolved;
}

/// A length override scales every part of the segment (the gait trunk: lumbar to head; the
/// clavicle's length is taken as given).
void apply_length_overrides(Build& b, const std::vector<SegmentPlan>& plan,
                            const std::map<std::string, SegmentOverride>& overrides) {
  for (const SegmentPlan& p : plan) {
    const auto it = overrides.find(p.name);
    if (it == overrides.end() || !it->second.length_m) continue;
    if (b.parts.at(p.parts.front()).kind == "clavicle") {
      b.parts.at(p.name).length = *it->second.length_m;
      continue;
    }
    std::vector<std::string> chain;
    double current = 0;
    for (const std::string& part : p.parts) {
      const std::string& kind = b.parts.at(part).kind;
      const bool spine = kind == "lumbar" || kind == "thorax" || kind == "neck" || kind == "head";
      if (p.parts.size() > 1 && !spine) continue;  // the fused arms keep their lengths
      chain.push_back(part);
      current += b.parts.at(part).length;
    }
    const double factor = *it->second.length_m / current;
    for (const std::string& part : chain) b.parts.at(part).length *= factor;
  }
}

/// Masses: overridden segments keep their value; the rest share the remainder in the tables'
/// proportions; within a fused segment the parts keep their table proportions.
void distribute_mass(Build& b, const std::vector<SegmentPlan>& plan,
                     const std::map<std::string, SegmentOverride>& overrides) {
  const double M = b.spec.mass_kg;
  const auto given = [&](const std::string& seg) -> const std::optional<double>& {
    static const std::optional<double> kNone;
    const auto it = overrides.find(seg);
    return it == overrides.end() ? kNone : it->second.mass_kg;
  };
  double fixed_mass = 0, free_fraction = 0;
  std::map<std::string, double> seg_fraction;
  for (const SegmentPlan& p : plan) {
    for (const std::string& part : p.parts) seg_fraction[p.name] += b.parts.at(part).table_fraction;
    if (given(p.name)) {
      fixed_mass += *given(p.name);
    } else {
      free_fraction += seg_fraction[p.name];
    }
  }
  std::ostringstream msg;
  if (free_fraction == 0 && std::abs(fixed_mass - M) > 1e-9) {
    msg << "overrides: every segment's mass is given and they sum to " << fixed_mass
        << " kg, not the body mass " << M << " kg";
    throw InvalidArgument(msg.str());
  }
  if (free_fraction > 0 && (fixed_mass >= M || M - fixed_mass < 1e-3 * M)) {
    msg << "overrides: segment masses sum to " << fixed_mass
        << " kg, which leaves nothing for the other segments of a " << M << " kg body";
    throw InvalidArgument(msg.str());
  }
  for (const SegmentPlan& p : plan) {
    const double seg_mass =
        given(p.name) ? *given(p.name) : (M - fixed_mass) * seg_fraction[p.name] / free_fraction;
    for (const std::string& part : p.parts) {
      Part& q = b.parts.at(part);
      q.mass = seg_mass * q.table_fraction / seg_fraction[p.name];
    }
  }
}

/// A limb part hanging straight down from `top`: capsule, de Leva CoM and radii.
void lay_out_limb(Build& b, const std::string& name, const Vector3d& top, const DeLevaRow& r) {
  Part& p = b.parts.at(name);
  const Vector3d down(0, 0, -1);
  p.proximal_W = top;
  p.distal_W = top + p.length * down;
  p.com_W = top + r.com_pct / 100.0 * p.length * down;
  p.inertia = diag_inertia(p.mass, r.r_sag_pct / 100 * p.length, r.r_trans_pct / 100 * p.length,
                           r.r_long_pct / 100 * p.length);
  const double rad = b.radius_of(name);
  p.geoms_W.push_back(capsule_between(p.proximal_W, p.distal_W, rad));
  p.half_extent = Vector3d::Constant(rad);
}

/// Legs from the hip joint centres down; the hips sit as high as the longer leg needs, so that
/// leg's sole is on the floor. Returns the hip height (m).
double lay_out_legs(Build& b) {
  const auto pelvis = b.spec.overrides.find("pelvis");
  const double hjc_half = pelvis != b.spec.overrides.end() && pelvis->second.width_m
                              ? 0.5 * *pelvis->second.width_m
                              : 0.5 * b.T.proportion("hip_joint_separation") * b.H;
  double z_hip = 0;
  for (const char* s : kSides) {
    const std::string sd = std::string("_") + s;
    z_hip = std::max(z_hip,
                     b.ankle_h + b.parts.at("shank" + sd).length + b.parts.at("thigh" + sd).length);
  }
  const double foot_w = b.T.proportion("foot_width") * b.H;
  const double foot_thick = b.T.proportion("foot_thickness") * b.ankle_h;
  const double toe_thick = b.T.proportion("toe_thickness") * b.ankle_h;
  const DeLevaRow& fr = b.row("foot");
  for (const char* s : kSides) {
    const std::string sd = std::string("_") + s;
    lay_out_limb(b, "thigh" + sd, Vector3d(0, side_sign(s) * hjc_half, z_hip), b.row("thigh"));
    lay_out_limb(b, "shank" + sd, b.parts.at("thigh" + sd).distal_W, b.row("shank"));
    const Vector3d ankle = b.parts.at("shank" + sd).distal_W;
    const double sole_z = ankle.z() - b.ankle_h;
    // Foot: heel -> MTP (box), toes: MTP -> tip (box); de Leva's CoM is for the whole foot.
    Part& foot = b.parts.at("foot" + sd);
    Part& toes = b.parts.at("toes" + sd);
    const double x_heel = -b.T.proportion("heel_to_ankle") * (foot.length + toes.length);
    const double x_mtp = x_heel + foot.length, x_tip = x_mtp + toes.length;
    foot.proximal_W = ankle;
    foot.distal_W = Vector3d(x_tip, ankle.y(), sole_z);
    toes.proximal_W = Vector3d(x_mtp, ankle.y(), sole_z + 0.5 * toe_thick);
    toes.distal_W = Vector3d(x_tip, ankle.y(), sole_z + 0.5 * toe_thick);
    foot.geoms_W.push_back(box(Vector3d(x_heel, ankle.y() - foot_w / 2, sole_z),
                               Vector3d(x_mtp, ankle.y() + foot_w / 2, sole_z + foot_thick)));
    toes.geoms_W.push_back(box(Vector3d(x_mtp, ankle.y() - foot_w / 2, sole_z),
                               Vector3d(x_tip, ankle.y() + foot_w / 2, sole_z + toe_thick)));
    foot.half_extent = Vector3d(0.5 * foot.length, foot_w / 2, foot_thick);  // z: sole to dorsum
    toes.half_extent = Vector3d(0.5 * toes.length, foot_w / 2, toe_thick);
    const Vector3d com_whole(x_heel + fr.com_pct / 100 * (foot.length + toes.length), ankle.y(),
                             sole_z + 0.5 * foot_thick);
    toes.com_W = Vector3d(0.5 * (x_mtp + x_tip), ankle.y(), sole_z + 0.5 * toe_thick);
    foot.com_W = ((foot.mass + toes.mass) * com_whole - toes.mass * toes.com_W) / foot.mass;
    // Foot axes: longitudinal = x (heel->toe), sagittal column about y, transverse about z.
    for (Part* q : {&foot, &toes}) {
      q->inertia = diag_inertia(q->mass, fr.r_long_pct / 100 * q->length,
                                fr.r_sag_pct / 100 * q->length, fr.r_trans_pct / 100 * q->length);
    }
  }
  return z_hip;
}

/// Pelvis, lumbar and thorax boxes, neck capsule and head sphere, stacked from the hips.
/// de Leva's trunk and head CoM are measured from the cranial end.
void lay_out_spine(Build& b, double z_hip) {
  const auto trunk_part = [&](const std::string& n, double z_bottom, const DeLevaRow& r,
                              double width) {
    Part& p = b.parts.at(n);
    p.proximal_W = Vector3d(0, 0, z_bottom);
    p.distal_W = Vector3d(0, 0, z_bottom + p.length);
    p.com_W = Vector3d(0, 0, z_bottom + p.length * (1 - r.com_pct / 100));
    p.inertia = diag_inertia(p.mass, r.r_sag_pct / 100 * p.length, r.r_trans_pct / 100 * p.length,
                             r.r_long_pct / 100 * p.length);
    const double depth = std::clamp(p.mass / (b.density * width * p.length),
                                    kMinTrunkDepthPerHeight * b.H, kMaxTrunkDepthPerHeight * b.H);
    p.geoms_W.push_back(box(Vector3d(-depth / 2, -width / 2, z_bottom),
                            Vector3d(depth / 2, width / 2, z_bottom + p.length)));
    p.half_extent = Vector3d(depth / 2, width / 2, p.length / 2);
  };
  const double hip_w = b.T.proportion("hip_width") * b.H;
  const double chest_w = b.T.proportion("chest_width") * b.H;
  trunk_part("pelvis", z_hip, b.row("lower_trunk"), hip_w);
  trunk_part("lumbar", b.parts.at("pelvis").distal_W.z(), b.row("middle_trunk"),
             0.5 * (hip_w + chest_w));
  trunk_part("thorax", b.parts.at("lumbar").distal_W.z(), b.row("upper_trunk"), chest_w);

  Part& neck = b.parts.at("neck");
  neck.proximal_W = b.parts.at("thorax").distal_W;  // suprasternale
  neck.distal_W = neck.proximal_W + Vector3d(0, 0, neck.length);
  neck.com_W = 0.5 * (neck.proximal_W + neck.distal_W);
  const double r = b.radius_of("neck");
  // Solid cylinder (no table gives the neck alone).
  const double I_perp = neck.mass * (3 * r * r + neck.length * neck.length) / 12;
  neck.inertia = Vector3d(I_perp, I_perp, 0.5 * neck.mass * r * r).asDiagonal();
  neck.geoms_W.push_back(capsule_between(neck.proximal_W, neck.distal_W, r));
  neck.half_extent = Vector3d::Constant(r);

  Part& head = b.parts.at("head");
  const DeLevaRow& hr = b.row("head");
  head.proximal_W = neck.distal_W;                                // gonion level
  head.distal_W = head.proximal_W + Vector3d(0, 0, head.length);  // vertex
  head.com_W = head.distal_W - Vector3d(0, 0, hr.com_pct / 100 * head.length);
  head.inertia =
      diag_inertia(head.mass, hr.r_sag_pct / 100 * head.length, hr.r_trans_pct / 100 * head.length,
                   hr.r_long_pct / 100 * head.length);
  Geom sphere;
  sphere.type = GeomType::kSphere;
  sphere.radius = 0.5 * head.length;
  sphere.center_B = head.distal_W - Vector3d(0, 0, sphere.radius);
  head.geoms_W.push_back(sphere);
  head.half_extent = Vector3d::Constant(sphere.radius);
}

/// Shoulder girdles and arms hanging beside the trunk in the anatomical position (palms
/// forward).
void lay_out_arms(Build& b) {
  const double z_supra = b.parts.at("thorax").distal_W.z();
  for (const char* s : kSides) {
    const std::string sd = std::string("_") + s;
    const double sign = side_sign(s);
    Part& clav = b.parts.at("clavicle" + sd);
    const double r_ua = b.radius_of("upper_arm" + sd);
    const double sc_y = b.T.proportion("sternoclavicular_offset") * b.H;
    const double gh_y = clav.length > 0 ? sc_y + clav.length  // overridden
                                        : 0.5 * b.T.proportion("shoulder_width") * b.H - r_ua;
    clav.length = gh_y - sc_y;
    const double gh_z = z_supra - b.T.proportion("shoulder_joint_drop") * b.H;
    clav.proximal_W = Vector3d(0, sign * sc_y, z_supra);
    clav.distal_W = Vector3d(0, sign * gh_y, gh_z);
    clav.com_W = 0.5 * (clav.proximal_W + clav.distal_W);
    const double rc = std::min(0.5 * r_ua, kMaxRadiusPerLength * clav.length);
    // Thin rod along y (clavicle + scapula lumped; no table gives them).
    const double I_perp = clav.mass * (3 * rc * rc + clav.length * clav.length) / 12;
    clav.inertia = Vector3d(I_perp, 0.5 * clav.mass * rc * rc, I_perp).asDiagonal();
    clav.geoms_W.push_back(capsule_between(clav.proximal_W, clav.distal_W, rc));
    clav.half_extent = Vector3d::Constant(rc);
    lay_out_limb(b, "upper_arm" + sd, clav.distal_W, b.row("upper_arm"));
    lay_out_limb(b, "forearm" + sd, b.parts.at("upper_arm" + sd).distal_W, b.row("forearm"));
    lay_out_limb(b, "hand" + sd, b.parts.at("forearm" + sd).distal_W, b.row("hand"));
  }
}

/// A joint from joints.csv at `anchor_W` (world; made body-relative on assembly). Axes are
/// given for the left side and mirrored for the right.
Joint make_joint(const Tables& T, double torque_scale, const std::string& dof,
                 const std::string& side, const Vector3d& anchor_W, const Vector3d& axis_left) {
  const JointRow& jr = T.joint(dof);
  Joint j;
  j.name = side.empty() ? dof : dof + "_" + side;
  j.type = jr.type;
  j.anchor_B = anchor_W;
  j.axis_B = side.empty() ? axis_left : mirror(axis_left, side_sign(side));
  j.min_rad = jr.min_deg * kRadPerDeg;
  j.max_rad = jr.max_deg * kRadPerDeg;
  j.armature = jr.armature;
  j.damping = jr.damping;
  j.tau_max_Nm = Vector3d::Constant(jr.tau_ref_Nm * torque_scale);
  j.tau_source = jr.tau_source;
  return j;
}

/// The joints of every full-detail part, keyed by part name (sign conventions: joints.csv).
std::map<std::string, std::vector<Joint>> make_joints(const Build& b, double torque_scale) {
  const Vector3d X = Vector3d::UnitX(), Y = Vector3d::UnitY(), Z = Vector3d::UnitZ();
  const auto at = [&](const std::string& part) { return b.parts.at(part).proximal_W; };
  const auto J = [&](const std::string& dof, const std::string& side, const Vector3d& anchor,
                     const Vector3d& axis) {
    return make_joint(b.T, torque_scale, dof, side, anchor, axis);
  };
  std::map<std::string, std::vector<Joint>> joints;
  joints["lumbar"] = {J("lumbar_flexion", "", at("lumbar"), Y),
                      J("lumbar_bending", "", at("lumbar"), -X)};
  joints["thorax"] = {J("thorax_flexion", "", at("thorax"), Y),
                      J("thorax_bending", "", at("thorax"), -X)};
  joints["neck"] = {J("neck_flexion", "", at("neck"), Y)};
  joints["head"] = {J("head", "", at("head"), Z)};
  for (const char* s : kSides) {
    const std::string sd = std::string("_") + s;
    joints["clavicle" + sd] = {J("clavicle_elevation", s, at("clavicle" + sd), X),
                               J("clavicle_protraction", s, at("clavicle" + sd), -Z)};
    joints["upper_arm" + sd] = {J("shoulder", s, at("upper_arm" + sd), Z)};
    joints["forearm" + sd] = {J("elbow_flexion", s, at("forearm" + sd), -Y),
                              J("forearm_pronation", s, at("forearm" + sd), -Z)};
    joints["hand" + sd] = {J("wrist_flexion", s, at("hand" + sd), -Y),
                           J("wrist_deviation", s, at("hand" + sd), X)};
    joints["thigh" + sd] = {J("hip", s, at("thigh" + sd), Z)};
    joints["shank" + sd] = {J("knee_flexion", s, at("shank" + sd), Y)};
    joints["foot" + sd] = {J("ankle_dorsiflexion", s, at("foot" + sd), -Y),
                           J("ankle_inversion", s, at("foot" + sd), -X)};
    joints["toes" + sd] = {J("toe_dorsiflexion", s, at("toes" + sd), -Y)};
  }
  return joints;
}

/// One body of the MJCF from its parts (several for the fused gait trunk), in its body frame.
Segment assemble_segment(const Build& b, const SegmentPlan& plan,
                         const std::map<std::string, std::vector<Joint>>& joints,
                         double torque_scale) {
  Segment seg;
  seg.name = plan.name;
  seg.parent = parent_of(plan.name, b.spec.detail);
  const Part& first = b.parts.at(plan.parts.front());
  seg.origin_W = first.proximal_W;
  Vector3d weighted = Vector3d::Zero();
  for (const std::string& n : plan.parts) {
    const Part& part = b.parts.at(n);
    seg.mass_kg += part.mass;
    weighted += part.mass * part.com_W;
    seg.table_mass_fraction += part.table_fraction;
  }
  const Vector3d com_W = weighted / seg.mass_kg;
  seg.com_B = com_W - seg.origin_W;
  for (const std::string& n : plan.parts) {
    const Part& part = b.parts.at(n);
    seg.inertia_B += shifted(part.inertia, part.mass, part.com_W - com_W);
    for (Geom g : part.geoms_W) {
      g.center_B -= seg.origin_W;
      g.from_B -= seg.origin_W;
      g.to_B -= seg.origin_W;
      seg.geoms.push_back(g);
    }
  }
  if (plan.parts.size() == 1) {
    seg.length_m = first.length;
    seg.table_parts = first.table_parts;
    const auto it = joints.find(first.name);  // the root (pelvis) has none: a free joint
    if (it != joints.end()) {
      for (Joint j : it->second) {
        j.anchor_B -= seg.origin_W;
        seg.joints.push_back(j);
      }
    }
  } else {  // gait trunk: OMPH to vertex; 2 DOF as the paper's TrunkJoint (Table 2)
    seg.length_m = b.parts.at("head").distal_W.z() - seg.origin_W.z();
    seg.table_parts = "de Leva head + upper_trunk + middle_trunk + both arms (fused)";
    seg.joints = {
        make_joint(b.T, torque_scale, "trunk_flexion", "", Vector3d::Zero(), Vector3d::UnitY()),
        make_joint(b.T, torque_scale, "trunk_bending", "", Vector3d::Zero(), -Vector3d::UnitX())};
  }
  return seg;
}

/// The marker placements of the spec (the thesis's 26 of markers_26.csv when it gives none).
const std::vector<MarkerPlacement>& marker_placements(const Build& b) {
  return b.spec.markers.empty() ? b.T.markers : b.spec.markers;
}

/// Marker sites on the skin of their part (MarkerPlacement explains the terms), attached to
/// the body that carries that part; arm markers only where there are arms.
std::vector<Marker> place_markers(const Build& b, const Character& c,
                                  const std::vector<SegmentPlan>& plan) {
  std::map<std::string, std::string> part_to_segment;
  for (const SegmentPlan& p : plan) {
    for (const std::string& part : p.parts) part_to_segment[part] = p.name;
  }
  std::vector<Marker> markers;
  for (const MarkerPlacement& mr : marker_placements(b)) {
    const auto pit = b.parts.find(mr.part);
    if (pit == b.parts.end()) {
      std::string names;
      for (const auto& [name, part] : b.parts) names += (names.empty() ? "" : ", ") + name;
      throw InvalidArgument("marker " + mr.name + ": part must be one of " + names + ", got '" +
                            mr.part + "'");
    }
    const Part& part = pit->second;
    const bool arm = part.kind == "clavicle" || part.kind == "upper_arm" ||
                     part.kind == "forearm" || part.kind == "hand";
    if (b.spec.detail == Detail::kGait && arm) continue;  // no arms in the gait model
    Marker m;
    m.name = mr.name;
    m.segment = part_to_segment.at(part.name);
    m.description = mr.description;
    if (mr.position_B) {
      m.position_B = *mr.position_B;
      markers.push_back(m);
      continue;
    }
    const double lateral_sign = part.side.empty() ? 1.0 : side_sign(part.side);
    Vector3d pos_W;
    if (part.kind == "foot") {  // along: heel -> toe tip; sup: sole -> dorsum
      const Geom& sole_box = part.geoms_W.front();
      const double x_heel = sole_box.center_B.x() - sole_box.half_extents.x();
      const double sole_z = sole_box.center_B.z() - sole_box.half_extents.z();
      const double full_len = part.length + b.parts.at("toes_" + part.side).length;
      pos_W = Vector3d(x_heel + mr.along * full_len + mr.ant * part.half_extent.x(),
                       part.proximal_W.y() + mr.lat * lateral_sign * part.half_extent.y(),
                       sole_z + mr.sup * part.half_extent.z());
    } else {
      pos_W = part.proximal_W + mr.along * (part.distal_W - part.proximal_W) +
              Vector3d(mr.ant * part.half_extent.x(), mr.lat * lateral_sign * part.half_extent.y(),
                       mr.sup * part.half_extent.z());
    }
    m.position_B = pos_W - c.find(m.segment)->origin_W;
    markers.push_back(m);
  }
  return markers;
}

/// Lowest and highest point of the geoms in the standing pose, m.
std::pair<double, double> geom_z_span(const std::vector<Segment>& segments) {
  double lowest = 1e9, highest = -1e9;
  for (const Segment& seg : segments) {
    for (Geom g : seg.geoms) {
      g.center_B += seg.origin_W;
      g.from_B += seg.origin_W;
      g.to_B += seg.origin_W;
      double lo = 0, hi = 0;
      geom_z_range(g, &lo, &hi);
      lowest = std::min(lowest, lo);
      highest = std::max(highest, hi);
    }
  }
  return {lowest, highest};
}

}  // namespace

Character generate_character(const CharacterSpec& spec) {
  spec.validate();
  Build b{default_tables(), spec};
  b.H = spec.height_m;
  b.ankle_h = b.T.proportion("ankle_height") * b.H;
  b.density = b.T.proportion("tissue_density");
  for (const std::string& n : full_part_names()) {
    Part p;
    p.name = n;
    std::tie(p.kind, p.side) = split_side(n);
    b.parts[n] = p;
  }
  assign_mass_shares(b);
  assign_table_lengths(b);

  const std::vector<SegmentPlan> plan = plan_segments(spec.detail);
  const std::map<std::string, SegmentOverride> overrides = resolve_overrides(spec, plan);
  apply_length_overrides(b, plan, overrides);
  distribute_mass(b, plan, overrides);

  lay_out_spine(b, lay_out_legs(b));
  lay_out_arms(b);

  Character c;
  c.spec = spec;
  c.torque_scale = torque_scale(spec);
  const auto joints = make_joints(b, c.torque_scale);
  for (const SegmentPlan& p : plan)
    c.segments.push_back(assemble_segment(b, p, joints, c.torque_scale));
  c.markers = place_markers(b, c, plan);
  const auto [lowest, highest] = geom_z_span(c.segments);
  c.lowest_point_m = lowest;
  c.standing_height_m = highest - lowest;
  if (spec.muscles) c.muscles = generate_muscles(c);
  return c;
}

void check_override_names(const std::map<std::string, SegmentOverride>& overrides, Detail detail,
                          const std::string& source) {
  const std::vector<SegmentPlan> plan = plan_segments(detail);
  for (const auto& entry : overrides) {
    const std::string& key = entry.first;
    const bool matched = std::any_of(plan.begin(), plan.end(), [&](const SegmentPlan& p) {
      return p.name == key || p.name == key + "_l" || p.name == key + "_r";
    });
    if (!matched) {
      throw InvalidArgument(source + ": segments." + key + ": no segment named '" + key +
                            "' in the " + to_string(detail) + " character (segments: " +
                            names_list(plan) + "; a name without _l/_r applies to both sides)");
    }
  }
}

Sex parse_sex(const std::string& text, const std::string& field) {
  if (text == "male" || text == "m") return Sex::kMale;
  if (text == "female" || text == "f") return Sex::kFemale;
  throw InvalidArgument(field + ": must be 'male' or 'female', got '" + text + "'");
}

Detail parse_detail(const std::string& text, const std::string& field) {
  if (text == "gait") return Detail::kGait;
  if (text == "full") return Detail::kFull;
  throw InvalidArgument(field + ": must be 'gait' or 'full', got '" + text + "'");
}

const char* to_string(Sex sex) { return sex == Sex::kMale ? "male" : "female"; }
const char* to_string(Detail detail) { return detail == Detail::kGait ? "gait" : "full"; }

}  // namespace biodyn::models
