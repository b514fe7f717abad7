#pragma once
/// The walking gait as data (paper §4, Fig. 2): one step's finite-state machine of target
/// phases, written for the left foot in stance and mirrored for the right, plus the foot
/// placement and posture settings. Read from and written to JSON (`biodyn walk --params`,
/// `biodyn walk --write-params`); every field optional, unknown keys are errors.
///
/// A step (stance = the foot that struck last, swing = the other one) runs the phases in
/// order; the last one ends at the swing foot's strike, which swaps the sides:
///   double_support  both feet down, the trailing (swing) foot pushes off      (time)
///   lift            the swing foot leaves the floor, knee flexes              (time)
///   swing           the swing leg reaches for the planned foot strike          (strike)
/// That is the paper's stance / swing phases with a double support per side.
///
/// Target roles: "stance_<joint>" and "swing_<joint>" for the sided joints (hip, knee, ankle,
/// toe, shoulder, elbow, ...: the group name without _l/_r), the plain group name for the
/// middle joints (lumbar, thorax, neck, head, trunk). Angles in degrees in JSON: hinges one
/// per DOF in model order, ball joints (flexion, abduction, internal rotation). Two roles are
/// not relative to the parent: "swing_hip" is the swing thigh's orientation in the heading
/// frame (so the leg swings the same whatever the pelvis does, as in SIMBICON), and the
/// stance hip has no table entry: it holds the pelvis at its world target (posture).

#include <Eigen/Core>
#include <map>
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <vector>

namespace biodyn::controllers {

/// One target state of a step.
struct VelocityWalkerPhase {
  std::string name;
  /// s, length of the state at the reference cadence (scaled by reference_cadence /
  /// cadence(speed)); for a state that ends at strike, the planned time to the strike.
  double duration_s = 0.1;
  bool ends_at_strike = false;  ///< ends when the swing foot touches the floor
  /// Targets are due this fraction of the state's (scaled) duration after it starts.
  double reach_fraction = 1.0;
  /// The swing hip and knee come from the foot-placement IK (paper §4.2) instead of the table.
  bool foot_placement = false;
  /// The swing foot stays on the floor (in stance for the welds): the double support.
  bool swing_foot_down = false;
  /// Centre of pressure under the stance foot (and under the swing foot while it still
  /// touches the floor: "trailing"),
  /// as a fraction of the contact area's length from its rear (0) to its front (1), at the
  /// start and end of the state: the ankle torque is what puts the CoP there under the
  /// foot's load (human roll-over, heel to toe; Perry 1992). Sideways it is held central.
  Eigen::Vector2d stance_cop = {0.3, 0.6};
  Eigen::Vector2d trailing_cop = {0.8, 0.9};
  std::map<std::string, Eigen::Vector3d> targets_rad;  ///< role -> angles, rad
};

/// Sagittal and frontal foot placement (see gait_controller.h for the laws).
struct FootPlacementParams {
  /// Gain on the capture point (1 = place relative to xi = c + v/omega0, Pratt 2006).
  double capture_gain = 1.0;
  /// Step width, centre to centre of the feet, as a fraction of the hip-joint spacing.
  double step_width_fraction = 1.0;
  /// The swing foot never lands closer than this fraction of the hip spacing to the stance
  /// foot sideways (no crossing the legs).
  double min_width_fraction = 0.5;
  /// Knee flexion at strike, deg (in the IK triangle).
  double strike_knee_deg = 5.0;
  /// Base polygon balance (paper §4.3): tolerance polygon = support polygon scaled about
  /// its centre so that its edges lie this fraction of the polygon's extent from the centre.
  double tolerance_fraction = 0.25;
  bool base_polygon_rule = true;
  /// Foot strikes are accepted no earlier than this fraction of the swing state's planned
  /// time (a toe scuff early in the swing is not a strike).
  double min_swing_fraction = 0.4;
  /// A swing that has not struck after this multiple of its planned time is ended anyway.
  double max_swing_factor = 2.5;
  /// m, the swing ankle is kept at least this much above its standing height (the swing
  /// knee bends as far as needed for the thigh where it is); goes to zero over the state that
  /// ends at the strike.
  double swing_clearance_m = 0.05;
  /// deg, the swing foot's sole is held level in the heading frame, toes up by this much.
  double swing_toe_up_deg = 5.0;
};

/// Legs with a foot on the floor (other than the stance hip) as springs: their torques are
/// tau = k m g L (e - damping_time * omega) (m the body mass, L the leg length, e the error to
/// the state's target), not prescribed accelerations; see JointController::set_compliant_once.
/// Dimensionless stiffness k; 0 prescribes that joint's acceleration as everywhere else.
struct LegComplianceParams {
  double stance_knee = 1.0;
  double stance_ankle = 1.0;
  double trailing_leg = 0.5;  ///< hip, knee and ankle of the swing leg while its foot touches
  double damping_time_s = 0.1;
};

/// Posture and speed.
struct GaitPostureParams {
  /// Cadence (steps/min) against commanded speed (m/s): piecewise linear, clamped at the ends.
  std::vector<double> cadence_speeds_m_s = {0.5, 1.0, 1.5};
  std::vector<double> cadence_steps_per_min = {95, 108, 120};
  /// The state durations are written for this cadence.
  double reference_cadence_steps_per_min = 108;
  /// Pelvis pitch (forward lean, deg) at 0 m/s and added per m/s of commanded speed.
  double pelvis_pitch_deg = 0.0;
  double pelvis_pitch_deg_per_m_s = 3.0;
  /// s, time constant of the world-frame targets (pelvis orientation, swing thigh): they are
  /// always due this long from now (w = theta v / t, a proportional feedback).
  double world_tracking_time_s = 0.08;
  /// m/s^2, how fast the commanded speed is approached from standing and when stopping.
  double speed_ramp_m_s2 = 0.6;
  /// Stance ankles: the ankle torque is held to what the centre of pressure inside this
  /// fraction of the actual contact area can give (so the foot stays flat).
  double cop_margin = 0.8;
  /// true: stance ankle torques put the CoP on the phases' stance_cop/trailing_cop profile;
  /// false: the ankles follow their angle targets inside the CoP window.
  bool cop_torque = false;
};

struct VelocityWalkerParams {
  std::vector<VelocityWalkerPhase> phases;
  FootPlacementParams placement;
  GaitPostureParams posture;
  LegComplianceParams compliance;
  /// Throws sim::InvalidArgument naming the field, rule and value.
  void validate() const;
  /// Cadence at `speed_m_s` (steps/min) from the table.
  double cadence(double speed_m_s) const;
};

/// The built-in default gait (documented in controllers/README.md).
VelocityWalkerParams default_velocity_walker_params();

/// Applies the JSON text on top of `params` (only the fields present; a "states" array
/// replaces all phases). `source` names the file in errors. Throws sim::InvalidArgument for
/// malformed JSON, unknown keys, wrong types and out-of-range values (key path and value).
void apply_velocity_walker_json(const std::string& json_text, const std::string& source,
                                VelocityWalkerParams* params);

/// The full gait as JSON (angles in degrees); apply_velocity_walker_json of it gives the same
/// params.
nlohmann::json velocity_walker_json(const VelocityWalkerParams& params);

}  // namespace biodyn::controllers
