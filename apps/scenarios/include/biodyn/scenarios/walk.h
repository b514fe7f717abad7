#pragma once
/// The walking scenario of `biodyn walk` and `biodyn push` (issue 4): a generated character
/// starts standing and walks under the torque walker (controllers/torque_gait.h) with the joint
/// controllers' muscle limits and a foot-contact mode, optionally pushed once during steady
/// walking (references.md, push protocol). Headless; shared by the CLI, the viewer and tests.

#include <array>
#include <functional>
#include <map>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "biodyn/controllers/control_pipeline.h"
#include "biodyn/sim/simulation.h"

namespace biodyn::scenarios {

/// One horizontal push during steady walking, through the centre of mass of the pelvis or the
/// trunk (xfrc_applied), timed by the gait: after `settle_strides` strides (a stride starts at
/// a left-foot strike), at `onset_phase` of the next stride (its length taken from the stride
/// before).
struct WalkPush {
  double force_N = 0;          ///< N, >= 0
  double duration_s = 0.2;     ///< s, > 0
  double direction_deg = 0;    ///< deg, relative to the heading: 0 forward, 90 left
  std::string body = "pelvis";  ///< "pelvis" or "trunk" (the thorax), or any body name
  double onset_phase = 0;      ///< [0, 1), fraction of the stride
  int settle_strides = 5;      ///< steady strides walked before the push's stride (>= 1)
  double watch_s = 5.0;        ///< s, watched after the push ends (references.md: 5 s)
};

struct WalkRunParams {
  double duration_s = 20;          ///< s; with a push the run ends when the push is judged
  double speed_m_s = 1.0;          ///< m/s, commanded speed
  double heading_rate_deg_s = 0;   ///< deg/s, commanded turning rate (+ to the left)
  controllers::WeldMode weld = controllers::WeldMode::kHonest;
  double reaction_time_s = 0;      ///< s; > 0 replaces every joint's t_r
  /// Joint controller parameter overrides (controller_params.h JSON, as `biodyn pose --params`
  /// and the viewer's saved files), optional; reaction_time_s > 0 still overrides t_r.
  std::string controller_json, controller_source;
  std::string gait_json;           ///< torque walker parameter overrides (JSON text), optional
  std::string gait_source;         ///< the file it came from, for errors
  std::optional<WalkPush> push;
  /// Stepping stones (paper §4.2): step lengths, m, ankle to ankle along the heading, walked
  /// from the first strike at or after steps_start_s (steady walking first); free steps after.
  std::vector<double> steps_m;
  double steps_start_s = 5.0;
  /// s; >= 0: from this time the walker stops (a half step, then the feet side by side) and
  /// the character is handed to the standing controller (pose "stand" with its balance).
  double stop_at_s = -1;
  /// If set, one CSV line per step is written here (header first).
  std::ostream* trace = nullptr;
  void validate() const;  ///< throws sim::InvalidArgument naming the field
};

/// The outcome of a push (references.md: survived = only the feet touch the ground for
/// watch_s after the push, the pelvis stays >= 0.7 x its standing height, and the speed is
/// back within 10% of the speed before the push by the 4th stride after it).
struct WalkPushOutcome {
  double onset_s = 0, end_s = 0;     ///< s, simulation time
  double force_N = 0, duration_s = 0, direction_deg = 0;
  std::string body;
  double impulse_N_s = 0;            ///< force x duration
  double delta_v_m_s = 0;            ///< impulse / body mass
  double speed_before_m_s = 0;       ///< mean stride speed of the strides before the push
  std::vector<double> stride_speeds_after_m_s;  ///< strides starting after the push ended
  int recovery_strides = -1;         ///< first stride after the push within 10%; -1 none in 4
  bool fell = false;
  bool survived = false;
  std::string failure;               ///< why not survived ("" if survived)
};

/// How the stepping stones were walked.
struct SteppingStonesResult {
  double start_s = -1;                 ///< s, the strike the plan started from (-1: never)
  std::vector<double> targets_m;       ///< the planned lengths
  std::vector<double> lengths_m;       ///< the lengths walked (as many as were walked)
  std::vector<double> errors_m;        ///< walked - planned
  double rms_error_m = 0, max_error_m = 0;  ///< over the steps walked
  bool complete = false;               ///< every planned step was walked
};

struct WalkRunResult {
  std::string weld;
  double reaction_time_s = 0;        ///< s, the t_r used (if uniform), else -1
  double speed_command_m_s = 0, heading_rate_deg_s = 0;
  int sim_steps = 0;
  double simulated_s = 0, wall_s = 0, realtime_factor = 0;
  bool fallen = false;
  double time_fallen_s = -1;         ///< s, -1 if never
  /// m, progress of the CoM's ground projection along the heading, summed from strike to
  /// strike (drops the sway, follows a turn; walking backwards counts against it).
  double distance_m = 0;
  double mean_speed_m_s = 0;         ///< distance / time walked
  /// m/s, the same after the start-up (the first kStartup_s, 5 s).
  double steady_speed_m_s = 0;
  double lateral_drift_m = 0;        ///< m, CoM sideways of the start heading at the end
  int steps = 0;                     ///< foot strikes
  std::vector<double> step_lengths_m, step_widths_m, step_times_s;
  double cadence_steps_per_min = 0;  ///< after the start-up
  double mean_step_length_m = 0;     ///< after the start-up
  /// deg, [min, max] of each leg and lumbar angle after the start-up; ball joints as
  /// <group>_flexion/_abduction/_rotation (joint_groups.h), hinges by their DOF name.
  std::map<std::string, std::array<double, 2>> joint_ranges_deg;
  double swing_knee_peak_deg = 0;    ///< deg, mean over swings of the peak knee flexion
  double heel_strike_fraction = 0;   ///< strikes whose first floor contact is behind the sole centre
  int base_polygon_steps = 0;        ///< steps the base-polygon rule moved (paper §4.3; torque_gait.h)
  double max_foot_slip_m = 0;        ///< m, largest move of a flat foot within one stance
  double mean_foot_slip_m = 0;       ///< m, mean over stances
  int weld_tension_steps = 0;
  int weld_redone_steps = 0;
  double max_weld_force_N = 0;
  double max_torque_ratio = 0;       ///< peak |tau| / tau_max
  double max_root_force_N = 0;       ///< largest applied force on the root's DOFs (must be 0)
  sim::WarningCounts warnings;
  std::optional<WalkPushOutcome> push;
  std::optional<SteppingStonesResult> stones;
  /// Stopping (stop_at_s >= 0): when the feet came side by side and the standing controller
  /// took over (-1: never), and the state at the end.
  double stopped_at_s = -1;
  bool standing_at_end = false;      ///< not fallen, CoM < 5 cm/s, both feet on the floor
  double final_com_speed_m_s = 0;    ///< m/s, horizontal, at the end
};

/// Start-up excluded from the steady figures, s.
inline constexpr double kWalkStartup_s = 5.0;

/// Builds and runs the walk on `sim` (a generated character, reset inside). Progress is
/// reported as a fraction. Throws sim::InvalidArgument for bad params.
WalkRunResult run_walk(sim::Simulation* sim, const WalkRunParams& params,
                       const std::function<void(double)>& progress = {});

}  // namespace biodyn::scenarios

namespace biodyn::scenarios {

/// The force scan of one push-sweep cell (references.md, push protocol).
struct WalkingPushScanSettings {
  double resolution_N = 10;    ///< N, step of the upward scan
  double max_force_N = 1000;   ///< N, the scan stops here
  bool bisect = true;          ///< also the bisection figure (shown beside, never instead)
};

/// One cell: direction x duration x onset phase.
struct WalkingPushCell {
  double direction_deg = 0, duration_s = 0, onset_phase = 0;
  /// N, the largest force of the upward scan below its first failure: every force up to it
  /// (at the resolution) was survived — the guaranteed envelope. Survival is not monotonic
  /// in force, so this is the figure to quote.
  double max_survived_N = 0;
  double first_failure_N = -1;  ///< N, -1 if the scan reached max_force_N
  std::string failure;          ///< why the first failure failed
  /// N, what bisection between 0 and max_force_N would report (assumes monotonic survival:
  /// overstates); -1 if not computed.
  double bisection_N = -1;
  int runs = 0;
  bool fell_before_push = false;  ///< the walk itself failed: the cell has no figure
};

/// Scans forces resolution, 2 resolution, ... for one cell with `base`'s walk (its push
/// field's body and settle strides are used; its force, duration, direction and phase are
/// replaced). `progress` gets the fraction of the scan's worst case.
WalkingPushCell scan_walking_push(sim::Simulation* sim, const WalkRunParams& base, double direction_deg,
                                  double duration_s, double onset_phase, const WalkingPushScanSettings& scan);

}  // namespace biodyn::scenarios
