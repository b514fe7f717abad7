#pragma once
/// The character rig: every id a controller, scenario, reader or viewer needs from a generated
/// character's compiled model (bodies, joint groups, DOFs, sites, geoms, equalities; the two
/// sides; the feet and their soles), resolved by name once, when the model is loaded. Nothing
/// else looks a name up while a simulation runs: a part is an integer from here on.
///
/// A model that lacks a part a user needs gets one typed error, RigError, naming the part and
/// the user (the require_* functions); parts no user asks for may be absent (-1): a gait-detail
/// character has no arms, an inline test model may have no feet.
///
/// Joint groups are the paper's controllable joints (§3.1): the DOFs of one body, a ball (hip,
/// shoulder, head: 3 DOF), a universal pair of hinges (ankle, lumbar, wrist: 2 DOF) or a hinge
/// (knee: 1 DOF). A group's state is its body's orientation relative to its parent (body frames
/// are parallel at rest, so the rest pose is the identity).

#include <mujoco/mujoco.h>

#include <Eigen/Core>
#include <array>
#include <map>
#include <string>
#include <vector>

#include "biodyn/sim/errors.h"

namespace biodyn::models {

/// A model lacks a part that a controller, scenario or reader needs. what() names the user, the
/// part and how to get a model that has it.
class RigError : public sim::InvalidArgument {
 public:
  using sim::InvalidArgument::InvalidArgument;
};

/// Sides, as indices of Rig::leg and of every per-foot array in biodyn.
inline constexpr int kLeft = 0, kRight = 1;
/// Name suffix of each side's bodies and joints ("thigh_l", "hip_r").
inline constexpr const char* kSideSuffix[2] = {"_l", "_r"};

/// A foot's sole: the rectangle spanned by the box geoms of the foot body and its child bodies
/// (toes) in the standing pose, in the foot's body frame.
struct Sole {
  double x_min = 0, x_max = 0, y_min = 0, y_max = 0;  ///< m, foot frame
  double z = 0;                                       ///< m, sole height in the foot frame
  Eigen::Vector3d centre_B() const { return {(x_min + x_max) / 2, (y_min + y_max) / 2, z}; }
  double length_m() const { return x_max - x_min; }
  double width_m() const { return y_max - y_min; }
};

/// The sole of `foot_body`; throws sim::InvalidArgument if it and its children have no box geom.
Sole find_sole(const mjModel& m, int foot_body);

/// One controllable joint: the DOFs of one body.
struct JointGroup {
  std::string name;       ///< anatomical name: "hip_l", "knee_l", "ankle_l", "lumbar", ...
  std::string body_name;  ///< the child body, e.g. "thigh_l"
  int body = -1;          ///< child body id
  int dof_begin = 0;      ///< first DOF (a body's DOFs are contiguous in MuJoCo)
  int dof_count = 0;      ///< 1, 2 (hinges) or 3 (ball)
  bool ball = false;      ///< one ball joint (else 1-2 hinges)
  int side = 0;           ///< +1 left, -1 right, 0 middle
  std::vector<std::string> dof_names;  ///< hinge names, or "<ball>_x/_y/_z"
  /// Unit hinge axes in the body frame (ball: x, y, z), one per DOF.
  std::vector<Eigen::Vector3d> axes_B;
  /// Ball joints: the anatomical angles are (s0*a, s1*b, s2*c) for the intrinsic body-frame
  /// rotation R_y(a) R_x(b) R_z(c); these are s0, s1, s2 (each +-1).
  Eigen::Vector3d ball_signs = Eigen::Vector3d::Ones();
  /// Hinges: the joint range per DOF, rad (-inf/+inf when the hinge is unlimited; ball
  /// joints: unused, their limits are swing-twist, controllers/joint_limits.h).
  std::vector<Eigen::Vector2d> range_rad;
};

/// Whether a group's strength is judged against its tau_max: every joint but the toes, whose
/// tau_max is an estimate (joints.csv) and whose load hangs on the forefoot/toe-tip split.
inline bool strength_judged(const JointGroup& g) { return g.name.rfind("toe", 0) != 0; }

/// Per DOF (nv): the motor's tau_max (sim::motor_limits_per_dof) where `groups` judge the
/// strength, -1 elsewhere (the root, the toes, DOFs without a motor).
std::vector<double> judged_tau_max(const mjModel& m, const std::vector<JointGroup>& groups);

/// The anatomical joint name of a generated character's body ("thigh_l" -> "hip_l",
/// "shank_r" -> "knee_r", "trunk" -> "trunk"); the body's own name for other bodies.
std::string joint_name_for_body(const std::string& body_name);

/// Every non-root body with at least one hinge or ball joint, in body order. Throws
/// sim::InvalidArgument for a body mixing ball and hinge joints or with slide joints.
std::vector<JointGroup> find_joint_groups(const mjModel& m);

/// Index of the group called `name` in `groups`, or -1.
int find_group(const std::vector<JointGroup>& groups, const std::string& name);

/// One leg: its bodies, joint groups, foot weld and sole.
struct RigLeg {
  int thigh = -1, shank = -1, foot = -1;  ///< body ids
  int toes = -1;                          ///< body id, -1 for a model without toes
  int hip = -1, knee = -1, ankle = -1;    ///< indices into Rig::groups()
  int toe = -1;                           ///< index into Rig::groups(), -1 without toes
  int foot_weld = -1;                     ///< equality id of the foot-contact weld, -1 if none
  Sole sole;                              ///< of the foot and its toes (valid if has_sole)
  bool has_sole = false;
  double thigh_length_m = 0;  ///< hip to knee, m (rest pose)
  double shank_length_m = 0;  ///< knee to ankle, m (rest pose)
};

class Rig {
 public:
  /// Resolves every part `m` has. Throws sim::InvalidArgument only for joints it cannot group
  /// (find_joint_groups); missing parts are -1 until a user requires them.
  explicit Rig(const mjModel& m);

  // --- The world and the root ---
  int floor_geom() const { return floor_geom_; }  ///< geom "floor", or -1
  int pelvis() const { return pelvis_; }          ///< body "pelvis" (the free root), or -1
  int root_joint() const { return root_joint_; }  ///< the pelvis's free joint, or -1
  /// Body a "trunk" push goes through: thorax (full detail), else trunk (gait), else lumbar.
  int trunk_body() const { return trunk_body_; }

  // --- Legs, feet and joints ---
  const RigLeg& leg(int side) const { return legs_[static_cast<std::size_t>(side)]; }
  /// Whether `body` is a foot or toes (what may touch the floor without a fall).
  bool is_foot_part(int body) const {
    return body >= 0 && foot_part_[static_cast<std::size_t>(body)] != 0;
  }
  const std::vector<JointGroup>& groups() const { return groups_; }
  /// Index of the group called `name` ("lumbar", "knee_r"), or -1.
  int group(const std::string& name) const { return find_group(groups_, name); }
  /// m, lateral distance between the two hip joints (rest pose).
  double hip_spacing_m() const { return hip_spacing_m_; }
  /// kg, the bodies' total mass (world excluded), summed in body order.
  double mass_kg() const { return mass_kg_; }

  // --- Parts by name, for set-up (a push's body, a marker's site): -1 when absent ---
  int body(const std::string& name) const;
  /// The site "marker_<label>" of a marker, or -1.
  int marker_site(const std::string& label) const;

  // --- Requirements: each throws RigError naming `user` and the first part missing ---
  /// The free-floating pelvis.
  void require_root(const std::string& user) const;
  /// The floor geom.
  void require_floor(const std::string& user) const;
  /// Both legs' thigh, shank and foot bodies with their hip, knee and ankle groups and soles
  /// (and the pelvis and floor).
  void require_legs(const std::string& user) const;
  /// Both feet's weld equalities (foot_weld_l/r).
  void require_foot_welds(const std::string& user) const;
  /// The group called `name`; returns its index.
  int require_group(const std::string& name, const std::string& user) const;
  /// The body called `name`; returns its id.
  int require_body(const std::string& name, const std::string& user) const;
  /// The joint group between the pelvis and the upper body: "lumbar" (full detail) or "trunk"
  /// (the paper's lower-body model, its upper body one segment); its index, or -1.
  int lower_back() const;
  /// lower_back(), or a RigError naming `user` and both names.
  int require_lower_back(const std::string& user) const;

 private:
  std::map<std::string, int> bodies_;        // every named body
  std::map<std::string, int> marker_sites_;  // label -> site id
  std::vector<JointGroup> groups_;
  std::array<RigLeg, 2> legs_;
  std::vector<unsigned char> foot_part_;  // per body
  int floor_geom_ = -1, pelvis_ = -1, root_joint_ = -1, trunk_body_ = -1;
  double hip_spacing_m_ = 0, mass_kg_ = 0;
};

}  // namespace biodyn::models
