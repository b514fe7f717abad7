#pragma once
/// The controllable joints of a generated character, one per non-root body: a ball (hip,
/// shoulder, head: 3 DOF), a universal pair of hinges (ankle, lumbar, wrist: 2 DOF) or a hinge
/// (knee: 1 DOF) — the paper's §3.1 joint kinds. A joint's state is the orientation of its body
/// relative to its parent (quaternion, w x y z); body frames are parallel at rest, so the rest
/// pose is the identity.
///
/// Anatomical angles: hinges use the model's own sign (positive in flexion, dorsiflexion,
/// abduction, inversion: models/data/joints.csv). Ball joints take (flexion, abduction,
/// internal rotation) in radians, applied in that order (intrinsic), mirrored for the right
/// side so that positive means the same movement on both sides.

#include <mujoco/mujoco.h>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <string>
#include <vector>

namespace biodyn::controllers {

/// One controllable joint: the DOFs of one body.
struct JointGroup {
  std::string name;      ///< anatomical name: "hip_l", "knee_l", "ankle_l", "lumbar", ...
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
  /// joints: unused, their limits are swing-twist, joint_limits.h).
  std::vector<Eigen::Vector2d> range_rad;
};

/// `angles` with every hinge angle moved inside its range by `margin_rad` (a target beyond a
/// joint stop cannot be reached and would drive the torque to saturation). Ball joints: as is.
Eigen::Vector3d clamp_to_range(const JointGroup& group, Eigen::Vector3d angles, double margin_rad);

/// The anatomical joint name of a generated character's body ("thigh_l" -> "hip_l",
/// "shank_r" -> "knee_r", "trunk" -> "trunk"); empty for the root.
std::string joint_name_for_body(const std::string& body_name);

/// Every non-root body with at least one hinge or ball joint, in body order. Throws
/// sim::InvalidArgument for a body mixing ball and hinge joints or with slide joints.
std::vector<JointGroup> find_joint_groups(const mjModel& m);

/// Index of the group called `name` in `groups`, or -1.
int find_group(const std::vector<JointGroup>& groups, const std::string& name);

/// The relative orientation of a group's body for joint angles `angles` (hinges: one angle per
/// DOF in model order, rad; ball: flexion, abduction, internal rotation, rad).
Eigen::Quaterniond orientation_from_angles(const JointGroup& group, const Eigen::Vector3d& angles);

/// A hinge group's angles in `qpos` (one per DOF in model order, rad; the rest 0). Ball groups:
/// use the joint's quaternion instead.
Eigen::Vector3d hinge_angles(const mjModel& m, const JointGroup& group, const double* qpos);

/// The anatomical angles of a relative orientation (inverse of orientation_from_angles for
/// hinge groups up to the projection on their axes; for a ball joint the intrinsic
/// flexion-abduction-rotation decomposition).
Eigen::Vector3d angles_from_orientation(const JointGroup& group, const Eigen::Quaterniond& q);

/// Rotation angle of q (w x y z) in [0, pi], rad: the shortest way round.
double rotation_angle(const Eigen::Quaterniond& q);

/// Rotation vector (angle * unit axis, rad) of q, the short way round.
Eigen::Vector3d rotation_vector(Eigen::Quaterniond q);

}  // namespace biodyn::controllers
