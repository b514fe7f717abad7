#pragma once
/// Joint-group angle arithmetic: targets as anatomical angles, and the rotation of a relative
/// orientation (quaternion, w x y z; the groups themselves are the rig's, models/rig.h).
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

#include "biodyn/models/rig.h"

namespace biodyn::controllers {

/// The joint groups (one per controllable body) are the rig's (models/rig.h).
using models::JointGroup;

/// `angles` with every hinge angle moved inside its range by `margin_rad` (a target beyond a
/// joint stop cannot be reached and would drive the torque to saturation). Ball joints: as is.
Eigen::Vector3d clamp_to_range(const JointGroup& group, Eigen::Vector3d angles, double margin_rad);

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
