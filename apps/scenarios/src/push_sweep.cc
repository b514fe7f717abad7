// The push protocol during walking as a library (push_sweep.h).
#include "biodyn/scenarios/push_sweep.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "biodyn/sim/errors.h"
#include "checks.h"

namespace biodyn::scenarios {
namespace {

// One run of `cell` with a push of `force_N`.
WalkRunResult run_once(sim::Simulation* sim, const PushSweepSpec& spec, const PushSweepCell& cell,
                       double force_N) {
  WalkRunParams run = spec.walk;
  run.trace = nullptr;
  WalkPush push = spec.walk.config.walk_push.value_or(WalkPush{});
  push.force_N = force_N;
  push.direction_deg = cell.direction_deg;
  push.duration_s = cell.duration_s;
  push.onset_phase = cell.onset_phase;
  run.config.walk_push = push;
  return run_walk(sim, run);
}

}  // namespace

void PushSweepSpec::validate() const {
  if (directions < 1 || directions > 360) fail("--directions", "must be in [1, 360]", directions);
  if (phases < 1 || phases > 100) fail("--phases", "must be in [1, 100]", phases);
  if (durations_s.empty()) throw sim::InvalidArgument("--durations: at least one duration");
  for (double x : durations_s)
    if (!(x > 0 && x <= 10)) fail("--durations", "each must be in (0, 10] s", x);
  if (!(fixed_force_N >= 0) || !std::isfinite(fixed_force_N))
    fail("--fixed-force", "must be >= 0 N", fixed_force_N);
  if (fixed_force_N == 0 && !(scan.resolution_N > 0 && scan.max_force_N >= scan.resolution_N)) {
    throw sim::InvalidArgument("--resolution/--max-force: need 0 < resolution <= max force");
  }
  if (!walk.config.walk_push)
    throw sim::InvalidArgument("push sweep: the walk needs its push (body, settle strides)");
  walk.validate();
}

std::vector<PushSweepCell> push_sweep_cells(const PushSweepSpec& spec) {
  std::vector<PushSweepCell> cells;
  for (double duration : spec.durations_s)
    for (int k = 0; k < spec.directions; ++k)
      for (int p = 0; p < spec.phases; ++p)
        cells.push_back(
            {360.0 * k / spec.directions, duration, static_cast<double>(p) / spec.phases});
  return cells;
}

namespace {
// The push was applied (the walk neither fell before it nor never became steady).
bool pushed(PushOutcome o) {
  return o != PushOutcome::kFellBeforePush && o != PushOutcome::kNoSteadyStride;
}
}  // namespace

PushCellResult run_push_cell(sim::Simulation* sim, const PushSweepSpec& spec,
                             const PushSweepCell& cell) {
  PushCellResult out;
  out.cell = cell;
  // One push of a fixed force: survived or not.
  if (spec.fixed_force_N > 0) {
    const WalkPushOutcome o = *run_once(sim, spec, cell, spec.fixed_force_N).push;
    out.runs = 1;
    out.outcome = o.outcome;
    out.failure = o.failure;
    out.not_pushed = !pushed(o.outcome);
    return out;
  }
  const WalkingPushScanSettings& scan = spec.scan;
  const auto survives = [&](double force) {
    const WalkPushOutcome o = *run_once(sim, spec, cell, force).push;
    ++out.runs;
    if (!pushed(o.outcome)) {
      out.not_pushed = true;
      out.failure = o.failure;
    }
    return o;
  };
  // Scan upward: resolution, 2 resolution, ... until the first failure.
  const int n = static_cast<int>(std::floor(scan.max_force_N / scan.resolution_N + 1e-9));
  for (int i = 1; i <= n; ++i) {
    const double force = i * scan.resolution_N;
    const WalkPushOutcome o = survives(force);
    if (out.not_pushed) return out;
    if (!o.survived) {
      out.first_failure_N = force;
      out.outcome = o.outcome;
      out.failure = o.failure;
      break;
    }
    out.max_survived_N = force;
  }
  if (scan.bisect) {
    // Bisection on the resolution grid between a survived 0 N and max_force_N, as if survival
    // were monotonic in force.
    int lo = 0, hi = n + 1;  // lo survived, hi failed (n + 1: beyond the range)
    if (survives(n * scan.resolution_N).survived) {
      lo = n;
    } else {
      hi = n;
      while (hi - lo > 1) {
        const int mid = (lo + hi) / 2;
        if (survives(mid * scan.resolution_N).survived)
          lo = mid;
        else
          hi = mid;
      }
    }
    out.bisection_N = lo * scan.resolution_N;
  }
  return out;
}

PushSweepSummary summarize_push_sweep(const PushSweepSpec& spec,
                                      const std::vector<PushCellResult>& results) {
  PushSweepSummary summary;
  const bool fixed = spec.fixed_force_N > 0;
  for (double duration : spec.durations_s) {
    for (int k = 0; k < spec.directions; ++k) {
      PushSweepGroup g;
      g.direction_deg = 360.0 * k / spec.directions;
      g.duration_s = duration;
      double worst = 1e18, sum = 0, bis_worst = 1e18, bis_sum = 0;
      for (const PushCellResult& r : results) {
        if (r.cell.duration_s != duration || r.cell.direction_deg != g.direction_deg) continue;
        if (r.not_pushed) g.walk_failed_before_push = true;
        const bool survived = fixed && r.outcome == PushOutcome::kSurvived;
        const double f = fixed ? (survived ? spec.fixed_force_N : 0.0) : r.max_survived_N;
        worst = std::min(worst, f);
        sum += f;
        bis_worst = std::min(bis_worst, r.bisection_N);
        bis_sum += r.bisection_N;
        g.survived_phases += survived ? 1 : 0;
        ++g.phases;
      }
      if (g.phases == 0) {
        std::ostringstream what;
        what << "push sweep summary: no result for direction " << g.direction_deg
             << " deg, duration " << duration << " s (give one per cell of push_sweep_cells)";
        throw sim::InvalidArgument(what.str());
      }
      g.max_survived_worst_N = worst;
      g.max_survived_mean_N = sum / g.phases;
      g.bisection_worst_N = bis_worst;
      g.bisection_mean_N = bis_sum / g.phases;
      if (fixed) summary.pushes_survived += static_cast<std::size_t>(g.survived_phases);
      summary.groups_with_failed_walks += g.walk_failed_before_push ? 1 : 0;
      summary.groups.push_back(g);
    }
  }
  return summary;
}

}  // namespace biodyn::scenarios
