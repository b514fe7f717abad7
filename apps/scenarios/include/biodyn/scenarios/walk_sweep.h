#pragma once
/// Walks on seeded random bodies (issue 28: "every body 1.55-1.95 m / 50-120 kg"): each body's
/// height, BMI (so its mass) and sex drawn from its own seed, walked from standing at a list of
/// speeds (or a random speed each), judged by not falling. `biodyn walk-sweep` runs it; a body's
/// printed seed reproduces that body alone, and every failed walk prints the `biodyn walk` line
/// that walks it again.

#include <cstdint>
#include <vector>

#include "biodyn/models/character.h"
#include "biodyn/scenarios/walk.h"
#include "biodyn/sim/simulation.h"

namespace biodyn::scenarios {

struct WalkSweepSpec {
  WalkRunParams walk;  ///< the weld, controller, t_r, parameters; its body and speed are set
  int bodies = 20;
  std::uint64_t seed = 1;  ///< body k has seed + k
  double height_min_m = 1.55, height_max_m = 1.95;
  double bmi_min = 19, bmi_max = 30;  ///< kg/m^2; mass = BMI x height^2
  /// Every body walks each of these; empty: one walk per body at a speed drawn from
  /// [speed_min_m_s, speed_max_m_s].
  std::vector<double> speeds_m_s;
  double speed_min_m_s = 0.5, speed_max_m_s = 1.5;
  double duration_s = 60;
  void validate() const;  ///< throws sim::InvalidArgument naming the field
};

/// One walk of the sweep: a body (from its seed) and a speed.
struct SweepWalk {
  std::uint64_t seed = 0;
  models::CharacterSpec body;  ///< height to the cm, mass to 0.1 kg (the replay line's figures)
  double speed_m_s = 0;        ///< to the cm/s
};

/// The sweep's walks, body by body (each body's speeds in the spec's order). The same on every
/// machine: a fixed 64-bit generator per body and its own mapping to uniform numbers; the body's
/// other fields (detail, muscles) are those of spec.walk.config.character.
std::vector<SweepWalk> random_sweep_walks(const WalkSweepSpec& spec);

struct SweepWalkResult {
  SweepWalk walk;
  bool fallen = false, diverged = false;
  double fell_at_s = -1;
  double distance_m = 0, mean_speed_m_s = 0, steady_speed_m_s = 0;
  double lateral_drift_m = 0, max_foot_slip_m = 0;
  int steps = 0;
};

/// Walks one of the sweep's walks on `sim` (that walk's generated character, reset inside).
SweepWalkResult run_sweep_walk(sim::Simulation* sim, const WalkSweepSpec& spec,
                               const SweepWalk& walk);

}  // namespace biodyn::scenarios
