#pragma once
/// The standing controller: a pose (poses.h: anatomical angles for some joints, a reach time,
/// the feet in stance) held upright by the standing balance (capture-point PI feedback tilting
/// the stance legs, hip strategy). The control pipeline's default driver: `biodyn pose`, the end
/// of a stopped walk, the viewer's standing scenarios.

#include <Eigen/Core>
#include <vector>

#include "biodyn/controllers/control_driver.h"
#include "biodyn/controllers/poses.h"
#include "biodyn/models/rig.h"

namespace biodyn::controllers {

/// What the standing controller carries from one step to the next (a copyable aggregate).
struct StandingControllerState {
  Pose pose;                                 ///< the pose being held
  double pose_start_s = 0;                   ///< s, when it began
  std::vector<Eigen::Vector3d> base_angles;  ///< rad, per group: the pose's angles
  BalanceOffsets offsets;                    ///< the balance's offsets of the last step
  StandingBalanceState balance;
};

class StandingController : public ControlDriver {
 public:
  /// Throws models::RigError without a pelvis and feet, sim::InvalidArgument for bad params.
  StandingController(const mjModel& m, const models::Rig& rig, BalanceParams balance);

  const StandingBalance& balance() const { return balance_; }
  const Pose& pose() const { return state_.pose; }
  const BalanceOffsets& offsets() const { return state_.offsets; }

  /// Back to the initial pose ("initial": every angle zero) from `time_s`; integrators cleared.
  void reset(double time_s);
  /// Starts the balance integrator holding the sagittal tilt of place_in_pose.
  void preset_sagittal_tilt(double tilt_rad) { balance_.preset_sagittal_tilt(tilt_rad); }
  /// Starts `pose` at `time_s`: its targets are due at time_s + reach_time_s.
  void set_pose(const Pose& pose, double time_s);

  /// Balance offsets from the capture point, then every joint's target: the pose's angles plus
  /// the offsets on the stance legs' ankles and hips.
  void drive(const ControlInput& in, ControlFrame* frame) override;

  /// The state aggregate (the balance's included).
  StandingControllerState state() const;
  void restore(const StandingControllerState& state);

 private:
  void apply_targets(ControlFrame* frame) const;

  const models::Rig* rig_;
  StandingBalance balance_;
  StandingControllerState state_;  // its `balance` is balance_'s, filled by state()
  int group_ankle_[2] = {-1, -1}, group_hip_[2] = {-1, -1};
};

}  // namespace biodyn::controllers
