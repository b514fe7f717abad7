#pragma once
/// The zero-torque drop: a generated character released standing with every actuator at zero
/// collapses like a rag doll. It checks the model passively (contacts, limits, energy) and is
/// the main job of ./run.sh until walking lands. Shared by the CLI and the tests.

#include <functional>

#include "biodyn/sim/simulation.h"

namespace biodyn::scenarios {

struct DropParams {
  double duration_s = 5.0;  ///< s, > 0
  /// Speed below which the body counts as at rest, m/s (largest body-CoM speed).
  double rest_speed = 0.05;
  void validate() const;  ///< throws sim::InvalidArgument
};

struct DropResult {
  int steps = 0;
  double simulated_s = 0;
  double pelvis_height_start_m = 0, pelvis_height_end_m = 0;
  double com_height_start_m = 0, com_height_end_m = 0, com_height_min_m = 0;
  /// First time the CoM fell below half its standing height, s; negative if it never did.
  double collapse_time_s = -1;
  /// First time after which every body stayed slower than rest_speed, s; negative if never.
  double rest_time_s = -1;
  double energy_start_J = 0, energy_end_J = 0;
  /// Largest rise of total mechanical energy above its running minimum, J. A passive system
  /// only loses energy; soft contacts and limits may return a little they stored.
  double max_energy_rise_J = 0;
  bool finite = true;  ///< qpos, qvel and qacc stayed finite
  sim::WarningCounts warnings;
};

/// Runs the drop on `sim` (a generated character: it reads the body "pelvis") from its current
/// state with ctrl = 0, calling `progress(fraction)` about every 1% if given. Throws
/// sim::InvalidArgument for bad params or a model without a pelvis.
DropResult run_drop(sim::Simulation* sim, const DropParams& params,
                    const std::function<void(double)>& progress = {});

}  // namespace biodyn::scenarios
