#pragma once
/// The control pipeline: everything that drives a generated character for one physics step,
/// as stages that write into one control frame (control_frame.h). Per step, inside
/// Simulation::step between mj_step1 and mj_step2:
///
///   1. the driver (a ControlDriver: the standing controller with its balance, a walker, a
///      motion tracker) sets targets, DOF commands and stance wishes;
///   2. the foot welds take the stance wishes and switch on at foot strikes (foot_contact.h);
///   3. the swing-twist limits add their torques to the frame's extra forces (joint_limits.h);
///   4. the joint controllers solve for the muscle torques (velocity-based whole-body solve or
///      PD) within tau_max and the reaction-time rate limit, with the extra forces and pushes
///      acting (joint_controller.h);
///   5. with Hill muscles (config.muscles), the torques of step 4 on the legs are what is
///      wanted: the muscles share them through activation dynamics and the Hill model, the
///      backups add what they cannot within their range (muscles/muscle_drive.h);
///   6. qfrc_applied = extra forces + joint (or muscle and backup) torques; nothing acts on the
///      free root.
///
/// After mj_step2 the welds' wrenches are measured; in honest mode a step with a weld in tension
/// is undone (the simulation's StateSnapshot, one aggregate) and taken again with that weld off,
/// so no kept step has a weld in tension. A redone step calls every stage again at the same
/// time: stages advance their state once per time (the balance integrates once, a walker's
/// heading turns once), so the second call writes what the first would have for that state.
///
/// Parameters (validated, fixed within a step) and state (ControlState, one copyable aggregate)
/// are apart: a rewind saves state() and restore()s it.

#include <array>
#include <memory>
#include <vector>

#include "biodyn/controllers/control_driver.h"
#include "biodyn/controllers/control_frame.h"
#include "biodyn/controllers/controller_params.h"
#include "biodyn/controllers/foot_contact.h"
#include "biodyn/controllers/joint_controller.h"
#include "biodyn/controllers/joint_limits.h"
#include "biodyn/controllers/poses.h"
#include "biodyn/controllers/standing_controller.h"
#include "biodyn/models/rig.h"
#include "biodyn/muscles/muscle_drive.h"
#include "biodyn/sim/simulation.h"
#include "biodyn/sim/snapshot.h"

namespace biodyn::controllers {

/// Choices fixed for a run (the weld mode may be edited live: set_weld_mode).
struct ControlPipelineConfig {
  ControllerKind kind = ControllerKind::kVelocity;
  FootWeldParams weld;
  BalanceParams balance;
  /// The legs' Hill muscles (muscles/muscle_drive.h), named as the model's spatial tendons:
  /// empty = no muscles (the joint controllers' torques act directly). With muscles, the
  /// controllers' torques on the DOFs the muscles span are what is wanted: the muscles share it
  /// and the backups give what they cannot, within their range.
  std::vector<muscles::MuscleParams> muscles;
  muscles::MuscleDriveParams muscle_drive;
};

/// Everything of the pipeline that changes from step to step, in one copyable aggregate (the
/// driver's own state is the driver's: a scenario keeps both).
struct ControlState {
  ControlFrame frame;
  JointControlState joints;
  FootWeldState welds;
  StandingControllerState standing;
  StepReport last_report;
  muscles::MuscleDriveState muscles;  ///< empty without muscles
};

class ControlPipeline {
 public:
  /// Builds the stages for `sim`'s model (a generated character, resolved in `rig`; both must
  /// outlive the pipeline). Throws sim::InvalidArgument (models::RigError) for bad parameters
  /// or a model without the parts the stages need.
  ControlPipeline(sim::Simulation* sim, const models::Rig& rig, ControllerParams params,
                  ControlPipelineConfig config);

  const models::Rig& rig() const { return *rig_; }
  const std::vector<JointGroup>& groups() const { return rig_->groups(); }
  const JointController& joints() const { return joints_; }
  const FootWelds& welds() const { return welds_; }
  const StandingController& standing() const { return standing_; }
  const StandingBalance& balance() const { return standing_.balance(); }
  /// The muscles, or nullptr (config().muscles empty).
  const muscles::MuscleDrive* muscles() const { return muscles_.get(); }
  const ControlPipelineConfig& config() const { return config_; }
  const ControlFrame& frame() const { return frame_; }
  sim::Simulation& simulation() { return *sim_; }
  const sim::Simulation& simulation() const { return *sim_; }

  /// Live tuning: new joint parameters (validated; throws InvalidArgument).
  void set_params(const ControllerParams& params);
  void set_weld_mode(WeldMode mode);

  /// Call after sim->reset(): targets = current pose, holding torques, welds off, balance
  /// integrators cleared, the standing controller driving.
  void reset();
  /// Places the character at rest in `pose` (place_in_pose: feet flat, CoM over the support
  /// point), then reset(), with the balance integrator holding that lean, and set_pose(pose).
  /// How every standing scenario starts.
  void reset_in_pose(const Pose& pose);
  /// The standing controller starts `pose` now: its targets are due at time() + reach_time_s;
  /// the feet take its stance at once.
  void set_pose(const Pose& pose);
  /// Foot `side` wanted in stance or swing now (outside a step; a driver writes its frame).
  void set_stance(int side, bool stance);

  /// One physics step of the simulation with the controllers. No allocation.
  StepReport step();

  /// Hands the targets to `driver` (nullptr: back to the standing controller). The driver must
  /// outlive its use.
  void set_driver(ControlDriver* driver) { driver_ = driver; }
  /// The driver set with set_driver (nullptr: the standing controller drives).
  ControlDriver* driver() const { return driver_; }
  const StepReport& last_report() const { return last_report_; }

  /// rad: angle from group `group`'s orientation now to its target.
  double orientation_error(int group) const;

  /// The state aggregate (copy it to rewind).
  ControlState state() const;
  /// Takes over a state saved from this pipeline; with the simulation restored to the same
  /// moment (sim::Simulation::restore), the following steps repeat bit for bit.
  void restore(const ControlState& state);

 private:
  void control(mjData& d);

  sim::Simulation* sim_;
  const models::Rig* rig_;
  ControlPipelineConfig config_;
  ControlFrame frame_;
  JointController joints_;
  SwingTwistLimiter limiter_;
  FootWelds welds_;
  StandingController standing_;
  ControlDriver* driver_ = nullptr;
  sim::StateSnapshot snapshot_;
  StepReport last_report_;
  JointControlStatus last_status_;
  int last_outside_ = 0;
  std::unique_ptr<muscles::MuscleDrive> muscles_;
  std::vector<mjtNum> qfrc_other_, torque_, applied_;  // nv scratch
  std::vector<int> joint_motors_;  // actuators on joints: their torques go through qfrc_applied
};

}  // namespace biodyn::controllers
