#pragma once
/// Walking in 3D (paper §4, extended): a finite-state machine of target states (gait_params.h)
/// drives the velocity-based joint controllers; foot placement in both planes keeps balance.
///
/// Per step, inside CharacterController::step (a TargetDriver):
///  1. The state machine advances on time or on the swing foot's strike (which swaps the
///     stance side). The commanded speed is approached at a ramp; the heading turns at the
///     commanded rate.
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
///     both offsets are the LIP's steady orbit). On top, the paper's base-polygon balance
///     (§4.3): when the CoM projection leaves the tolerance polygon, the step is made at
///     least d = 4(c_CM - b_P)/3 - 2 foot_length (the gap from the stance toe to the new heel,
///     with b_P the polygon's rear edge: the new polygon then puts the CoM on its tolerance
///     edge), and its frontal counterpart with the foot width for the step width. With
///     stepping stones the sagittal target is the stone.
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

#include "biodyn/controllers/character_controller.h"
#include "biodyn/controllers/gait_params.h"
#include "biodyn/controllers/joint_groups.h"
#include "biodyn/sim/queries.h"

namespace biodyn::controllers {

/// The paper's 2D IK triangle (§4.2) for one leg: hip - knee - ankle.
struct LegTriangle {
  double hip_flexion_rad = 0;    ///< thigh pitch forward of vertical (heading frame)
  double hip_abduction_rad = 0;  ///< thigh roll outward of vertical
  double knee_flexion_rad = 0;
  bool reachable = true;  ///< false: the pose is the closest reachable one
};

/// The thigh and knee angles that put the ankle at `hip_to_ankle` (heading frame: x forward,
/// y left, z up; m) for thigh length l1 and shank length l2. `sigma` is +1 for a left leg,
/// -1 for a right one (abduction is outward). The knee bends at least `min_knee_rad` and at most
/// `max_knee_rad`; a point beyond the leg's reach (or closer than the most flexed knee allows,
/// and than 0.3 (l1 + l2)) gives the pose pointing at it with the nearest reachable length
/// (paper: "the closest state to the desired foot position").
LegTriangle solve_leg_triangle(double l1, double l2, const Eigen::Vector3d& hip_to_ankle,
                               double sigma, double min_knee_rad, double max_knee_rad = M_PI);

/// Paper §4.3, read as: the next strike makes the base polygon long enough that the CoM, at
/// `com_from_rear` (m) in front of the polygon's rear edge, lies on the new polygon's
/// tolerance edge at 75% of its length: d = 4(c_CM - b_P)/3 - 2 foot_length is the gap from
/// the stance toe to the new heel, so the step (heel to heel) is d + foot_length. Returns it.
double base_polygon_step(double com_from_rear, double foot_length);

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
  int index = -1;           ///< 0, 1, ... in order
  double time_s = 0;
  int side = 0;             ///< the foot that struck (0 left, 1 right)
  Eigen::Vector3d foot_W = Eigen::Vector3d::Zero();   ///< its foot origin (ankle), world
  Eigen::Vector3d other_W = Eigen::Vector3d::Zero();  ///< the stance foot origin, world
  double step_length_m = 0;   ///< along the heading, between the feet at strike
  double step_width_m = 0;    ///< across it
  double planned_length_m = 0;  ///< what the foot placement asked for at the strike
  bool timed_out = false;       ///< the swing ended on its time limit, not on contact
};

class GaitController : public TargetDriver {
 public:
  /// For a generated character's model and joint groups. Throws sim::InvalidArgument for
  /// invalid params or a model without legs.
  GaitController(const mjModel& m, const std::vector<JointGroup>& groups, GaitParams params);

  const GaitParams& params() const { return params_; }
  /// Live tuning; throws InvalidArgument (and keeps the old params) if invalid.
  void set_params(const GaitParams& params);
  const GaitCommand& command() const { return command_; }
  void set_command(const GaitCommand& command);

  /// Starts walking from the current state (standing): left foot in stance, the first state,
  /// speed ramping up from the CoM's current speed, heading from the pelvis yaw. Needs
  /// mj_forward on `d`.
  void reset(const mjModel& m, const mjData& d);

  void drive(CharacterController& controller, const mjModel& m, const mjData& d) override;

  // Read-outs.
  int stance_side() const { return stance_; }
  int state_index() const { return state_; }
  const std::string& state_name() const { return params_.states[static_cast<std::size_t>(state_)].name; }
  int strike_count() const { return static_cast<int>(strike_count_); }
  const StrikeEvent& last_strike() const { return last_strike_; }
  double speed_target_m_s() const { return speed_now_; }
  double heading_rad() const { return heading_; }
  /// The planned strike point of the swing foot (sole, world) and whether the base-polygon
  /// rule moved it in this step.
  const Eigen::Vector3d& planned_foot_W() const { return planned_foot_W_; }
  bool base_polygon_rule_active() const { return rule_active_; }
  /// Support polygon of the actual foot contacts (convex hull, world xy, counter-clockwise)
  /// and the tolerance polygon, of the last step.
  const std::vector<Eigen::Vector2d>& support_polygon() const { return hull_; }
  const std::vector<Eigen::Vector2d>& tolerance_polygon() const { return tolerance_; }
  /// Leg geometry used by the IK (m).
  double thigh_length() const { return l_thigh_; }
  double shank_length() const { return l_shank_; }
  double foot_length() const { return foot_length_; }

 private:
  struct RoleTarget {
    int group = -1;
    Eigen::Vector3d angles = Eigen::Vector3d::Zero();
  };
  void compile_roles();
  double state_duration(int state) const;
  void advance(const mjData& d);
  void plan_foot(const mjData& d, const sim::CenterOfMass& com);
  void support_polygons(const mjModel& m, const mjData& d);
  void set_targets(CharacterController& c, const mjData& d);
  void limit_ankles(CharacterController& c, const mjModel& m, const mjData& d);
  Eigen::Quaterniond heading_rotation() const;

  GaitParams params_;
  GaitCommand command_;
  std::vector<JointGroup> groups_;
  // roles_[state][stance side]: tabled targets by group (relative to parent).
  std::vector<std::array<std::vector<RoleTarget>, 2>> roles_;
  // Swing-hip table entry per state (heading frame), and whether the state has one.
  std::vector<Eigen::Vector3d> swing_hip_;
  std::vector<bool> has_swing_hip_;
  int hip_[2] = {-1, -1}, knee_[2] = {-1, -1}, ankle_[2] = {-1, -1};
  int foot_[2] = {-1, -1}, toes_[2] = {-1, -1}, thigh_[2] = {-1, -1};
  void apply_compliance(CharacterController& c) const;
  bool foot_touches_now_[2] = {false, false};  // this step's contacts, per side
  int pelvis_ = -1, floor_geom_ = -1;
  double l_thigh_ = 0.43, l_shank_ = 0.45, ankle_height_ = 0.07, foot_length_ = 0.26,
         foot_width_ = 0.1, hip_spacing_ = 0.17, weight_ = 785;

  // State machine.
  int stance_ = 0, state_ = 0;
  double state_start_s_ = 0, last_time_s_ = -1;
  double speed_now_ = 0, heading_ = 0;
  std::size_t strike_count_ = 0, stones_used_ = 0;
  StrikeEvent last_strike_;
  Eigen::Vector3d planned_foot_W_ = Eigen::Vector3d::Zero();
  double planned_length_ = 0;
  bool rule_active_ = false;
  std::vector<sim::FloorContact> contacts_;
  std::vector<Eigen::Vector2d> points_, hull_, tolerance_;
};

}  // namespace biodyn::controllers
