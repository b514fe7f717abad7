#pragma once
/// The velocity-based walker (paper §4, extended to 3D): a finite-state machine of phases (the
/// paper's target states, velocity_walker_params.h) drives the velocity-based joint controllers
/// (paper §3); foot placement in both planes keeps balance. It is the paper's method and does
/// not walk yet (controllers/README.md); the torque walker (torque_walker.h) is the state machine
/// that walks, on the same gait core (gait_core.h).
///
/// Per step, inside ControlPipeline::step (a ControlDriver):
///  1. The phase machine advances on time or on the swing foot's strike (gait core: touching
///     the floor after having left it, no earlier than min_swing_fraction of the phase; which
///     swaps the stance side). The commanded speed is approached at a ramp; the heading turns
///     at the commanded rate.
///  2. Tabled targets (relative to the parent) for every joint by role: stance_/swing_<joint>.
///  3. The pelvis is held at its world target (upright, a speed-dependent forward pitch, the
///     heading's yaw) by the stance hip: its target is the relative orientation between the
///     desired pelvis and the stance thigh as it is (paper §4.1: "the stance thigh joint is in
///     charge to control the orientation of the hip"; the paper got the global orientation
///     from the gluing weld, here it is read from the state, so it works without a weld).
///  4. The swing thigh's target is in the heading frame (SIMBICON, Yin et al. 2007), from the
///     table early in the swing and from the foot placement late in it.
///  5. Foot placement (beyond the paper, which walked in the sagittal plane with a gluing weld;
///     without glue the CoM velocity has to be fed back): the strike is planned at the
///     capture point (Pratt 2006) of the linear inverted pendulum, xi = c + v/omega0, less
///     the offset that keeps a steady gait at the commanded speed and step width:
///       x_foot = c_x + k v_x/omega0 - (v_cmd/omega0)(1 - tanh(omega0 T/2))
///       y_foot = c_y + k v_y/omega0 + sigma (w/2)(1 - tanh(omega0 T/2))
///     (T the step time from the cadence table, w the step width, sigma +1 for a left swing;
///     both offsets are the LIP's steady orbit). On top, the paper's base-polygon rule (§4.3,
///     gait core: the same rule as the torque walker's) moves the strike at least as far as it
///     asks, ahead, behind or aside. With stepping stones the sagittal target is the stone.
///  6. The 2D IK triangle of paper §4.2 (thigh, shank, and the hip-to-ankle line) turns the
///     strike point into swing hip flexion and knee flexion; a point out of reach gives the
///     closest reachable pose (the leg straightened to the strike knee angle, pointing at it).
///  7. Each ankle of a foot on the floor gets a torque window: what the ground can return
///     with the centre of pressure inside the actual contact points (cop_margin of their
///     extent) under the foot's measured load. The foot then stays flat and the body rolls
///     over it as an inverted pendulum instead of the whole body tipping rigidly about a sole
///     edge (why single support failed with every joint's acceleration prescribed).
///
/// No force on the root; every torque comes from the joint controllers within muscle limits.

#include <mujoco/mujoco.h>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cmath>
#include <string>
#include <vector>

#include "biodyn/controllers/control_driver.h"
#include "biodyn/controllers/gait_core.h"
#include "biodyn/controllers/joint_groups.h"
#include "biodyn/controllers/velocity_walker_params.h"
#include "biodyn/models/rig.h"
#include "biodyn/sim/queries.h"

namespace biodyn::controllers {

/// What the walker is asked to do.
struct GaitCommand {
  double speed_m_s = 1.0;           ///< forward speed, m/s, >= 0
  double heading_rate_rad_s = 0.0;  ///< turning rate, rad/s (positive to the left)
  /// Stepping stones: successive step lengths along the heading (foot origin to foot origin),
  /// m; free walking when empty or once they are used up.
  std::vector<double> step_lengths_m;
  void validate() const;  ///< throws sim::InvalidArgument
};

/// One foot strike.
struct StrikeEvent {
  int index = -1;  ///< 0, 1, ... in order
  double time_s = 0;
  int side = 0;                                       ///< the foot that struck (0 left, 1 right)
  Eigen::Vector3d foot_W = Eigen::Vector3d::Zero();   ///< its foot origin (ankle), world
  Eigen::Vector3d other_W = Eigen::Vector3d::Zero();  ///< the stance foot origin, world
  double step_length_m = 0;     ///< along the heading, between the feet at strike
  double step_width_m = 0;      ///< across it
  double planned_length_m = 0;  ///< what the foot placement asked for at the strike
  bool timed_out = false;       ///< the swing ended on its time limit, not on contact
};

/// What the velocity walker carries from one step to the next (a copyable aggregate).
struct VelocityWalkerState {
  int stance = 0, phase = 0;
  double phase_start_s = 0, last_time_s = -1;
  double speed_now_m_s = 0;  ///< the ramped speed command
  HeadingFrame heading;
  StrikeDetector strike;
  std::size_t strike_count = 0, stones_used = 0;
  StrikeEvent last_strike;
  Eigen::Vector3d planned_foot_W = Eigen::Vector3d::Zero();
  double planned_length_m = 0;
  bool rule_active = false;
  std::array<bool, 2> foot_touches = {false, false};  ///< this step's contacts, per side
};

class VelocityWalker : public ControlDriver {
 public:
  /// For a rig with legs (models/rig.h). Throws sim::InvalidArgument for invalid params (naming
  /// a target role the model does not have) and models::RigError for a model without legs.
  VelocityWalker(const mjModel& m, const models::Rig& rig, VelocityWalkerParams params);

  const VelocityWalkerParams& params() const { return params_; }
  /// Live tuning; throws InvalidArgument (and keeps the old params) if invalid.
  void set_params(const VelocityWalkerParams& params);
  const GaitCommand& command() const { return command_; }
  void set_command(const GaitCommand& command);

  /// Starts walking from the current state (standing): left foot in stance, the first phase,
  /// speed ramping up from the CoM's current speed, heading from the pelvis yaw. Needs
  /// mj_forward on `d`.
  void reset(const mjModel& m, const mjData& d);

  void drive(const ControlInput& in, ControlFrame* frame) override;

  // Read-outs.
  int stance_side() const { return state_.stance; }
  int phase_index() const { return state_.phase; }
  const std::string& phase_name() const {
    return params_.phases[static_cast<std::size_t>(state_.phase)].name;
  }
  int strike_count() const { return static_cast<int>(state_.strike_count); }
  const StrikeEvent& last_strike() const { return state_.last_strike; }
  double speed_target_m_s() const { return state_.speed_now_m_s; }
  double heading_rad() const { return state_.heading.heading_rad(); }
  /// The planned strike point of the swing foot (sole, world) and whether the base-polygon
  /// rule moved it in this step.
  const Eigen::Vector3d& planned_foot_W() const { return state_.planned_foot_W; }
  bool base_polygon_rule_active() const { return state_.rule_active; }
  /// Support polygon of the actual foot contacts (convex hull, world xy, counter-clockwise)
  /// and the tolerance polygon, of the last step.
  const std::vector<Eigen::Vector2d>& support_polygon() const { return polygons_.support(); }
  const std::vector<Eigen::Vector2d>& tolerance_polygon() const { return polygons_.tolerance(); }

  const VelocityWalkerState& state() const { return state_; }
  void restore(const VelocityWalkerState& state) { state_ = state; }

 private:
  struct RoleTarget {
    int group = -1;
    Eigen::Vector3d angles = Eigen::Vector3d::Zero();
  };
  void compile_roles();
  double phase_duration(int phase) const;
  void advance(const mjData& d);
  void plan_foot(const mjData& d, const sim::CenterOfMass& com);
  void set_targets(ControlFrame* f, const mjData& d);
  /// The swing sole level and the knee bent for clearance.
  void set_swing_foot(ControlFrame* f, const mjData& d);
  void limit_ankles(ControlFrame* f, const ControlInput& in);
  void apply_compliance(ControlFrame* f) const;

  VelocityWalkerParams params_;
  GaitCommand command_;
  VelocityWalkerState state_;
  const models::Rig* rig_;
  // roles_[phase][stance side]: tabled targets by group (relative to parent).
  std::vector<std::array<std::vector<RoleTarget>, 2>> roles_;
  // Swing-hip table entry per phase (heading frame), and whether the phase has one.
  std::vector<Eigen::Vector3d> swing_hip_;
  std::vector<bool> has_swing_hip_;
  double ankle_height_ = 0.07, weight_ = 785;  // m (sole below the ankle), N
  double gravity_m_s2_ = 9.81;                 // the model's, downward
  SupportPolygons polygons_;
  std::vector<sim::FloorContact> contacts_;
};

}  // namespace biodyn::controllers
