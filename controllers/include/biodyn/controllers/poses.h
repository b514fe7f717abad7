#pragma once
/// Pose sequences and the standing balance that keeps them upright.
///
/// A pose is a target state (paper §3, Fig. 2): anatomical angles for some joints (the others
/// stand straight), a reach time, which feet are in stance, and over which support the centre
/// of mass should be held. A sequence plays poses in order; each lasts `duration_s` and its
/// targets are due `reach_time_s` after it starts.
///
/// Standing balance (ankle and hip strategies, Horak & Nashner 1986) works on the targets, as
/// the paper's balance does: the capture point xi = c + v/omega0 (omega0 = sqrt(g/z_c),
/// Pratt 2006) is compared with the chosen support centre; the error tilts the stance legs
/// about the ankles (sagittal theta, frontal phi; the trunk is kept upright by the hips) with
/// proportional-integral feedback (tilt the ankle cannot take goes to hip flexion, see
/// CharacterController), and a large forward capture-point error adds hip flexion (hip
/// strategy: the trunk's forward rotation pushes the feet back against the floor).
/// No force acts on the root: the joint controllers turn the new targets into torques.

#include <mujoco/mujoco.h>

#include <Eigen/Core>
#include <array>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include "biodyn/controllers/joint_groups.h"

namespace biodyn::controllers {

/// Where the balance holds the centre of mass.
enum class Support { kBoth, kLeft, kRight };

/// One target state.
struct Pose {
  std::string name;
  double duration_s = 1.0;    ///< s, time until the next pose starts, > 0
  double reach_time_s = 0.5;  ///< s, the targets are due this long after the pose starts
  /// Joint name -> anatomical angles, rad (hinges: one per DOF in model order; ball joints:
  /// flexion, abduction, internal rotation). Joints not listed: 0 (upright standing).
  std::map<std::string, Eigen::Vector3d> angles_rad;
  std::array<bool, 2> stance = {true, true};  ///< feet wanted on the ground (left, right)
  Support support = Support::kBoth;
};

/// The built-in scenarios of `biodyn pose`: "stand", "squat", "reach", "one-leg".
std::vector<std::string> pose_scenario_names();
/// The poses of a scenario for the model's joints; `duration_s` stretches the final hold so
/// the whole sequence lasts that long (if longer than the poses). Throws
/// sim::InvalidArgument for an unknown scenario or one the model cannot do (reach needs arms).
std::vector<Pose> pose_scenario(const std::string& name, const std::vector<JointGroup>& groups,
                                double duration_s);

/// Gains of the standing balance.
struct BalanceParams {
  bool enabled = true;
  double proportional = 1.0;  ///< leg tilt per capture-point error, in units of error / leg length
  double integral_per_s = 2.0;  ///< 1/s, integral gain (removes a steady CoM offset)
  double max_tilt_rad = 0.25;   ///< rad, bound on the sagittal and frontal leg tilts
  /// Hip strategy, forward errors only: hip flexion per metre of forward capture-point error
  /// beyond `hip_threshold_fraction` of the half foot length, rad/m. Backward it is off: the
  /// extension it would ask for leans the trunk back, which statically moves the CoM further
  /// back; measured on the default body, it lowered the largest backward 0.2 s pelvis push
  /// survived from 190 N to 160 N (and raised forward from 230 N to 240 N).
  double hip_gain_rad_per_m = 4.0;
  double hip_threshold_fraction = 0.5;
  double max_hip_rad = 0.6;
  /// Where along each sole (0 heel, 1 toe tip) the CoM is held. People stand with the CoM
  /// about 40% of the foot length in front of the heel (a few cm ahead of the ankle,
  /// Winter 1995), not over the middle of a sole that includes the toes.
  double support_point_fraction = 0.4;
  void validate() const;  ///< throws sim::InvalidArgument
};

/// Puts the character into `pose` at rest, as if it had been standing so before t = 0: joint
/// angles from the pose (hinges clamped inside their stops), both feet flat with the soles at
/// their rest height, and the stance legs leaned about the ankles (trunk kept upright by the
/// hips) so the CoM is over the balance's support point. Keeps the root's x, y; zero
/// velocities; runs mj_forward. Returns the sagittal lean it chose, rad.
double place_in_pose(const mjModel& m, mjData& d, const models::Rig& rig, const Pose& pose,
                     const BalanceParams& balance);

/// Offsets the balance adds to the stance legs, rad.
struct BalanceOffsets {
  double sagittal_tilt = 0;  ///< legs lean forward (+) about the ankles
  double frontal_tilt = 0;   ///< legs lean to the left (+)
  double hip_flexion = 0;    ///< hip strategy, both stance hips
};

/// What the standing balance carries from one step to the next (a copyable aggregate).
struct StandingBalanceState {
  Eigen::Vector2d integral = Eigen::Vector2d::Zero();  ///< m s, capture-point error integral
  /// The integral when the step at last_update_s began: a step taken again at the same time (an
  /// honest weld's redo) integrates from here once more, not twice.
  Eigen::Vector2d integral_at_step_start = Eigen::Vector2d::Zero();
  double last_update_s = std::numeric_limits<double>::quiet_NaN();  ///< s, NaN before the first
  Eigen::Vector2d error = Eigen::Vector2d::Zero();   ///< m, capture-point error, heading frame
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();  ///< m, support centre, world
};

/// Standing balance (the capture-point PI feedback). reset() -> update() each step.
class StandingBalance {
 public:
  /// Throws models::RigError without a pelvis and feet, sim::InvalidArgument for bad params.
  StandingBalance(const mjModel& m, const models::Rig& rig, BalanceParams params);
  const BalanceParams& params() const { return params_; }
  void set_params(const BalanceParams& params);
  void reset();
  /// Starts the integrator so that, with the CoM on its support point, the balance asks for
  /// this sagittal tilt (after place_in_pose).
  void preset_sagittal_tilt(double tilt_rad);
  /// Offsets for the current state (after mj_step1) holding the CoM over `support` with the
  /// given feet in stance. Also reports the capture-point error (m, heading frame) and the
  /// support centre (world). Called again at the same time (a redone step) it gives what the
  /// first call would have given for that state: the integral is not counted twice.
  BalanceOffsets update(const mjModel& m, const mjData& d, Support support, double dt);
  const Eigen::Vector2d& capture_point_error() const { return state_.error; }
  const Eigen::Vector2d& support_centre_W() const { return state_.centre; }

  const StandingBalanceState& state() const { return state_; }
  void restore(const StandingBalanceState& state) { state_ = state; }

 private:
  BalanceParams params_;
  StandingBalanceState state_;
  int foot_[2] = {-1, -1};
  int pelvis_ = -1;
  Eigen::Vector3d support_point_B_[2];  // balance point on each sole, foot frame (m)
  double foot_half_length_ = 0.1;
  double leg_length_ = 0.9;
};

}  // namespace biodyn::controllers
