#pragma once
/// Inverse dynamics of captured motion on any generated body (thesis: recursive Newton-Euler;
/// MuJoCo's mj_inverse). Positions are low-pass filtered (zero-lag Butterworth), velocities and
/// accelerations are finite differences on the configuration manifold (mj_differentiatePos);
/// mj_inverse then gives the generalised force every DOF needs. The 6 root entries are the
/// residual force and moment: the "helping hand" the motion needs beyond what the ground gives
/// (mujoco-2.2.2.md); with measured ground reaction forces applied it should be small.

#include <mujoco/mujoco.h>

#include <Eigen/Core>
#include <string>
#include <vector>

#include "biodyn/mocap_io/filter.h"
#include "biodyn/mocap_io/ground_force_estimate.h"
#include "biodyn/mocap_io/marker_data.h"
#include "biodyn/mocap_io/motion_csv.h"

namespace biodyn::mocap_io {

/// Where the ground reaction comes from.
enum class GroundForces {
  kNone,  ///< none applied: the root residual is the whole ground reaction the motion needs
  /// measured force plates, each applied at its centre of pressure to the foot standing on it
  /// (its sole on the plate and the centre of pressure under it; mocap_io/src/plate_assignment.h),
  /// to its toes when the force's line of action would turn them up about their joint (push-off)
  kForcePlates,
  /// estimated from the kinematics (ground_force_estimate.h: sole points near the floor and
  /// slow, friction pyramid, least root residual and leg torques): an estimate, for motions
  /// without plates; it assumes a flat floor and the body's mass being the subject's
  kEstimated
};

struct InverseDynamicsOptions {
  LowPassFilter filter;
  GroundForces ground = GroundForces::kNone;
  GroundForceEstimateOptions estimate;  ///< for GroundForces::kEstimated
  /// Joint armature and damping are the simulation's numerical stabilisers (walking-notes.md),
  /// not body properties: off by default so the torques are the body's. On to reproduce what the
  /// simulator itself applied.
  bool include_armature_damping = false;
  /// Frames at each end dropped from the result: finite differences need neighbours.
  int trim_frames = 1;
};

/// InverseDynamicsResult::plate_foot entries besides the side (models::kLeft, models::kRight).
inline constexpr int kPlateUnloaded = -1;  ///< the plate carries less than 20 N: nothing applied
/// Loaded, but no single foot is on it (both feet share it, or the pose puts neither foot over
/// the centre of pressure): the load is not applied and stays in the root residual.
inline constexpr int kPlateUnassigned = 2;

/// Per frame (frames x columns) results, SI units.
struct InverseDynamicsResult {
  std::vector<double> times_s;
  std::vector<std::string> dof_names;  ///< nv names: root dofs, then each joint's
  /// frames x nq: the low-passed positions the velocities, accelerations and forces are for.
  Eigen::MatrixXd qpos;
  Eigen::MatrixXd qvel, qacc;  ///< frames x nv
  /// frames x nv: N (root translation) or N m (rotations) each DOF needs (root entries: the
  /// residual, in MuJoCo's free-joint frames).
  Eigen::MatrixXd generalized_force;
  Eigen::MatrixXd residual_force_N;    ///< frames x 3, world frame, on the root
  Eigen::MatrixXd residual_moment_Nm;  ///< frames x 3, world frame, about the root body origin
  Eigen::MatrixXd ground_force_N;      ///< frames x 3, world: the ground reaction applied (0: none)
  /// kEstimated: the estimate per foot and point (else empty).
  GroundForceEstimate ground_estimate;
  /// frames x plates (kForcePlates): the side whose foot carried each plate's load, or
  /// kPlateUnloaded / kPlateUnassigned.
  Eigen::MatrixXi plate_foot;
};

/// Runs inverse dynamics of `motion` (its columns must be `model`'s qpos; frames evenly spaced)
/// on `model`. `plates` (in the model's world frame) are needed for kForcePlates; their samples
/// are interpolated to the motion's times, which must be on the plates' clock (capture time).
/// Throws sim::InvalidArgument for a mismatched motion, NaN frames, uneven times, too few frames
/// or missing plates.
InverseDynamicsResult inverse_dynamics(const mjModel& model, const Motion& motion,
                                       const InverseDynamicsOptions& options,
                                       const std::vector<ForcePlate>& plates = {},
                                       double plate_rate_hz = 0.0);

/// An estimate of the ground forces (GroundForces::kEstimated) against measured force plates.
/// Frames compared: a plate is loaded, its load belongs to one foot (plate_assignment.h) and it
/// sees that whole foot (every sole point within 5 cm of its floor is over the plate).
struct PlateComparison {
  int frames = 0;
  double body_weight_N = 0;  ///< the model's m g
  /// Estimated minus measured, that foot's force; fore-aft along the pelvis's heading, lateral
  /// across it.
  double vertical_rms_N = 0, fore_aft_rms_N = 0, lateral_rms_N = 0, vertical_peak_error_N = 0;
  /// Over the compared frames where the estimate loads no other foot (single support): the
  /// plates' vertical force over the estimate's, about the subject's mass over the model's
  /// (NaN without such frames).
  double single_support_ratio = 0;
  int single_support_frames = 0;
  /// Per compared frame: time, side, and the estimated and measured force (world, N).
  std::vector<double> times_s;
  std::vector<int> sides;
  std::vector<Eigen::Vector3d> estimated_N, measured_N;
};

/// Compares `estimated` (inverse_dynamics with kEstimated on `model`) with `plates` (model
/// world, samples at `plate_rate_hz` on the motion's clock). Throws sim::InvalidArgument when
/// `estimated` has no estimate.
PlateComparison compare_with_plates(const mjModel& model, const InverseDynamicsResult& estimated,
                                    const std::vector<ForcePlate>& plates, double plate_rate_hz);

/// The names of `model`'s DOFs: root_tx, root_ty, root_tz, root_rx, root_ry, root_rz for the free
/// joint, <joint>_x/_y/_z for balls, <joint> for hinges.
std::vector<std::string> dof_names(const mjModel& model);

}  // namespace biodyn::mocap_io
