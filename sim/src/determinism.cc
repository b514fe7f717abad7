#include "biodyn/sim/determinism.h"

#include <random>
#include <string>

#include "biodyn/sim/errors.h"
#include "biodyn/sim/simulation.h"

namespace biodyn::sim {
namespace {

constexpr std::uint64_t kFnvOffset = 1469598103934665603ull;
constexpr std::uint64_t kFnvPrime = 1099511628211ull;

void fnv1a(std::uint64_t* hash, const void* bytes, size_t size) {
  const auto* p = static_cast<const unsigned char*>(bytes);
  for (size_t i = 0; i < size; ++i) {
    *hash ^= p[i];
    *hash *= kFnvPrime;
  }
}

/// Fills ctrl for step `step` from a generator seeded by (seed, step): both runs draw the same.
void random_controls(const mjModel& m, std::uint64_t seed, int step, mjData* d) {
  std::mt19937_64 rng(seed ^ (static_cast<std::uint64_t>(step) * 0x9E3779B97F4A7C15ull));
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  for (int i = 0; i < m.nu; ++i) {
    const double u = unit(rng);
    if (m.actuator_ctrllimited[i]) {
      const double lo = m.actuator_ctrlrange[2 * i], hi = m.actuator_ctrlrange[2 * i + 1];
      d->ctrl[i] = lo + 0.5 * (u + 1.0) * (hi - lo);
    } else {
      d->ctrl[i] = u;
    }
  }
}

}  // namespace

std::uint64_t state_digest(const mjModel& m, const mjData& d) {
  std::uint64_t h = kFnvOffset;
  fnv1a(&h, &d.time, sizeof(d.time));
  fnv1a(&h, d.qpos, sizeof(mjtNum) * static_cast<size_t>(m.nq));
  fnv1a(&h, d.qvel, sizeof(mjtNum) * static_cast<size_t>(m.nv));
  fnv1a(&h, d.act, sizeof(mjtNum) * static_cast<size_t>(m.na));
  fnv1a(&h, d.qacc_warmstart, sizeof(mjtNum) * static_cast<size_t>(m.nv));
  return h;
}

RolloutCheck check_deterministic_rollout(const Model& model, int steps, std::uint64_t seed) {
  if (steps <= 0) {
    throw InvalidArgument("check_deterministic_rollout: steps must be > 0, got " +
                          std::to_string(steps));
  }
  Simulation a(model.copy());
  Simulation b(model.copy());
  RolloutCheck result;
  result.steps = steps;
  for (int s = 0; s < steps; ++s) {
    const auto drive = [&](const mjModel& m, mjData& d) { random_controls(m, seed, s, &d); };
    a.step(drive);
    b.step(drive);
    const std::uint64_t da = state_digest(a.model(), a.data());
    if (result.first_mismatch_step < 0 && da != state_digest(b.model(), b.data())) {
      result.first_mismatch_step = s;
    }
    result.final_digest = da;
  }
  result.identical = result.first_mismatch_step < 0;
  return result;
}

}  // namespace biodyn::sim
