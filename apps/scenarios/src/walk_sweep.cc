#include "biodyn/scenarios/walk_sweep.h"

#include "checks.h"
#include "seeded_random.h"

namespace biodyn::scenarios {

void WalkSweepSpec::validate() const {
  if (bodies < 1 || bodies > 100000) fail("bodies", "must be in [1, 100000]", bodies);
  if (!(height_min_m >= 1.0 && height_min_m <= height_max_m && height_max_m <= 2.3))
    fail("height range", "must satisfy 1.0 <= min <= max <= 2.3 m", height_min_m);
  if (!(bmi_min >= 12 && bmi_min <= bmi_max && bmi_max <= 50))
    fail("BMI range", "must satisfy 12 <= min <= max <= 50 kg/m^2", bmi_min);
  if (!(speed_min_m_s <= speed_max_m_s)) fail("speed range", "min must be <= max", speed_min_m_s);
  check_walk_speed(speed_min_m_s);
  check_walk_speed(speed_max_m_s);
  for (const double v : speeds_m_s) check_walk_speed(v);
  if (!(duration_s > 0 && duration_s <= 600)) fail("duration", "must be in (0, 600] s", duration_s);
}

std::vector<SweepWalk> random_sweep_walks(const WalkSweepSpec& spec) {
  std::vector<SweepWalk> walks;
  for (int k = 0; k < spec.bodies; ++k) {
    const std::uint64_t seed = spec.seed + static_cast<std::uint64_t>(k);
    SeededUniform uniform(seed);
    SweepWalk w;
    w.seed = seed;
    w.body = spec.walk.config.character;
    w.body.height_m = round_to(uniform(spec.height_min_m, spec.height_max_m), 0.01);
    const double bmi = uniform(spec.bmi_min, spec.bmi_max);
    w.body.mass_kg = round_to(bmi * w.body.height_m * w.body.height_m, 0.1);
    w.body.sex = uniform.coin() ? models::Sex::kFemale : models::Sex::kMale;
    // Drawn either way, so that a body is the same with or without a speed list.
    const double drawn = round_to(uniform(spec.speed_min_m_s, spec.speed_max_m_s), 0.01);
    if (spec.speeds_m_s.empty()) {
      w.speed_m_s = drawn;
      walks.push_back(w);
    }
    for (const double v : spec.speeds_m_s) {
      w.speed_m_s = v;
      walks.push_back(w);
    }
  }
  return walks;
}

SweepWalkResult run_sweep_walk(sim::Simulation* sim, const WalkSweepSpec& spec,
                               const SweepWalk& walk) {
  WalkRunParams p = spec.walk;
  p.config.scenario = "walk";
  p.config.character = walk.body;
  p.config.speed_m_s = walk.speed_m_s;
  p.duration_s = spec.duration_s;
  const WalkRunResult r = run_walk(sim, p);
  SweepWalkResult out;
  out.walk = walk;
  out.fallen = r.fallen;
  out.diverged = r.diverged_at_s >= 0;
  out.fell_at_s = r.time_fallen_s;
  out.distance_m = r.distance_m;
  out.mean_speed_m_s = r.mean_speed_m_s;
  out.steady_speed_m_s = r.steady_speed_m_s;
  out.lateral_drift_m = r.lateral_drift_m;
  out.max_foot_slip_m = r.max_foot_slip_m;
  out.steps = r.steps;
  return out;
}

}  // namespace biodyn::scenarios
