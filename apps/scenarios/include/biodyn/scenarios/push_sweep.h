#pragma once
/// The push protocol of references.md during steady walking, as a library: the cells
/// (direction x duration x onset phase), one cell's run (an upward force scan, or one push of a
/// fixed force), and the summary per direction and duration. Every cell is its own deterministic
/// run on a simulation of the same model, so any driver gives the same results: `biodyn
/// push-sweep` runs the cells on threads (one model copy each); an MPI driver can deal them out
/// to ranks the same way.

#include <string>
#include <vector>

#include "biodyn/scenarios/walk.h"
#include "biodyn/sim/simulation.h"

namespace biodyn::scenarios {

/// The force scan of one cell (references.md: scan upward, report the first failure).
struct WalkingPushScanSettings {
  double resolution_N = 10;   ///< N, step of the upward scan
  double max_force_N = 1000;  ///< N, the scan stops here
  bool bisect = true;         ///< also the bisection figure (shown beside, never instead)
};

/// What a sweep runs.
struct PushSweepSpec {
  /// The walk; its config.walk_push gives the pushed body and the settle strides (its force,
  /// duration, direction and phase are the cells').
  WalkRunParams walk;
  int directions = 8;                                 ///< evenly spaced from forward, [1, 360]
  std::vector<double> durations_s = {0.1, 0.2, 0.5};  ///< s, each in (0, 10]
  int phases = 10;                                    ///< onsets spread over one stride, [1, 100]
  WalkingPushScanSettings scan;
  /// N; > 0: one push of this force per cell (the share survived) instead of scanning.
  double fixed_force_N = 0;
  void validate() const;  ///< throws sim::InvalidArgument naming the option
};

/// One cell: direction x duration x onset phase.
struct PushSweepCell {
  double direction_deg = 0, duration_s = 0, onset_phase = 0;
};

/// The cells in the order a sweep reports them (durations, then directions, then phases).
std::vector<PushSweepCell> push_sweep_cells(const PushSweepSpec& spec);

/// One cell's result.
struct PushCellResult {
  PushSweepCell cell;
  /// Scan: N, the largest force of the upward scan below its first failure: every force up to it
  /// (at the resolution) was survived — the guaranteed envelope. Survival is not monotonic in
  /// force, so this is the figure to quote.
  double max_survived_N = 0;
  double first_failure_N = -1;  ///< N, -1 if the scan reached max_force_N
  /// How the first failure (scan) or the one push (fixed force) ended.
  PushOutcome outcome = PushOutcome::kSurvived;
  std::string failure;  ///< that outcome said for a person ("" if survived)
  /// N, what bisection between 0 and max_force_N would report (assumes monotonic survival:
  /// overstates); -1 if not computed.
  double bisection_N = -1;
  int runs = 0;
  /// A run of this cell was never pushed: the walk fell before the push or never became steady
  /// (PushOutcome::kFellBeforePush, kNoSteadyStride); the cell has no figure.
  bool not_pushed = false;
};

/// Runs one cell on `sim` (a simulation of the spec's character; reset inside).
PushCellResult run_push_cell(sim::Simulation* sim, const PushSweepSpec& spec,
                             const PushSweepCell& cell);

/// One direction and duration over its phases.
struct PushSweepGroup {
  double direction_deg = 0, duration_s = 0;
  int phases = 0;
  /// Scan: N, the worst and mean over phases of max_survived_N (fixed force: survived x force).
  double max_survived_worst_N = 0, max_survived_mean_N = 0;
  double bisection_worst_N = 0, bisection_mean_N = 0;
  int survived_phases = 0;  ///< fixed force
  bool walk_failed_before_push = false;
};

struct PushSweepSummary {
  std::vector<PushSweepGroup> groups;  ///< per duration, per direction
  std::size_t pushes_survived = 0;     ///< fixed force: over all cells
  std::size_t groups_with_failed_walks = 0;
};

/// The groups of `results` (as run_push_cell gave them for push_sweep_cells(spec), in any order).
/// Throws sim::InvalidArgument if a group has no result.
PushSweepSummary summarize_push_sweep(const PushSweepSpec& spec,
                                      const std::vector<PushCellResult>& results);

}  // namespace biodyn::scenarios
