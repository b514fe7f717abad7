#pragma once
/// The paper's velocity-based joint controllers (§3), and a PD controller with the same
/// interface so the two can be compared on the same task.
///
/// Each joint group has a target orientation relative to its parent, q_d, and a time by
/// which to reach it. Paper §3.2: q_t = conj(q_c) * q_d gives axis v and angle theta, and
/// the desired relative angular velocity is w = theta v / t. Here t is the time still to go
/// until the target's reach time (never below `min_time_to_go_s`), so a joint arrives at
/// its reach time moving at a steady theta/t instead of decaying exponentially.
///
/// Velocity-based (ControllerKind::kVelocity): the torques are those the *whole* articulated
/// system needs, jointly with its contacts, to change every joint's velocity to w over
/// `velocity_horizon_s` (desired acceleration (w - omega)/horizon): sim::HybridDynamics
/// solves root acceleration, constraint forces and torques together, with the muscle limits
/// as bounds. PD (kPd): independent per-DOF torques tau = I (wn^2 e - 2 zeta wn omega) with
/// e the DOF's share of theta v and I the DOF's joint-space inertia in the reset pose.
///
/// Muscle limits (paper §3.2), applied exactly each step to either kind, per DOF:
/// |tau| <= tau_max and |tau - tau_prev| <= tau_max dt / t_r.

#include <mujoco/mujoco.h>

#include <Eigen/Geometry>
#include <cstdint>
#include <string>
#include <vector>

#include "biodyn/controllers/control_frame.h"
#include "biodyn/controllers/controller_params.h"
#include "biodyn/controllers/joint_groups.h"
#include "biodyn/sim/hybrid_dynamics.h"

namespace biodyn::controllers {

enum class ControllerKind { kVelocity, kPd };
const char* to_string(ControllerKind kind);
/// "velocity" or "pd"; throws sim::InvalidArgument naming `field` and the value.
ControllerKind parse_controller_kind(const std::string& text,
                                     const std::string& field = "controller");

/// What one compute() did.
struct JointControlStatus {
  double max_torque_ratio = 0;  ///< max over DOFs of |tau| / tau_max
  int saturated_dofs = 0;       ///< DOFs held at a muscle bound
  int solver_iterations = 0;    ///< Newton iterations of the whole-body solve
  bool converged = true;
};

/// What the joint controllers carry from one step to the next (a copyable aggregate).
struct JointControlState {
  std::vector<mjtNum> tau_prev;  ///< N m per DOF: the kept step's torques (the rate limit's start)
  std::vector<mjtNum> tau;  ///< N m per DOF: the last compute()'s torques (commit() keeps them)
};

/// Joint controllers for every group of a rig. Construct -> reset -> (compute, commit)*.
class JointController {
 public:
  /// Validates `params` against `m` (throws sim::InvalidArgument). Allocates everything.
  JointController(const mjModel& m, const models::Rig& rig, ControllerParams params,
                  ControllerKind kind);

  const std::vector<JointGroup>& groups() const { return rig_->groups(); }
  const ControllerParams& params() const { return params_; }
  ControllerKind kind() const { return kind_; }
  /// Replaces the parameters (live tuning); validated, throws InvalidArgument.
  void set_params(const ControllerParams& params);

  /// Targets in `frame` = the current pose, reach now; tau_prev = the torques that hold the
  /// current state still (the character was already standing before t = 0: its muscles carry
  /// the static load). `d` must have mj_forward run. Same for both kinds. `support_bodies` (the
  /// stance feet) choose the PD inertia: a joint with a support below it moves the rest of the
  /// body, not its own subtree.
  void reset(const mjModel& m, mjData& d, ControlFrame* frame,
             const std::vector<int>& support_bodies = {});

  /// PD kind: gains for the current supports (the feet on the ground now; the pipeline calls
  /// this each step, as a foot that leaves the floor no longer carries the body and a stance
  /// gain on its light subtree would be unstable). No allocation.
  void update_pd_gains(const mjModel& m, const mjData& d, const int* support_bodies,
                       int n_supports);

  /// Torques for the current state (call after mj_step1) reaching `frame`'s targets under its
  /// DOF commands. `qfrc_other` (nv): every other generalized force that acts in this step
  /// (the frame's extra forces, mapped pushes). Writes the muscle torques (nv; zero on the
  /// root) into `torque`. No allocation.
  JointControlStatus compute(const mjModel& m, mjData& d, const ControlFrame& frame,
                             const mjtNum* qfrc_other, mjtNum* torque);
  /// The last computed torques become tau_prev (call once the step is kept).
  void commit();

  /// N m, per DOF (0 on unactuated DOFs).
  const std::vector<mjtNum>& tau_max() const { return tau_max_; }
  const std::vector<mjtNum>& previous_torque() const { return state_.tau_prev; }
  /// Predicted accelerations of the last velocity-based solve (nv); NaN after a step in which
  /// every actuated DOF was torque-specified (the solve was skipped).
  const std::vector<mjtNum>& predicted_qacc() const { return qacc_pred_; }
  /// Desired DOF accelerations of the last compute (nv; velocity kind).
  const std::vector<mjtNum>& desired_qacc() const { return qacc_des_; }

  const JointControlState& state() const { return state_; }
  /// Takes over a state saved earlier from this controller (rewind). No allocation.
  void restore(const JointControlState& state);

 private:
  void refresh_limits(double timestep);
  // Per group: rotation vector to the target in the body frame and per-DOF velocity wish.
  void desired_motion(const mjModel& m, const mjData& d, const ControlFrame& frame);

  const models::Rig* rig_;
  ControllerParams params_;
  ControllerKind kind_;
  JointControlState state_;
  sim::HybridDynamics solver_;
  int nv_ = 0;
  double timestep_ = 0;
  std::vector<std::uint8_t> actuated_;
  std::vector<mjtNum> tau_max_, rate_, lo_, hi_;
  std::vector<mjtNum> qacc_des_, qacc_pred_, error_dof_, vel_dof_;
  std::vector<mjtNum> kp_, kd_;
  std::vector<mjtNum> zero_;
};

/// Orientation error of a group, rad: angle of conj(q_current) * q_target.
double orientation_error(const mjModel& m, const mjData& d, const JointGroup& group,
                         const JointTarget& target);

}  // namespace biodyn::controllers
