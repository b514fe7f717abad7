#include "biodyn/models/character.h"

#include <algorithm>
#include <cmath>
#include <set>
#include <sstream>

#include "biodyn/models/tables.h"
#include "biodyn/sim/errors.h"

namespace biodyn::models {
namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;
using sim::InvalidArgument;

constexpr double kDegToRad = M_PI / 180.0;
// Capsule radii never exceed this share of the capsule's length (keeps short, heavy segments
// such as the hand of a 150 kg body from turning into spheres).
constexpr double kMaxRadiusPerLength = 0.3;
// Trunk boxes: depth derived from mass/(density*width*length), kept within these bounds (m per
// m of height) so extreme masses still give a plausible shape.
constexpr double kMinTrunkDepthPerHeight = 0.06;
constexpr double kMaxTrunkDepthPerHeight = 0.2;

const char* kSides[] = {"l", "r"};
double side_sign(const std::string& side) { return side == "l" ? 1.0 : -1.0; }

/// Mirror a left-side axis to the right side: x and z flip, y stays (sagittal symmetry).
Vector3d mirror(const Vector3d& axis_left, double sign) {
  return sign > 0 ? axis_left : Vector3d(-axis_left.x(), axis_left.y(), -axis_left.z());
}

/// A piece of the full-detail body, laid out in the world frame of the standing pose.
struct Part {
  std::string name;                        // full-detail segment name, e.g. "thigh_l"
  std::string parent;                      // full-detail parent
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
  const size_t us = part.rfind('_');
  const bool sided =
      us != std::string::npos && (part.substr(us + 1) == "l" || part.substr(us + 1) == "r");
  const std::string kind = sided ? part.substr(0, us) : part;
  const std::string parent_kind = kParentKind.at(kind);
  const bool parent_sided = parent_kind != "pelvis" && parent_kind != "thorax" &&
                            parent_kind != "lumbar" && parent_kind != "neck";
  return parent_sided ? parent_kind + part.substr(us) : parent_kind;
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
  const double r = std::sqrt(mass / (density * M_PI * length));
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

void CharacterSpec::validate() const {
  check_range("height", height_m, kMinHeight, kMaxHeight, "m");
  check_range("mass", mass_kg, kMinMass, kMaxMass, "kg");
  for (const auto& [name, o] : overrides) {
    if (o.mass_kg && !(std::isfinite(*o.mass_kg) && *o.mass_kg > 0)) {
      throw InvalidArgument("overrides." + name + ".mass_kg: must be > 0, got " +
                            std::to_string(*o.mass_kg));
    }
    if (o.length_m && !(std::isfinite(*o.length_m) && *o.length_m > 0 && *o.length_m < 1.5)) {
      throw InvalidArgument("overrides." + name + ".length_m: must be within (0, 1.5) m, got " +
                            std::to_string(*o.length_m));
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

std::vector<std::string> segment_names(Detail detail) {
  std::vector<std::string> names;
  for (const SegmentPlan& p : plan_segments(detail)) names.push_back(p.name);
  return names;
}

Character generate_character(const CharacterSpec& spec) {
  spec.validate();
  const Tables& T = default_tables();
  const double H = spec.height_m;
  const double M = spec.mass_kg;
  const Sex sex = spec.sex;
  const double density = T.proportion("tissue_density");
  const double stature_ref = de_leva_reference_height_m(sex);
  const auto row = [&](const char* seg) -> const DeLevaRow& { return T.de_leva_row(seg, sex); };
  const auto table_length = [&](const char* seg) {
    return row(seg).length_mm / 1000.0 / stature_ref * H;
  };

  // --- Mass fractions (de Leva Table 4), normalised so they sum to exactly 1 (the female
  // column sums to 99.99% by rounding).
  const char* kDeLevaParts[] = {"head",      "upper_trunk", "middle_trunk", "lower_trunk",
                                "upper_arm", "forearm",     "hand",         "thigh",
                                "shank",     "foot"};
  double pct_sum = 0;
  for (const char* seg : kDeLevaParts) {
    const bool bilateral =
        std::string(seg) != "head" && std::string(seg).find("trunk") == std::string::npos;
    pct_sum += row(seg).mass_pct * (bilateral ? 2 : 1);
  }
  const auto frac = [&](const char* seg) { return row(seg).mass_pct / pct_sum; };
  const double neck_share = T.proportion("neck_mass_share");
  const double girdle_share = T.proportion("shoulder_girdle_mass_share");
  const double toe_mass_share = T.proportion("toe_mass_share");
  const double toe_len_share = T.proportion("toe_length_share");

  std::map<std::string, Part> parts;
  for (const std::string& n : full_part_names()) {
    Part p;
    p.name = n;
    const size_t us = n.rfind('_');
    const bool sided =
        us != std::string::npos && (n.substr(us + 1) == "l" || n.substr(us + 1) == "r");
    p.kind = sided ? n.substr(0, us) : n;
    p.side = sided ? n.substr(us + 1) : "";
    p.parent = parent_of(n, Detail::kFull);
    parts[n] = p;
  }
  const auto set_table = [&](const std::string& part, double fraction, const std::string& what) {
    parts[part].table_fraction = fraction;
    parts[part].table_parts = what;
  };
  set_table("pelvis", frac("lower_trunk"), "de Leva lower_trunk (OMPH-MIDH)");
  set_table("lumbar", frac("middle_trunk"), "de Leva middle_trunk (XYPH-OMPH)");
  set_table("thorax", frac("upper_trunk") * (1 - 2 * girdle_share),
            "de Leva upper_trunk less both shoulder girdles");
  set_table("neck", frac("head") * neck_share, "share neck_mass_share of de Leva head");
  set_table("head", frac("head") * (1 - neck_share), "de Leva head less the neck share");
  for (const char* s : kSides) {
    const std::string sd = std::string("_") + s;
    set_table("clavicle" + sd, frac("upper_trunk") * girdle_share,
              "share shoulder_girdle_mass_share of de Leva upper_trunk");
    set_table("upper_arm" + sd, frac("upper_arm"), "de Leva upper_arm");
    set_table("forearm" + sd, frac("forearm"), "de Leva forearm");
    set_table("hand" + sd, frac("hand"), "de Leva hand");
    set_table("thigh" + sd, frac("thigh"), "de Leva thigh");
    set_table("shank" + sd, frac("shank"), "de Leva shank");
    set_table("foot" + sd, frac("foot") * (1 - toe_mass_share), "de Leva foot less the toe share");
    set_table("toes" + sd, frac("foot") * toe_mass_share, "share toe_mass_share of de Leva foot");
  }

  // --- Table lengths (m). The neck takes what is left of the stature.
  const double ankle_h = T.proportion("ankle_height") * H;
  const double foot_total = table_length("foot");
  parts["pelvis"].length = table_length("lower_trunk");
  parts["lumbar"].length = table_length("middle_trunk");
  parts["thorax"].length = table_length("upper_trunk");
  parts["head"].length = table_length("head");
  parts["neck"].length =
      H - (ankle_h + table_length("shank") + table_length("thigh") + parts["pelvis"].length +
           parts["lumbar"].length + parts["thorax"].length + parts["head"].length);
  if (!(parts["neck"].length > 0.01 * H)) {
    throw sim::Error("tables: segment lengths leave no room for the neck (" +
                     std::to_string(parts["neck"].length) + " m)");
  }
  for (const char* s : kSides) {
    const std::string sd = std::string("_") + s;
    parts["upper_arm" + sd].length = table_length("upper_arm");
    parts["forearm" + sd].length = table_length("forearm");
    parts["hand" + sd].length = table_length("hand");
    parts["thigh" + sd].length = table_length("thigh");
    parts["shank" + sd].length = table_length("shank");
    parts["foot" + sd].length = foot_total * (1 - toe_len_share);
    parts["toes" + sd].length = foot_total * toe_len_share;
    parts["clavicle" + sd].length = 0;  // derived from the shoulder breadth below
  }

  // --- Segments of this detail and their overrides.
  const std::vector<SegmentPlan> plan = plan_segments(spec.detail);
  std::map<std::string, SegmentOverride> seg_override;
  check_override_names(spec.overrides, spec.detail, "overrides");
  for (const auto& [key, o] : spec.overrides) {
    for (const SegmentPlan& p : plan) {
      if (p.name == key) {
        seg_override[key] = o;
      } else if ((p.name == key + "_l" || p.name == key + "_r") && !spec.overrides.count(p.name)) {
        seg_override[p.name] = o;  // a side-specific override wins over the generic one
      }
    }
  }

  // Length overrides scale every part of the segment (the gait trunk: lumbar..head; the
  // clavicle's length is taken as given).
  for (const SegmentPlan& p : plan) {
    const auto it = seg_override.find(p.name);
    if (it == seg_override.end() || !it->second.length_m) continue;
    if (p.name.rfind("clavicle", 0) == 0) {
      parts[p.name].length = *it->second.length_m;
      continue;
    }
    double current = 0;
    std::vector<std::string> chain;
    for (const std::string& part : p.parts) {
      const std::string& kind = parts[part].kind;
      if (p.parts.size() > 1 && kind != "lumbar" && kind != "thorax" && kind != "neck" &&
          kind != "head")
        continue;
      chain.push_back(part);
      current += parts[part].length;
    }
    const double factor = *it->second.length_m / current;
    for (const std::string& part : chain) parts[part].length *= factor;
  }

  // --- Masses: overridden segments keep their value; the rest share the remainder in the
  // tables' proportions.
  double fixed_mass = 0, free_fraction = 0;
  std::map<std::string, double> seg_fraction;
  for (const SegmentPlan& p : plan) {
    double f = 0;
    for (const std::string& part : p.parts) f += parts[part].table_fraction;
    seg_fraction[p.name] = f;
    const auto it = seg_override.find(p.name);
    if (it != seg_override.end() && it->second.mass_kg) {
      fixed_mass += *it->second.mass_kg;
    } else {
      free_fraction += f;
    }
  }
  if (free_fraction == 0 && std::abs(fixed_mass - M) > 1e-9) {
    std::ostringstream msg;
    msg << "overrides: every segment's mass is given and they sum to " << fixed_mass
        << " kg, not the body mass " << M << " kg";
    throw InvalidArgument(msg.str());
  }
  if (free_fraction > 0 && (fixed_mass >= M || M - fixed_mass < 1e-3 * M)) {
    std::ostringstream msg;
    msg << "overrides: segment masses sum to " << fixed_mass << " kg, which leaves nothing for the "
        << "other segments of a " << M << " kg body";
    throw InvalidArgument(msg.str());
  }
  std::map<std::string, double> seg_mass;
  for (const SegmentPlan& p : plan) {
    const auto it = seg_override.find(p.name);
    seg_mass[p.name] = (it != seg_override.end() && it->second.mass_kg)
                           ? *it->second.mass_kg
                           : (M - fixed_mass) * seg_fraction[p.name] / free_fraction;
    for (const std::string& part : p.parts) {
      parts[part].mass = seg_mass[p.name] * parts[part].table_fraction / seg_fraction[p.name];
    }
  }

  // --- Layout of the standing pose, bottom-up (legs), then the spine, then the arms.
  const double hjc_half = 0.5 * T.proportion("hip_joint_separation") * H;
  double z_hip = 0;
  for (const char* s : kSides) {
    const std::string sd = std::string("_") + s;
    z_hip = std::max(z_hip, ankle_h + parts["shank" + sd].length + parts["thigh" + sd].length);
  }
  const auto radius_of = [&](const std::string& n) {
    return capsule_radius(parts[n].mass, parts[n].length, density);
  };
  const auto limb = [&](const std::string& n, const Vector3d& top, const Vector3d& axis_down,
                        const DeLevaRow& r) {
    Part& p = parts[n];
    p.proximal_W = top;
    p.distal_W = top + p.length * axis_down;
    p.com_W = top + r.com_pct / 100.0 * p.length * axis_down;
    p.inertia = diag_inertia(p.mass, r.r_sag_pct / 100 * p.length, r.r_trans_pct / 100 * p.length,
                             r.r_long_pct / 100 * p.length);
    const double rad = radius_of(n);
    p.geoms_W.push_back(capsule_between(p.proximal_W, p.distal_W, rad));
    p.half_extent = Vector3d(rad, rad, rad);
  };
  const Vector3d down(0, 0, -1);
  const double foot_w = T.proportion("foot_width") * H;
  const double foot_thick = T.proportion("foot_thickness") * ankle_h;
  const double toe_thick = T.proportion("toe_thickness") * ankle_h;
  for (const char* s : kSides) {
    const std::string sd = std::string("_") + s;
    const double sign = side_sign(s);
    const Vector3d hjc(0, sign * hjc_half, z_hip);
    limb("thigh" + sd, hjc, down, row("thigh"));
    limb("shank" + sd, parts["thigh" + sd].distal_W, down, row("shank"));
    const Vector3d ankle = parts["shank" + sd].distal_W;
    const double sole_z = ankle.z() - ankle_h;
    // Foot: heel -> MTP (box), toes: MTP -> tip (box); de Leva's CoM is for the whole foot.
    const double len_foot = parts["foot" + sd].length, len_toes = parts["toes" + sd].length;
    const double x_heel = -T.proportion("heel_to_ankle") * (len_foot + len_toes);
    const double x_mtp = x_heel + len_foot, x_tip = x_mtp + len_toes;
    Part& foot = parts["foot" + sd];
    Part& toes = parts["toes" + sd];
    foot.proximal_W = ankle;
    foot.distal_W = Vector3d(x_tip, ankle.y(), sole_z);
    toes.proximal_W = Vector3d(x_mtp, ankle.y(), sole_z + 0.5 * toe_thick);
    toes.distal_W = Vector3d(x_tip, ankle.y(), sole_z + 0.5 * toe_thick);
    foot.geoms_W.push_back(box(Vector3d(x_heel, ankle.y() - foot_w / 2, sole_z),
                               Vector3d(x_mtp, ankle.y() + foot_w / 2, sole_z + foot_thick)));
    toes.geoms_W.push_back(box(Vector3d(x_mtp, ankle.y() - foot_w / 2, sole_z),
                               Vector3d(x_tip, ankle.y() + foot_w / 2, sole_z + toe_thick)));
    foot.half_extent = Vector3d(0.5 * len_foot, foot_w / 2, foot_thick);
    toes.half_extent = Vector3d(0.5 * len_toes, foot_w / 2, toe_thick);
    const DeLevaRow& fr = row("foot");
    const double m_total = foot.mass + toes.mass;
    const Vector3d com_total(x_heel + fr.com_pct / 100 * (len_foot + len_toes), ankle.y(),
                             sole_z + 0.5 * foot_thick);
    toes.com_W = Vector3d(0.5 * (x_mtp + x_tip), ankle.y(), sole_z + 0.5 * toe_thick);
    foot.com_W = (m_total * com_total - toes.mass * toes.com_W) / foot.mass;
    // Foot axes: longitudinal = x (heel->toe), sagittal column about y, transverse about z.
    foot.inertia = diag_inertia(foot.mass, fr.r_long_pct / 100 * len_foot,
                                fr.r_sag_pct / 100 * len_foot, fr.r_trans_pct / 100 * len_foot);
    toes.inertia = diag_inertia(toes.mass, fr.r_long_pct / 100 * len_toes,
                                fr.r_sag_pct / 100 * len_toes, fr.r_trans_pct / 100 * len_toes);
  }

  // Spine: each trunk part spans its landmarks; de Leva's CoM is measured from the cranial end.
  const auto trunk_part = [&](const std::string& n, double z_bottom, const DeLevaRow& r,
                              double width) {
    Part& p = parts[n];
    p.proximal_W = Vector3d(0, 0, z_bottom);
    p.distal_W = Vector3d(0, 0, z_bottom + p.length);
    p.com_W = Vector3d(0, 0, z_bottom + p.length * (1 - r.com_pct / 100));
    const double rl = p.length;
    p.inertia = diag_inertia(p.mass, r.r_sag_pct / 100 * rl, r.r_trans_pct / 100 * rl,
                             r.r_long_pct / 100 * rl);
    double depth = p.mass / (density * width * p.length);
    depth = std::clamp(depth, kMinTrunkDepthPerHeight * H, kMaxTrunkDepthPerHeight * H);
    p.geoms_W.push_back(box(Vector3d(-depth / 2, -width / 2, z_bottom),
                            Vector3d(depth / 2, width / 2, z_bottom + p.length)));
    p.half_extent = Vector3d(depth / 2, width / 2, p.length / 2);
  };
  const double hip_w = T.proportion("hip_width") * H;
  const double chest_w = T.proportion("chest_width") * H;
  trunk_part("pelvis", z_hip, row("lower_trunk"), hip_w);
  trunk_part("lumbar", parts["pelvis"].distal_W.z(), row("middle_trunk"), 0.5 * (hip_w + chest_w));
  trunk_part("thorax", parts["lumbar"].distal_W.z(), row("upper_trunk"), chest_w);
  const double z_supra = parts["thorax"].distal_W.z();
  {
    Part& neck = parts["neck"];
    neck.proximal_W = Vector3d(0, 0, z_supra);
    neck.distal_W = Vector3d(0, 0, z_supra + neck.length);
    neck.com_W = 0.5 * (neck.proximal_W + neck.distal_W);
    const double r = radius_of("neck");
    // Solid cylinder (no table gives the neck alone).
    const double Ixy = neck.mass * (3 * r * r + neck.length * neck.length) / 12;
    neck.inertia = Vector3d(Ixy, Ixy, 0.5 * neck.mass * r * r).asDiagonal();
    neck.geoms_W.push_back(capsule_between(neck.proximal_W, neck.distal_W, r));
    neck.half_extent = Vector3d(r, r, r);
  }
  {
    Part& head = parts["head"];
    const DeLevaRow& r = row("head");
    head.proximal_W = parts["neck"].distal_W;
    head.distal_W = head.proximal_W + Vector3d(0, 0, head.length);  // vertex
    head.com_W = head.distal_W - Vector3d(0, 0, r.com_pct / 100 * head.length);
    head.inertia =
        diag_inertia(head.mass, r.r_sag_pct / 100 * head.length, r.r_trans_pct / 100 * head.length,
                     r.r_long_pct / 100 * head.length);
    Geom sphere;
    sphere.type = GeomType::kSphere;
    sphere.radius = 0.5 * head.length;
    sphere.center_B = head.distal_W - Vector3d(0, 0, sphere.radius);
    head.geoms_W.push_back(sphere);
    head.half_extent = Vector3d::Constant(sphere.radius);
  }
  // Arms hang beside the trunk in the anatomical position (palms forward).
  for (const char* s : kSides) {
    const std::string sd = std::string("_") + s;
    const double sign = side_sign(s);
    Part& clav = parts["clavicle" + sd];
    const double r_ua = radius_of("upper_arm" + sd);
    const double sc_y = T.proportion("sternoclavicular_offset") * H;
    const double gh_y =
        clav.length > 0 ? sc_y + clav.length : 0.5 * T.proportion("shoulder_width") * H - r_ua;
    clav.length = gh_y - sc_y;
    const double gh_z = z_supra - T.proportion("shoulder_joint_drop") * H;
    clav.proximal_W = Vector3d(0, sign * sc_y, z_supra);
    clav.distal_W = Vector3d(0, sign * gh_y, gh_z);
    clav.com_W = 0.5 * (clav.proximal_W + clav.distal_W);
    const double rc = std::min(0.5 * r_ua, kMaxRadiusPerLength * clav.length);
    // Thin rod along y (clavicle + scapula lumped; no table gives them).
    const double Iperp = clav.mass * (3 * rc * rc + clav.length * clav.length) / 12;
    clav.inertia = Vector3d(Iperp, 0.5 * clav.mass * rc * rc, Iperp).asDiagonal();
    clav.geoms_W.push_back(capsule_between(clav.proximal_W, clav.distal_W, rc));
    clav.half_extent = Vector3d(rc, rc, rc);
    limb("upper_arm" + sd, clav.distal_W, down, row("upper_arm"));
    limb("forearm" + sd, parts["upper_arm" + sd].distal_W, down, row("forearm"));
    limb("hand" + sd, parts["forearm" + sd].distal_W, down, row("hand"));
  }

  // --- Joints (axes given for the left side; right side mirrored).
  const double torque_scale = (M / kPaperMass_kg) * (H / kPaperHeight_m);
  const auto make_joint = [&](const std::string& dof, const std::string& side,
                              const Vector3d& anchor_W, const Vector3d& axis_left) {
    const JointRow& jr = T.joint(dof);
    Joint j;
    j.name = side.empty() ? dof : dof + "_" + side;
    j.type = jr.type;
    j.anchor_B = anchor_W;  // converted to the body frame below
    j.axis_B = side.empty() ? axis_left : mirror(axis_left, side_sign(side));
    j.min_rad = jr.min_deg * kDegToRad;
    j.max_rad = jr.max_deg * kDegToRad;
    j.armature = jr.armature;
    j.damping = jr.damping;
    j.tau_max_Nm = Vector3d::Constant(jr.tau_ref_Nm * torque_scale);
    j.tau_source = jr.tau_source;
    return j;
  };
  const Vector3d X = Vector3d::UnitX(), Y = Vector3d::UnitY(), Z = Vector3d::UnitZ();
  std::map<std::string, std::vector<Joint>> joints;  // by full part name
  joints["lumbar"] = {make_joint("lumbar_flexion", "", parts["lumbar"].proximal_W, Y),
                      make_joint("lumbar_bending", "", parts["lumbar"].proximal_W, -X)};
  joints["thorax"] = {make_joint("thorax_flexion", "", parts["thorax"].proximal_W, Y),
                      make_joint("thorax_bending", "", parts["thorax"].proximal_W, -X)};
  joints["neck"] = {make_joint("neck_flexion", "", parts["neck"].proximal_W, Y)};
  joints["head"] = {make_joint("head", "", parts["head"].proximal_W, Z)};
  for (const char* s : kSides) {
    const std::string sd = std::string("_") + s;
    const Vector3d sc = parts["clavicle" + sd].proximal_W;
    joints["clavicle" + sd] = {make_joint("clavicle_elevation", s, sc, X),
                               make_joint("clavicle_protraction", s, sc, -Z)};
    joints["upper_arm" + sd] = {make_joint("shoulder", s, parts["upper_arm" + sd].proximal_W, Z)};
    const Vector3d elbow = parts["forearm" + sd].proximal_W;
    joints["forearm" + sd] = {make_joint("elbow_flexion", s, elbow, -Y),
                              make_joint("forearm_pronation", s, elbow, -Z)};
    const Vector3d wrist = parts["hand" + sd].proximal_W;
    joints["hand" + sd] = {make_joint("wrist_flexion", s, wrist, -Y),
                           make_joint("wrist_deviation", s, wrist, X)};
    joints["thigh" + sd] = {make_joint("hip", s, parts["thigh" + sd].proximal_W, Z)};
    joints["shank" + sd] = {make_joint("knee_flexion", s, parts["shank" + sd].proximal_W, Y)};
    const Vector3d ankle = parts["foot" + sd].proximal_W;
    joints["foot" + sd] = {make_joint("ankle_dorsiflexion", s, ankle, -Y),
                           make_joint("ankle_inversion", s, ankle, -X)};
    joints["toes" + sd] = {make_joint("toe_dorsiflexion", s, parts["toes" + sd].proximal_W, -Y)};
  }

  // --- Assemble the segments of this detail (fusing the gait trunk), in body frames.
  Character c;
  c.spec = spec;
  c.torque_scale = torque_scale;
  std::map<std::string, std::string> part_to_segment;
  for (const SegmentPlan& p : plan) {
    Segment seg;
    seg.name = p.name;
    seg.parent = parent_of(p.name, spec.detail);
    const Part& first = parts[p.parts.front()];
    seg.origin_W = first.proximal_W;
    seg.mass_kg = 0;
    Vector3d weighted = Vector3d::Zero();
    for (const std::string& n : p.parts) {
      seg.mass_kg += parts[n].mass;
      weighted += parts[n].mass * parts[n].com_W;
      seg.table_mass_fraction += parts[n].table_fraction;
      part_to_segment[n] = p.name;
    }
    const Vector3d com_W = weighted / seg.mass_kg;
    seg.com_B = com_W - seg.origin_W;
    for (const std::string& n : p.parts) {
      const Part& part = parts[n];
      seg.inertia_B += shifted(part.inertia, part.mass, part.com_W - com_W);
      for (Geom g : part.geoms_W) {
        g.center_B -= seg.origin_W;
        g.from_B -= seg.origin_W;
        g.to_B -= seg.origin_W;
        seg.geoms.push_back(g);
      }
    }
    if (p.parts.size() == 1) {
      seg.length_m = first.length;
      seg.table_parts = first.table_parts;
      for (Joint j : joints[first.name]) {
        j.anchor_B -= seg.origin_W;
        seg.joints.push_back(j);
      }
    } else {  // gait trunk: OMPH to vertex; joints as the paper's TrunkJoint (Table 2)
      seg.length_m = parts["head"].distal_W.z() - seg.origin_W.z();
      seg.table_parts = "de Leva head + upper_trunk + middle_trunk + both arms (fused)";
      seg.joints = {make_joint("trunk_flexion", "", Vector3d::Zero(), Y),
                    make_joint("trunk_bending", "", Vector3d::Zero(), -X)};
    }
    c.segments.push_back(seg);
  }

  // --- Markers (thesis's 26-marker model) on the skin of their part.
  for (const MarkerRow& mr : T.markers) {
    const auto pit = parts.find(mr.segment);
    if (pit == parts.end()) {
      throw sim::Error("markers_26.csv: marker " + mr.marker + " names no segment '" + mr.segment +
                       "'");
    }
    const Part& part = pit->second;
    const bool arm = part.kind == "clavicle" || part.kind == "upper_arm" ||
                     part.kind == "forearm" || part.kind == "hand";
    if (spec.detail == Detail::kGait && arm) continue;  // no arms in the gait model
    const double lateral_sign = part.side.empty() ? 1.0 : side_sign(part.side);
    Vector3d pos_W;
    if (part.kind == "foot") {
      const double x_heel = part.geoms_W[0].center_B.x() - part.geoms_W[0].half_extents.x();
      const double sole = part.geoms_W[0].center_B.z() - part.geoms_W[0].half_extents.z();
      const double full_len = part.length + parts["toes_" + part.side].length;
      pos_W = Vector3d(x_heel + mr.along * full_len, part.proximal_W.y(),
                       sole + mr.sup * part.half_extent.z());
      pos_W.y() += mr.lat * lateral_sign * part.half_extent.y();
      pos_W.x() += mr.ant * part.half_extent.x();
    } else {
      pos_W = part.proximal_W + mr.along * (part.distal_W - part.proximal_W);
      pos_W += Vector3d(mr.ant * part.half_extent.x(), mr.lat * lateral_sign * part.half_extent.y(),
                        mr.sup * part.half_extent.z());
    }
    const std::string& seg_name = part_to_segment.at(part.name);
    Marker m;
    m.name = mr.marker;
    m.segment = seg_name;
    m.position_B = pos_W - c.find(seg_name)->origin_W;
    m.description = mr.description;
    c.markers.push_back(m);
  }

  // --- Standing height and lowest point from the geoms.
  double lowest = 1e9, highest = -1e9;
  for (const Segment& seg : c.segments) {
    for (const Geom& g : seg.geoms) {
      Geom w = g;
      w.center_B += seg.origin_W;
      w.from_B += seg.origin_W;
      w.to_B += seg.origin_W;
      double lo = 0, hi = 0;
      geom_z_range(w, &lo, &hi);
      lowest = std::min(lowest, lo);
      highest = std::max(highest, hi);
    }
  }
  c.lowest_point_m = lowest;
  c.standing_height_m = highest - lowest;
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
