#pragma once
/// Stepping stones on random sequences (issue 28): seeded random sequences of stones (a length
/// and a lateral offset per step, a speed per sequence), each walked from steady walking by
/// the walk scenario ("stones"), judged walked to the end with a small step error and no fall.
/// `biodyn stones-sweep` runs it; every sequence has its own seed, so one printed seed
/// reproduces that sequence alone.

#include <cstdint>
#include <vector>

#include "biodyn/scenarios/walk.h"
#include "biodyn/sim/simulation.h"

namespace biodyn::scenarios {

struct StoneSweepSpec {
  WalkRunParams walk;  ///< the body, weld, controller...; its steps, speed and duration are set
  int sequences = 50;
  int stones = 8;
  std::uint64_t seed = 1;  ///< sequence k has seed + k
  double length_min_m = 0.2, length_max_m = 0.65;
  double lateral_m = 0.1;  ///< offsets uniform in +-lateral_m; 0: lengths only (free widths)
  double speed_min_m_s = 0.5, speed_max_m_s = 1.0;
  double rms_limit_m = 0.02;  ///< a sequence passes with its step error RMS below this
  double after_s = 3.0;       ///< s of free walking after the last stone's slot, without a fall
  void validate() const;      ///< throws sim::InvalidArgument naming the field
};

struct StoneSequence {
  std::uint64_t seed = 0;
  double speed_m_s = 0;
  std::vector<double> lengths_m, lateral_m;  ///< lateral_m empty: lengths only
};

/// The sequence of one seed (the same on every machine: a fixed 64-bit generator and its own
/// mapping to uniform numbers), lengths and offsets to the millimetre, speed to the cm/s.
StoneSequence random_stone_sequence(const StoneSweepSpec& spec, std::uint64_t seed);
/// s, how long a sequence's walk runs: the walk's start-up, a second per stone and one more,
/// then spec.after_s.
double stone_sequence_duration_s(const StoneSweepSpec& spec, const StoneSequence& sequence);

struct StoneSequenceResult {
  StoneSequence sequence;
  int walked = 0;  ///< stones walked
  bool complete = false, fallen = false;
  double fell_at_s = -1;
  double rms_error_m = 0, max_error_m = 0;
  std::vector<int> out_of_reach;  ///< steps (1-based) that came down at the closest reachable point
  bool passed = false;            ///< complete, RMS below the limit, no fall
};

/// Walks one sequence on `sim` (a generated character, reset inside).
StoneSequenceResult run_stone_sequence(sim::Simulation* sim, const StoneSweepSpec& spec,
                                       const StoneSequence& sequence);

}  // namespace biodyn::scenarios
