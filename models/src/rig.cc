// The character rig: a generated character's parts resolved by name once (rig.h).
#include "biodyn/models/rig.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "biodyn/models/mjcf.h"
#include "biodyn/sim/queries.h"

namespace biodyn::models {
namespace {

using Eigen::Vector3d;

// Body-name stem -> anatomical joint name (character.cc builds these bodies).
const std::pair<const char*, const char*> kJointNames[] = {
    {"trunk", "trunk"}, {"lumbar", "lumbar"},     {"thorax", "thorax"},      {"neck", "neck"},
    {"head", "head"},   {"clavicle", "clavicle"}, {"upper_arm", "shoulder"}, {"forearm", "elbow"},
    {"hand", "wrist"},  {"thigh", "hip"},         {"shank", "knee"},         {"foot", "ankle"},
    {"toes", "toe"}};

// The generated character's names (character.cc, mjcf.cc).
constexpr const char* kFloorGeom = "floor";
constexpr const char* kPelvis = "pelvis";
constexpr const char* kMarkerSitePrefix = "marker_";
const char* const kTrunkBodies[] = {"thorax", "trunk", "lumbar"};  // what a "trunk" push pushes

constexpr const char* kHowToGetOne = " (a generated character has it: biodyn model)";

int id_or_none(const std::map<std::string, int>& ids, const std::string& name) {
  const auto it = ids.find(name);
  return it == ids.end() ? -1 : it->second;
}

}  // namespace

Sole find_sole(const mjModel& m, int foot_body) {
  Sole s;
  s.x_min = s.y_min = s.z = std::numeric_limits<double>::max();
  s.x_max = s.y_max = -std::numeric_limits<double>::max();
  for (int b = 0; b < m.nbody; ++b) {
    if (b != foot_body && m.body_parentid[b] != foot_body) continue;
    const Vector3d offset = b == foot_body ? Vector3d::Zero() : sim::vec3_at(m.body_pos + 3 * b);
    for (int g = m.body_geomadr[b]; g < m.body_geomadr[b] + m.body_geomnum[b]; ++g) {
      if (m.geom_type[g] != mjGEOM_BOX) continue;
      const Vector3d c = offset + sim::vec3_at(m.geom_pos + 3 * g);
      const Vector3d h = sim::vec3_at(m.geom_size + 3 * g);
      s.x_min = std::min(s.x_min, c.x() - h.x());
      s.x_max = std::max(s.x_max, c.x() + h.x());
      s.y_min = std::min(s.y_min, c.y() - h.y());
      s.y_max = std::max(s.y_max, c.y() + h.y());
      s.z = std::min(s.z, c.z() - h.z());
    }
  }
  if (s.x_max < s.x_min) {
    const char* name = mj_id2name(&m, mjOBJ_BODY, foot_body);
    throw sim::InvalidArgument(std::string("sole: body '") + (name ? name : "?") +
                               "' and its children have no box geom");
  }
  return s;
}

std::vector<double> judged_tau_max(const mjModel& m, const std::vector<JointGroup>& groups) {
  std::vector<double> tau_max = sim::motor_limits_per_dof(m);
  for (const JointGroup& g : groups) {
    if (strength_judged(g)) continue;
    for (int k = 0; k < g.dof_count; ++k) tau_max[static_cast<std::size_t>(g.dof_begin + k)] = -1;
  }
  return tau_max;
}

std::string joint_name_for_body(const std::string& body_name) {
  std::string stem = body_name, suffix;
  if (stem.size() > 2 &&
      (stem.substr(stem.size() - 2) == "_l" || stem.substr(stem.size() - 2) == "_r")) {
    suffix = stem.substr(stem.size() - 2);
    stem = stem.substr(0, stem.size() - 2);
  }
  for (const auto& [body, joint] : kJointNames) {
    if (stem == body) return joint + suffix;
  }
  return body_name;  // not a generated character's body: keep its own name
}

std::vector<JointGroup> find_joint_groups(const mjModel& m) {
  std::vector<JointGroup> groups;
  for (int b = 1; b < m.nbody; ++b) {
    if (m.body_jntnum[b] == 0) continue;
    const int first_joint = m.body_jntadr[b];
    if (m.jnt_type[first_joint] == mjJNT_FREE) continue;  // the root
    const char* body_name = mj_id2name(&m, mjOBJ_BODY, b);
    JointGroup g;
    g.body_name = body_name ? body_name : "body" + std::to_string(b);
    g.name = joint_name_for_body(g.body_name);
    g.body = b;
    g.dof_begin = m.body_dofadr[b];
    g.dof_count = m.body_dofnum[b];
    const std::size_t n = g.name.size();
    g.side = (n > 2 && g.name.compare(n - 2, 2, "_l") == 0)   ? 1
             : (n > 2 && g.name.compare(n - 2, 2, "_r") == 0) ? -1
                                                              : 0;
    for (int j = first_joint; j < first_joint + m.body_jntnum[b]; ++j) {
      const char* jn = mj_id2name(&m, mjOBJ_JOINT, j);
      const std::string joint_name = jn ? jn : "joint" + std::to_string(j);
      if (m.jnt_type[j] == mjJNT_BALL) {
        if (m.body_jntnum[b] != 1) {
          throw sim::InvalidArgument("joint groups: body '" + g.body_name +
                                     "' mixes a ball joint with other joints");
        }
        g.ball = true;
        for (int k = 0; k < 3; ++k) {
          g.dof_names.push_back(joint_name + "_" + "xyz"[k]);
          g.axes_B.push_back(Vector3d::Unit(k));
        }
      } else if (m.jnt_type[j] == mjJNT_HINGE) {
        g.dof_names.push_back(joint_name);
        const double inf = std::numeric_limits<double>::infinity();
        g.range_rad.push_back(m.jnt_limited[j]
                                  ? Eigen::Vector2d(m.jnt_range[2 * j], m.jnt_range[2 * j + 1])
                                  : Eigen::Vector2d(-inf, inf));
        g.axes_B.push_back(sim::vec3_at(m.jnt_axis + 3 * j).normalized());
      } else {
        throw sim::InvalidArgument("joint groups: joint '" + joint_name +
                                   "' is neither a hinge nor a ball joint");
      }
    }
    if (!g.ball && g.dof_count > 2) {
      throw sim::InvalidArgument("joint groups: body '" + g.body_name + "' has " +
                                 std::to_string(g.dof_count) +
                                 " hinges (at most 2; use a ball joint for 3 DOF)");
    }
    if (g.ball) {
      // Limbs hang down (thigh, upper arm): flexion moves them forward = rotation about -y,
      // abduction away from the midline = about +x on the left, internal rotation = about
      // -z on the left. The head points up: flexion about +y, bending left about -x,
      // rotation left about +z.
      const bool points_up = g.body_name.rfind("head", 0) == 0;
      const double s = g.side == 0 ? 1.0 : g.side;
      g.ball_signs = points_up ? Vector3d(1, -1, 1) : Vector3d(-1, s, -s);
    }
    groups.push_back(std::move(g));
  }
  return groups;
}

int find_group(const std::vector<JointGroup>& groups, const std::string& name) {
  for (std::size_t i = 0; i < groups.size(); ++i) {
    if (groups[i].name == name) return static_cast<int>(i);
  }
  return -1;
}

Rig::Rig(const mjModel& m)
    : groups_(find_joint_groups(m)), foot_part_(static_cast<std::size_t>(m.nbody), 0) {
  for (int b = 0; b < m.nbody; ++b) {
    const char* name = mj_id2name(&m, mjOBJ_BODY, b);
    if (name != nullptr) bodies_.emplace(name, b);
  }
  const std::string prefix = kMarkerSitePrefix;
  for (int s = 0; s < m.nsite; ++s) {
    const char* name = mj_id2name(&m, mjOBJ_SITE, s);
    if (name != nullptr && std::string(name).rfind(prefix, 0) == 0)
      marker_sites_.emplace(name + prefix.size(), s);
  }
  floor_geom_ = mj_name2id(&m, mjOBJ_GEOM, kFloorGeom);
  pelvis_ = body(kPelvis);
  if (pelvis_ >= 0 && m.body_jntnum[pelvis_] > 0 &&
      m.jnt_type[m.body_jntadr[pelvis_]] == mjJNT_FREE) {
    root_joint_ = m.body_jntadr[pelvis_];
  }
  for (const char* n : kTrunkBodies) {
    if (trunk_body_ < 0) trunk_body_ = body(n);
  }
  for (int side = 0; side < 2; ++side) {
    const std::string sfx = kSideSuffix[side];
    RigLeg& leg = legs_[static_cast<std::size_t>(side)];
    leg.thigh = body("thigh" + sfx);
    leg.shank = body("shank" + sfx);
    leg.foot = body("foot" + sfx);
    leg.toes = body("toes" + sfx);
    leg.hip = group("hip" + sfx);
    leg.knee = group("knee" + sfx);
    leg.ankle = group("ankle" + sfx);
    leg.toe = group("toe" + sfx);
    leg.foot_weld = mj_name2id(
        &m, mjOBJ_EQUALITY, (std::string(kFootWeldPrefix) + (side == kLeft ? "l" : "r")).c_str());
    if (leg.foot >= 0) {
      foot_part_[static_cast<std::size_t>(leg.foot)] = 1;
      try {
        leg.sole = find_sole(m, leg.foot);
        leg.has_sole = true;
      } catch (const sim::InvalidArgument&) {
        leg.has_sole = false;  // require_legs names it
      }
    }
    if (leg.toes >= 0) foot_part_[static_cast<std::size_t>(leg.toes)] = 1;
    if (leg.shank >= 0) leg.thigh_length_m = sim::vec3_at(m.body_pos + 3 * leg.shank).norm();
    if (leg.foot >= 0) leg.shank_length_m = sim::vec3_at(m.body_pos + 3 * leg.foot).norm();
  }
  if (legs_[0].thigh >= 0 && legs_[1].thigh >= 0) {
    hip_spacing_m_ =
        std::abs(m.body_pos[3 * legs_[0].thigh + 1] - m.body_pos[3 * legs_[1].thigh + 1]);
  }
  for (int b = 1; b < m.nbody; ++b) mass_kg_ += m.body_mass[b];
}

int Rig::body(const std::string& name) const { return id_or_none(bodies_, name); }

int Rig::marker_site(const std::string& label) const { return id_or_none(marker_sites_, label); }

void Rig::require_root(const std::string& user) const {
  if (root_joint_ < 0) {
    throw RigError(user + ": the model has no free-floating body '" + kPelvis + "'" + kHowToGetOne);
  }
}

void Rig::require_floor(const std::string& user) const {
  if (floor_geom_ < 0)
    throw RigError(user + ": the model has no geom '" + kFloorGeom + "'" + kHowToGetOne);
}

void Rig::require_legs(const std::string& user) const {
  require_root(user);
  for (int side = 0; side < 2; ++side) {
    const std::string sfx = kSideSuffix[side];
    const RigLeg& leg = legs_[static_cast<std::size_t>(side)];
    const std::pair<int, std::string> bodies[] = {
        {leg.thigh, "thigh"}, {leg.shank, "shank"}, {leg.foot, "foot"}};
    for (const auto& [id, stem] : bodies) {
      if (id < 0)
        throw RigError(user + ": the model has no body '" + stem + sfx + "'" + kHowToGetOne);
    }
    const std::pair<int, std::string> joints[] = {
        {leg.hip, "hip"}, {leg.knee, "knee"}, {leg.ankle, "ankle"}};
    for (const auto& [g, stem] : joints) {
      if (g < 0)
        throw RigError(user + ": the model has no joint group '" + stem + sfx + "'" + kHowToGetOne);
    }
    if (!leg.has_sole) {
      throw RigError(user + ": body 'foot" + sfx + "' and its children have no box geom (a sole)" +
                     kHowToGetOne);
    }
  }
  require_floor(user);
}

void Rig::require_foot_welds(const std::string& user) const {
  for (int side = 0; side < 2; ++side) {
    if (legs_[static_cast<std::size_t>(side)].foot_weld < 0) {
      throw RigError(user + ": the model has no equality '" + kFootWeldPrefix +
                     (side == kLeft ? "l" : "r") + "'" + kHowToGetOne);
    }
  }
}

int Rig::require_group(const std::string& name, const std::string& user) const {
  const int g = group(name);
  if (g < 0)  // callers ask for upper-body groups by name; require_legs checks the legs
    throw RigError(user + ": the model has no joint group '" + name +
                   "' (a generated character in full detail has it: --detail full)");
  return g;
}

int Rig::lower_back() const {
  for (const char* name : {"lumbar", "trunk"}) {
    const int g = group(name);
    if (g >= 0) return g;
  }
  return -1;
}

int Rig::require_lower_back(const std::string& user) const {
  const int g = lower_back();
  if (g >= 0) return g;
  throw RigError(user +
                 ": the model has no joint group 'lumbar' or 'trunk' between the pelvis and the "
                 "upper body (a generated character has one in either detail)");
}

int Rig::require_body(const std::string& name, const std::string& user) const {
  const int b = body(name);
  if (b < 0) throw RigError(user + ": the model has no body '" + name + "'");
  return b;
}

}  // namespace biodyn::models
