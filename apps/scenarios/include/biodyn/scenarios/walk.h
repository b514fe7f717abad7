#pragma once
/// `biodyn walk` and `push`: a walking scenario (walk_scenario.h) run headless to its end,
/// measured by observers: gait figures (distance, speed, cadence, steps, joint ranges, heel
/// strikes, foot slip), a per-step trace, and a push judged by the protocol of references.md.

#include <array>
#include <functional>
#include <map>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "biodyn/scenarios/scenario.h"
#include "biodyn/sim/simulation.h"

namespace biodyn::scenarios {

/// A walking scenario's run (`biodyn walk`, `push`, one push-sweep run).
struct WalkRunParams {
  /// The scenario: "walk" (or "stones" with steps_m planned), its speed,
  /// turning rate, weld mode, reaction time, parameter files, stepping stones, stop and push.
  ScenarioConfig config;
  double duration_s = 20;  ///< s; with a push the run ends when the push is judged
  /// If set, one CSV line per step is written here (header first).
  std::ostream* trace = nullptr;
  /// More observers of every step (e.g. a MotionRecorder), not owned.
  std::vector<StepObserver*> observers;
  void validate() const;  ///< throws sim::InvalidArgument naming the field
};

/// How a push ended (references.md: survived = only the feet touch the ground for watch_s
/// after the push, the pelvis stays >= 0.7 x its standing height, and the speed is back within
/// 10% of the speed before the push by the 4th stride after it).
enum class PushOutcome {
  kSurvived,
  kFellBeforePush,     ///< the walk itself failed: the run has no figure
  kNoSteadyStride,     ///< never steady in the strides a push waits (or stopped striking): no push
  kFell,               ///< fell after the push
  kSpeedNotRecovered,  ///< up, but the stride speed not back within 10% in 4 strides
};
/// "survived", "fell before the push", ...
const char* to_string(PushOutcome outcome);

/// The outcome of a push (references.md: survived = only the feet touch the ground for
/// watch_s after the push, the pelvis stays >= 0.7 x its standing height, and the speed is
/// back within 10% of the speed before the push by the 4th stride after it).
struct WalkPushOutcome {
  PushOutcome outcome = PushOutcome::kSurvived;
  double onset_s = 0, end_s = 0;  ///< s, simulation time
  double force_N = 0, duration_s = 0, direction_deg = 0;
  std::string body;
  double impulse_N_s = 0;       ///< force x duration
  double delta_v_m_s = 0;       ///< impulse / body mass
  double speed_before_m_s = 0;  ///< mean stride speed of the 4 steady strides before the push
  int strides_before = -1;      ///< strides walked before the push's stride (-1: no push)
  std::vector<double> stride_speeds_after_m_s;  ///< strides starting after the push ended
  int recovery_strides = -1;  ///< first stride after the push within 10%; -1 none in 4
  bool fell = false;
  bool survived = false;
  std::string failure;  ///< why not survived ("" if survived), said for a person
};

/// How the stepping stones were walked.
struct SteppingStonesResult {
  double start_s = -1;                  ///< s, the strike the plan started from (-1: never)
  std::vector<double> targets_m;        ///< the planned lengths
  std::vector<double> lateral_m;        ///< the stones' lateral offsets (empty: free)
  std::vector<double> lengths_m;        ///< the lengths walked (as many as were walked)
  std::vector<double> across_m;         ///< left of the stance ankle, walked (2D stones)
  std::vector<double> target_across_m;  ///< ... and planned (2D stones)
  std::vector<double> errors_m;         ///< Stone::error_m: 2D distance, or walked - planned
  /// The steps (1-based) whose stone was out of the leg's reach: each came down at the closest
  /// reachable point instead (its walked length and width say where), or, the one after the
  /// last walked, the character fell reaching for it.
  std::vector<int> out_of_reach;
  double rms_error_m = 0, max_error_m = 0;  ///< over the steps walked
  bool complete = false;                    ///< every planned step was walked
};

struct WalkRunResult {
  std::string weld;
  double reaction_time_s = 0;  ///< s, the t_r used (if uniform), else -1
  double speed_command_m_s = 0, heading_rate_deg_s = 0;
  int sim_steps = 0;
  double simulated_s = 0, wall_s = 0, realtime_factor = 0;
  bool fallen = false;
  double time_fallen_s = -1;  ///< s, -1 if never
  /// s, when the simulation diverged (MuJoCo's bad qpos, qvel or qacc; counted as the fall), -1 if
  /// never
  double diverged_at_s = -1;
  /// m, progress of the CoM's ground projection along the heading, summed from strike to
  /// strike (drops the sway, follows a turn; walking backwards counts against it).
  double distance_m = 0;
  double mean_speed_m_s = 0;  ///< distance / time walked
  /// m/s, the same after the start-up (the first kStartup_s, 5 s).
  double steady_speed_m_s = 0;
  double lateral_drift_m = 0;  ///< m, CoM sideways of the start heading at the end
  int steps = 0;               ///< foot strikes
  std::vector<double> step_lengths_m, step_widths_m, step_times_s;
  double cadence_steps_per_min = 0;  ///< after the start-up
  double mean_step_length_m = 0;     ///< after the start-up
  /// deg, [min, max] of each leg and lower-back (lumbar, or trunk) angle after the start-up; ball
  /// joints as <group>_flexion/_abduction/_rotation (joint_groups.h), hinges by their DOF name.
  std::map<std::string, std::array<double, 2>> joint_ranges_deg;
  double swing_knee_peak_deg = 0;   ///< deg, mean over swings of the peak knee flexion
  double heel_strike_fraction = 0;  ///< strikes whose first floor contact is behind the sole centre
  int base_polygon_steps = 0;   ///< steps the base-polygon rule moved (paper §4.3; torque_gait.h)
  double max_foot_slip_m = 0;   ///< m, largest move of a flat foot within one stance
  double mean_foot_slip_m = 0;  ///< m, mean over stances
  int weld_tension_steps = 0;
  int weld_redone_steps = 0;
  double max_weld_force_N = 0;
  double max_torque_ratio = 0;  ///< peak |tau| / tau_max
  JointLoadReport joint_load;   ///< the joints' range stops beside the motors (toes not judged)
  double max_root_force_N = 0;  ///< largest applied force on the root's DOFs (must be 0)
  sim::WarningCounts warnings;
  std::optional<WalkPushOutcome> push;
  std::optional<SteppingStonesResult> stones;
  /// Stopping (stop_at_s >= 0): when the feet came side by side and the standing controller
  /// took over (-1: never), and the state at the end.
  double stopped_at_s = -1;
  bool standing_at_end = false;    ///< not fallen, CoM < 5 cm/s, both feet on the floor
  double final_com_speed_m_s = 0;  ///< m/s, horizontal, at the end
  /// With --muscles on: what the muscles and backups gave (scenario.h).
  std::optional<MuscleRunReport> muscles;
};

/// Start-up excluded from the steady figures, s.
inline constexpr double kWalkStartup_s = 5.0;

/// Builds and runs the walk on `sim` (a generated character, reset inside): a WalkScenario with
/// the walk metrics, the trace and (with a push) the push judge as observers. Progress is
/// reported as a fraction. Throws sim::InvalidArgument for bad params.
WalkRunResult run_walk(sim::Simulation* sim, const WalkRunParams& params,
                       const std::function<void(double)>& progress = {});

}  // namespace biodyn::scenarios
