#include "biodyn/scenarios/stones_sweep.h"

#include <cmath>
#include <string>

#include "biodyn/sim/errors.h"
#include "checks.h"
#include "seeded_random.h"

namespace biodyn::scenarios {

void StoneSweepSpec::validate() const {
  if (sequences < 1 || sequences > 100000) fail("sequences", "must be in [1, 100000]", sequences);
  if (stones < 1 || stones > 100) fail("stones", "must be in [1, 100]", stones);
  if (!(length_min_m >= 0 && length_min_m <= length_max_m && length_max_m <= 1.5))
    fail("length range", "must satisfy 0 <= min <= max <= 1.5 m", length_max_m);
  if (!(lateral_m >= 0 && lateral_m <= 0.3)) fail("lateral", "must be in [0, 0.3] m", lateral_m);
  if (!(speed_min_m_s <= speed_max_m_s)) fail("speed range", "min must be <= max", speed_min_m_s);
  check_walk_speed(speed_min_m_s);
  check_walk_speed(speed_max_m_s);
  if (!(rms_limit_m > 0)) fail("rms limit", "must be > 0 m", rms_limit_m);
  if (!(after_s >= 0 && after_s <= 60)) fail("after", "must be in [0, 60] s", after_s);
}

StoneSequence random_stone_sequence(const StoneSweepSpec& spec, std::uint64_t seed) {
  SeededUniform uniform(seed);
  // Rounded (mm, cm/s) so that the printed replay line is the same run.
  StoneSequence s;
  s.seed = seed;
  s.speed_m_s = round_to(uniform(spec.speed_min_m_s, spec.speed_max_m_s), 0.01);
  for (int k = 0; k < spec.stones; ++k) {
    s.lengths_m.push_back(round_to(uniform(spec.length_min_m, spec.length_max_m), 0.001));
    if (spec.lateral_m > 0)
      s.lateral_m.push_back(round_to(uniform(-spec.lateral_m, spec.lateral_m), 0.001));
  }
  return s;
}

double stone_sequence_duration_s(const StoneSweepSpec& spec, const StoneSequence& sequence) {
  // The stones start after the walk's start-up; a step takes under a second at these speeds.
  return spec.walk.config.steps_start_s + static_cast<double>(sequence.lengths_m.size()) + 1.0 +
         spec.after_s;
}

StoneSequenceResult run_stone_sequence(sim::Simulation* sim, const StoneSweepSpec& spec,
                                       const StoneSequence& sequence) {
  WalkRunParams p = spec.walk;
  p.config.scenario = "stones";
  p.config.speed_m_s = sequence.speed_m_s;
  p.config.steps_m = sequence.lengths_m;
  p.config.steps_lateral_m = sequence.lateral_m;
  p.duration_s = stone_sequence_duration_s(spec, sequence);
  const WalkRunResult r = run_walk(sim, p);
  StoneSequenceResult out;
  out.sequence = sequence;
  out.fallen = r.fallen;
  out.fell_at_s = r.time_fallen_s;
  if (r.stones) {
    out.walked = static_cast<int>(r.stones->lengths_m.size());
    out.complete = r.stones->complete;
    out.rms_error_m = r.stones->rms_error_m;
    out.max_error_m = r.stones->max_error_m;
    out.out_of_reach = r.stones->out_of_reach;
  }
  out.passed = out.complete && !out.fallen && out.rms_error_m < spec.rms_limit_m;
  return out;
}

}  // namespace biodyn::scenarios
