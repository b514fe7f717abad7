#pragma once
/// Everything that drives a generated character for one step: the pose (targets), standing
/// balance, swing-twist joint limits, the joint controllers and the foot welds.
///
/// Per step (inside Simulation::step, between mj_step1 and mj_step2):
///   1. balance offsets from the capture point -> targets of every joint (pose + offsets);
///   2. welds switch on at foot strikes (from the current pose, active next step);
///   3. swing-twist limit torques; pushes mapped to generalized forces;
///   4. joint torques (velocity-based whole-body solve or PD) with the muscle limits;
///   5. qfrc_applied = limit torques + muscle torques (zero on the free root: no helping hand).
/// After mj_step2 the welds' wrenches are measured; in honest mode a step with a weld in
/// tension is undone and repeated with that weld off (so it never counts a tension step).

#include <array>
#include <memory>
#include <string>
#include <vector>

#include "biodyn/controllers/controller_params.h"
#include "biodyn/controllers/foot_contact.h"
#include "biodyn/controllers/joint_controller.h"
#include "biodyn/controllers/joint_limits.h"
#include "biodyn/controllers/poses.h"
#include "biodyn/sim/simulation.h"
#include "biodyn/sim/snapshot.h"

namespace biodyn::controllers {

class CharacterController;

/// Something that sets the joint targets each step in place of the pose and standing balance
/// (the gait controller). Called inside the step (after mj_step1, before the torques); in
/// honest weld mode a step may be taken again from the same state, so drive() must give the
/// same targets when called twice at the same time. No allocation.
class TargetDriver {
 public:
  virtual ~TargetDriver() = default;
  virtual void drive(CharacterController& controller, const mjModel& m, const mjData& d) = 0;
};

/// Choices fixed for a run.
struct CharacterControllerConfig {
  ControllerKind kind = ControllerKind::kVelocity;
  FootWeldParams weld;
  BalanceParams balance;
};

/// What one step did.
struct StepReport {
  sim::StepStatus status;          ///< MuJoCo warnings of the kept step
  JointControlStatus joints;       ///< torque ratios, saturation, solver iterations
  std::array<WeldWrench, 2> weld;  ///< each foot weld's wrench (zero when off)
  std::array<bool, 2> weld_active = {false, false};
  bool weld_tension = false;       ///< a kept step with a weld in tension (glue mode only)
  int redone = 0;                  ///< honest-mode redos of this step
  int joints_outside_limits = 0;   ///< ball joints outside their swing-twist limits
  BalanceOffsets balance;
};

class CharacterController {
 public:
  /// Builds controllers for `sim`'s model (a generated character). Throws
  /// sim::InvalidArgument for bad parameters.
  CharacterController(sim::Simulation* sim, ControllerParams params,
                      CharacterControllerConfig config);

  const std::vector<JointGroup>& groups() const { return joints_.groups(); }
  const JointController& joints() const { return joints_; }
  const FootWelds& welds() const { return welds_; }
  const StandingBalance& balance() const { return balance_; }
  const CharacterControllerConfig& config() const { return config_; }
  const Pose& pose() const { return pose_; }

  /// Live tuning: new joint parameters (validated; throws InvalidArgument).
  void set_params(const ControllerParams& params);
  void set_weld_mode(WeldMode mode);

  /// Call after sim->reset(): targets = current pose, holding torques, welds off, balance
  /// integrators cleared.
  void reset();

  /// Places the character at rest in `pose` (place_in_pose: feet flat, CoM over the
  /// support point), then reset(), with the balance integrator holding that lean, and
  /// set_pose(pose). How every standing scenario starts.
  void reset_in_pose(const Pose& pose);

  /// Starts `pose` now: its targets are due at time() + reach_time_s.
  void set_pose(const Pose& pose);

  /// One physics step of the simulation with the controllers. No allocation.
  StepReport step();

  /// Hands the targets to `driver` (nullptr: back to the pose and standing balance). The
  /// driver must outlive its use.
  void set_driver(TargetDriver* driver) { driver_ = driver; }
  TargetDriver* driver() const { return driver_; }

  // For drivers (inside drive()):
  /// Group `group`'s target, due at `reach_at_s`; hinge angles are clamped inside the stops
  /// when given as angles (set_joint_angles).
  void set_joint_target(int group, const Eigen::Quaterniond& orientation, double reach_at_s);
  void set_joint_angles(int group, Eigen::Vector3d angles_rad, double reach_at_s);
  /// Foot `side` (0 left, 1 right) wanted in stance (may weld at strike) or swing (released).
  void set_stance(int side, bool stance);
  /// See JointController::limit_torque_once.
  void limit_torque_once(int dof, double lo, double hi) { joints_.limit_torque_once(dof, lo, hi); }
  /// See JointController::set_compliant_once.
  void set_compliant_once(int group, double stiffness, double damping) {
    joints_.set_compliant_once(group, stiffness, damping);
  }
  /// See JointController::set_velocity_once.
  void set_velocity_once(int group, const Eigen::Vector3d& w_body) { joints_.set_velocity_once(group, w_body); }
  sim::Simulation& simulation() { return *sim_; }
  const StepReport& last_report() const { return last_report_; }
  /// Takes over the whole state of `saved` (a copy of this controller made earlier: targets,
  /// welds, balance integrators, parameters), keeping this controller's simulation and driver.
  /// With the simulation restored to the same moment (sim::Simulation::restore), the following
  /// steps repeat bit for bit (rewind: scenarios/live.h).
  void restore_state(const CharacterController& saved);

 private:
  void control(mjData& d, bool* outside);
  void apply_targets();

  sim::Simulation* sim_;
  CharacterControllerConfig config_;
  JointController joints_;
  SwingTwistLimiter limiter_;
  FootWelds welds_;
  StandingBalance balance_;
  sim::StateSnapshot snapshot_;
  Pose pose_;
  std::vector<Eigen::Vector3d> base_angles_;  // per group, rad
  double pose_start_s_ = 0;
  BalanceOffsets offsets_;
  std::vector<mjtNum> qfrc_limit_, qfrc_other_, torque_;
  int group_ankle_[2] = {-1, -1}, group_hip_[2] = {-1, -1};
  int foot_[2] = {-1, -1};  // body ids of foot_l, foot_r
  int floor_geom_ = -1;
  JointControlStatus last_status_;
  TargetDriver* driver_ = nullptr;
  StepReport last_report_;
  int last_outside_ = 0;
};

}  // namespace biodyn::controllers
