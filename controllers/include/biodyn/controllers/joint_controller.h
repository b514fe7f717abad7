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

#include "biodyn/controllers/controller_params.h"
#include "biodyn/controllers/joint_groups.h"
#include "biodyn/sim/hybrid_dynamics.h"

namespace biodyn::controllers {

enum class ControllerKind { kVelocity, kPd };
const char* to_string(ControllerKind kind);
/// "velocity" or "pd"; throws sim::InvalidArgument naming `field` and the value.
ControllerKind parse_controller_kind(const std::string& text,
                                     const std::string& field = "controller");

/// A joint's current target.
struct JointTarget {
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();  ///< relative to parent
  double reach_at_s = 0.0;  ///< s, simulation time by which to reach it
};

/// What one compute() did.
struct JointControlStatus {
  double max_torque_ratio = 0;  ///< max over DOFs of |tau| / tau_max
  int saturated_dofs = 0;       ///< DOFs held at a muscle bound
  int solver_iterations = 0;    ///< Newton iterations of the whole-body solve
  bool converged = true;
};

/// Joint controllers for every group of a model. Construct -> reset -> (compute, commit)*.
class JointController {
 public:
  /// Validates `params` against `m` (throws sim::InvalidArgument). Allocates everything.
  JointController(const mjModel& m, std::vector<JointGroup> groups, ControllerParams params,
                  ControllerKind kind);

  const std::vector<JointGroup>& groups() const { return groups_; }
  const ControllerParams& params() const { return params_; }
  ControllerKind kind() const { return kind_; }
  /// Replaces the parameters (live tuning); validated, throws InvalidArgument.
  void set_params(const ControllerParams& params);

  void set_target(int group, const Eigen::Quaterniond& orientation, double reach_at_s);

  /// Narrows DOF `dof`'s torque bounds to [lo, hi] for the next compute() only, on top of the
  /// muscle limits (e.g. a stance ankle held to what the centre of pressure under the foot
  /// can give). If the muscle's reachable range misses the window, the torque goes to the
  /// end of that range nearest to it. No allocation.
  void limit_torque_once(int dof, double lo, double hi);
  /// For the next compute() only, group `group` is compliant: its torque is the spring-damper
  /// tau = stiffness * e - damping * omega (e the DOF's share of the rotation to the target,
  /// N m/rad and N m s/rad) inside the muscle limits and any torque window, instead of what
  /// a prescribed acceleration needs. For a leg whose foot is on the floor: prescribing its
  /// joints' accelerations closes a kinematic loop through the ground, and the solve meets
  /// them by moving the whole body (SIMBICON's stance leg is a spring for the same reason,
  /// Yin et al. 2007). No allocation.
  void set_compliant_once(int group, double stiffness, double damping);
  /// For the next compute() only, a ball group's desired relative angular velocity (its
  /// body frame, rad/s) in place of w = theta v / t_go: for targets held in the world frame,
  /// where the parent's own rotation must be fed forward (e.g. the stance hip that holds the
  /// pelvis's world posture while the thigh turns under it). No allocation.
  void set_velocity_once(int group, const Eigen::Vector3d& w_body);
  const JointTarget& target(int group) const { return targets_[static_cast<std::size_t>(group)]; }

  /// Targets = the current pose, reach now; tau_prev = the torques that hold the current
  /// state still (the character was already standing before t = 0: its muscles carry the
  /// static load). `d` must have mj_forward run. Same for both kinds. `support_bodies`
  /// (the stance feet) choose the PD inertia: a joint with a support below it moves the rest
  /// of the body, not its own subtree.
  void reset(const mjModel& m, mjData& d, const std::vector<int>& support_bodies = {});

  /// PD kind: gains for the current supports (the feet on the ground now; the controller
  /// calls this each step, as a foot that leaves the floor no longer carries the body and a
  /// stance gain on its light subtree would be unstable). No allocation.
  void update_pd_gains(const mjModel& m, const mjData& d, const int* support_bodies, int n_supports);

  /// Torques for the current state (call after mj_step1). `qfrc_other` (nv): every other
  /// generalized force that acts in this step (joint-limit forces, mapped pushes). Writes
  /// the muscle torques (nv; zero on the root) into `torque`. No allocation.
  JointControlStatus compute(const mjModel& m, mjData& d, const mjtNum* qfrc_other,
                             mjtNum* torque);
  /// The last computed torques become tau_prev (call once the step is kept).
  void commit();

  /// N m, per DOF (0 on unactuated DOFs).
  const std::vector<mjtNum>& tau_max() const { return tau_max_; }
  const std::vector<mjtNum>& previous_torque() const { return tau_prev_; }
  /// Predicted accelerations of the last velocity-based solve (nv); NaN after a step in which
  /// every actuated DOF was torque-specified (the solve was skipped).
  const std::vector<mjtNum>& predicted_qacc() const { return qacc_pred_; }
  /// Desired DOF accelerations of the last compute (nv; velocity kind).
  const std::vector<mjtNum>& desired_qacc() const { return qacc_des_; }

  /// Orientation error of a group, rad: angle of conj(q_current) * q_target.
  double orientation_error(const mjModel& m, const mjData& d, int group) const;

 private:
  void refresh_limits(double timestep);
  // Per group: rotation vector to the target in the body frame and per-DOF velocity wish.
  void desired_motion(const mjModel& m, const mjData& d);

  std::vector<JointGroup> groups_;
  ControllerParams params_;
  ControllerKind kind_;
  std::vector<JointTarget> targets_;
  sim::HybridDynamics solver_;
  int nv_ = 0;
  double timestep_ = 0;
  std::vector<std::uint8_t> actuated_;
  std::vector<mjtNum> tau_max_, rate_, tau_prev_, tau_, lo_, hi_;
  std::vector<mjtNum> qacc_des_, qacc_pred_, error_dof_, vel_dof_;
  std::vector<mjtNum> kp_, kd_;
  std::vector<mjtNum> window_lo_, window_hi_;  // limit_torque_once, +-inf when unset
  std::vector<mjtNum> compliant_kp_, compliant_kd_;  // set_compliant_once, 0 when unset
  std::vector<mjtNum> velocity_once_;                // set_velocity_once, per DOF
  std::vector<std::uint8_t> has_velocity_once_;
  std::vector<mjtNum> zero_;
};

}  // namespace biodyn::controllers
