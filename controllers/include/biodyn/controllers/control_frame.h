#pragma once
/// The control frame: what the stages of one control step tell the joint controllers, and the
/// generalized forces they add. One frame per character; ControlPipeline::step runs, inside
/// Simulation::step after mj_step1:
///
///   1. begin_step(): the per-step part is cleared (DOF commands, extra forces, stance wishes);
///   2. the driver (standing controller, walker or motion tracker) sets the joints' targets,
///      per-DOF commands and the feet's stance wishes;
///   3. the foot-weld logic takes the stance wishes; the swing-twist limits add their torques to
///      the extra forces;
///   4. the joint controllers reach the targets under the commands (paper §3.2: velocity wish
///      w = theta v / t, or what a command says instead) within the muscle limits, with every
///      extra force (and the pushes) acting in the whole-body solve;
///   5. with muscles (control_pipeline.h) the legs' joint torques are what the muscles are asked
///      for: they and the backups give them;
///   6. qfrc_applied = extra forces + joint torques: sources add up, none overwrites another.
///
/// The targets persist from step to step (a target state holds until another is set, paper
/// §3); everything else lasts one step. The frame is part of the pipeline's copyable state.

#include <mujoco/mujoco.h>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <limits>
#include <vector>

#include "biodyn/models/rig.h"

namespace biodyn::controllers {

/// A joint group's target (paper §3.1): its orientation relative to its parent and the time by
/// which to reach it.
struct JointTarget {
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();  ///< relative to the parent
  double reach_at_s = 0.0;  ///< s, simulation time by which to reach it
};

/// How a DOF's muscle torque is chosen this step. A DOF given several modes in one step keeps the
/// last in this list (free over spring over velocity over target), whatever the order they came.
enum class DofMode : std::uint8_t {
  /// Reach the group's target: relative velocity wish w = theta v / t_go (paper §3.2).
  kTarget,
  /// An explicit relative velocity wish (rad/s; a ball group's in its body frame) in place of
  /// w = theta v / t_go, e.g. a target held in the world frame whose parent's rotation is fed
  /// forward.
  kVelocity,
  /// Compliant: the spring-damper tau = stiffness e - damping omega (e the DOF's share of the
  /// rotation to the target) inside the muscle limits, instead of a prescribed acceleration.
  /// For a leg whose foot is on the floor: prescribing its accelerations closes a loop through
  /// the ground (SIMBICON's stance leg is a spring for the same reason, Yin et al. 2007).
  kSpring,
  /// No muscle torque at all (tau = 0, outside the rate limit too): the DOF is left to other
  /// force sources and the solve.
  kFree,
};

/// One DOF's command for one step. A torque window applies on top of the muscle limits in
/// every mode but kFree (a prescribed torque is a window of zero width); if the muscle's
/// reachable range misses the window, the torque is the end of that range nearest to it.
struct DofCommand {
  DofMode mode = DofMode::kTarget;
  /// An explicit velocity wish was given (rad/s; set_velocity raises the mode to kVelocity). It
  /// stays the DOF's acceleration wish in the whole-body solve even when a spring takes over
  /// its torque: the solve projects every wish onto the welds' constraints.
  bool has_velocity = false;
  double velocity_rad_s = 0;
  double stiffness_Nm_per_rad = 0;                                  ///< kSpring
  double damping_Nm_s_per_rad = 0;                                  ///< kSpring
  double torque_min_Nm = -std::numeric_limits<double>::infinity();  ///< window, N m
  double torque_max_Nm = std::numeric_limits<double>::infinity();   ///< window, N m
};

class ControlFrame {
 public:
  ControlFrame() = default;
  /// A frame for the rig's joint groups on a model with `nv` DOFs; targets at the rest pose.
  ControlFrame(const models::Rig& rig, int nv);

  /// Clears the per-step part (DOF commands, extra forces, stance wishes). No allocation.
  void begin_step();

  // --- Targets (persist) ---
  /// Group `group`'s target orientation (normalised), due at `reach_at_s`.
  void set_target(int group, const Eigen::Quaterniond& orientation, double reach_at_s);
  /// The same from anatomical angles (joint_groups.h), hinges kept kTargetLimitMargin_rad inside
  /// their stops (a target on a stop is never reached: the limit spring starts there).
  void set_joint_angles(int group, Eigen::Vector3d angles_rad, double reach_at_s);
  const JointTarget& target(int group) const { return targets_[static_cast<std::size_t>(group)]; }
  static constexpr double kTargetLimitMargin_rad = 2.0 * 3.14159265358979323846 / 180.0;

  // --- Per-DOF commands (this step) ---
  /// Prescribes DOF `dof`'s torque (N m), still within the muscle limits.
  void set_torque(int dof, double torque_Nm) { limit_torque(dof, torque_Nm, torque_Nm); }
  /// Narrows DOF `dof`'s torque to [lo, hi] (N m), intersected with any window set before.
  void limit_torque(int dof, double lo_Nm, double hi_Nm);
  /// Makes group `group` compliant (DofMode::kSpring), N m/rad and N m s/rad (negative: 0).
  void set_spring(int group, double stiffness_Nm_per_rad, double damping_Nm_s_per_rad);
  /// A ball group's relative velocity wish, body frame (DofMode::kVelocity); hinges: ignored.
  void set_velocity(int group, const Eigen::Vector3d& w_body_rad_s);
  /// DOF `dof` gets no muscle torque (DofMode::kFree).
  void set_free(int dof);
  const DofCommand& command(int dof) const { return dofs_[static_cast<std::size_t>(dof)]; }

  // --- Extra generalized forces (this step) ---
  /// N m (or N) per DOF, summed over every source that is not a joint controller.
  mjtNum* qfrc_extra() { return qfrc_extra_.data(); }
  const mjtNum* qfrc_extra() const { return qfrc_extra_.data(); }

  // --- Feet (this step) ---
  /// Foot `side` wanted in stance (may weld at strike) or swing (weld released).
  void set_stance(int side, bool stance) {
    stance_wish_[static_cast<std::size_t>(side)] = stance ? 1 : 0;
  }
  /// The wish of this step: 1 stance, 0 swing, -1 none (the feet stay as they are).
  int stance_wish(int side) const { return stance_wish_[static_cast<std::size_t>(side)]; }

 private:
  const models::Rig* rig_ = nullptr;
  std::vector<JointTarget> targets_;  // per group
  std::vector<DofCommand> dofs_;      // per DOF (nv; the root's unused)
  std::vector<mjtNum> qfrc_extra_;    // nv
  std::array<std::int8_t, 2> stance_wish_ = {-1, -1};
};

}  // namespace biodyn::controllers
