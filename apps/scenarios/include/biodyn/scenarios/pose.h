#pragma once
/// `biodyn pose` and `stand-push`: a pose scenario (pose_scenario.h: stand, squat, reach,
/// one-leg, optionally with a push) run headless to its end, measured by observers (target
/// errors at the reach times, welds, support polygon, joint velocities), and the standing push
/// scan.

#include <functional>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "biodyn/scenarios/scenario.h"
#include "biodyn/sim/simulation.h"

namespace biodyn::scenarios {

/// A pose scenario's run (`biodyn pose`).
struct PoseRunParams {
  PoseRunParams() { config.scenario = "stand"; }
  /// The scenario (a pose scenario: stand, squat, reach, one-leg), its controller kind, weld
  /// mode, reaction time, parameter files, duration (pose_duration_s) and push (pose_push).
  ScenarioConfig config;
  /// Joint-velocity RMS is reported per window of this length (stability check), s.
  double velocity_window_s = 5.0;
  /// If set, one CSV line per step is written here (header first): time, CoM, pelvis
  /// height, capture-point error, balance offsets, welds (on, weld force on each foot in
  /// world x y z, total ground force z, tension excess), torque ratio, saturated DOFs,
  /// honest-mode redos.
  std::ostream* trace = nullptr;
  void validate() const;  ///< throws sim::InvalidArgument
};

/// Orientation error of every joint when one pose's targets are due.
struct TargetCheck {
  std::string pose;
  double time_s = 0;          ///< s, the pose's reach time
  double error_deg = 0;       ///< deg, max over joints against the controller's targets
  std::string worst_joint;    ///< where that maximum was
  double pose_error_deg = 0;  ///< deg, max over joints against the pose without balance offsets
};

struct PoseRunResult {
  std::string scenario, controller, weld;
  double reaction_time_s = 0;  ///< s, the t_r used (if uniform), else -1
  int steps = 0;
  double simulated_s = 0, wall_s = 0, realtime_factor = 0;
  bool fallen = false;
  double time_fallen_s = -1;  ///< s, first time a non-foot body touched the floor or the
                              ///< pelvis dropped below 0.6 x its start height; -1 if never
  std::vector<TargetCheck> targets;
  double max_orientation_error_deg = 0;  ///< max over targets of error_deg
  double max_pose_error_deg = 0;         ///< max over targets of pose_error_deg
  int weld_tension_steps = 0;
  int weld_redone_steps = 0;        ///< honest mode: steps repeated with a weld released
  double max_weld_force_N = 0;      ///< largest |weld force| in any step
  double weld_active_fraction = 0;  ///< share of foot-steps with a weld on
  double max_torque_ratio = 0;      ///< peak |tau| / tau_max
  /// Time the CoM ground projection spent outside the support polygon of the actual foot
  /// contacts (double stance only), s, and the largest distance outside, m.
  double com_outside_support_s = 0;
  double max_com_outside_support_m = 0;
  double max_foot_displacement_m = 0;      ///< largest horizontal move of a foot (stepping)
  std::vector<double> joint_velocity_rms;  ///< rad/s, per window (actuated DOFs)
  int joints_outside_limits_steps = 0;
  bool solver_converged = true;
  sim::WarningCounts warnings;
  /// A push was given, the character did not fall and no foot moved 3 cm or more (no step).
  bool survived_push = false;
  /// With --muscles on: what the muscles and backups gave (scenario.h).
  std::optional<MuscleRunReport> muscles;
};

/// Builds and runs the scenario on `sim` (a generated character, reset inside): a PoseScenario
/// with the pose metrics and trace as observers. Progress is reported as a fraction. Throws
/// sim::InvalidArgument for bad params.
PoseRunResult run_pose(sim::Simulation* sim, const PoseRunParams& params,
                       const std::function<void(double)>& progress = {});

/// Standing push scan (issue 3): pushes of growing force on a quietly standing character.
struct PushScanParams {
  double duration_s = 0.2;    ///< s, push length
  double resolution_N = 10;   ///< N, force step of the upward scan
  double max_force_N = 1000;  ///< N, the scan stops here
  double onset_s = 1.0;       ///< s, push onset after the start
  double settle_s = 3.0;      ///< s, watched after the push ends
  std::string body = "pelvis";
};

struct StandingPushScan {
  double direction_deg = 0;
  std::string weld;
  /// N, the largest force of the upward scan below the first failure: every force up to it
  /// (at the resolution) was survived — the guaranteed envelope (references.md: survival
  /// is not monotonic in force, so no bisection).
  double max_survived_N = 0;
  double first_failure_N = -1;  ///< N, -1 if the scan reached max_force_N
  std::string failure;          ///< "fell" or "feet moved ... cm"
  int runs = 0;
};

/// Scans forces resolution, 2 resolution, ... in one direction (deg, 0 forward, 90 left) with
/// the stand scenario and `base`'s controller, weld and t_r, until the first failure.
StandingPushScan scan_standing_push(sim::Simulation* sim, const PoseRunParams& base,
                                    double direction_deg, const PushScanParams& scan,
                                    const std::function<void(double)>& progress = {});

}  // namespace biodyn::scenarios
