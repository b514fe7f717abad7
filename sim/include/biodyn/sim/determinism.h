#pragma once
/// Bit-exact reproducibility checks (after Box2D's determinism hash test): the same model and
/// inputs must give bit-identical states, whatever thread runs them.

#include <mujoco/mujoco.h>

#include <cstdint>

#include "biodyn/sim/model.h"

namespace biodyn::sim {

/// FNV-1a hash of the raw bytes of the state: time, qpos, qvel, act, qacc_warmstart.
std::uint64_t state_digest(const mjModel& m, const mjData& d);

/// Outcome of check_deterministic_rollout.
struct RolloutCheck {
  bool identical = false;          ///< every step's digest matched in both runs
  int first_mismatch_step = -1;    ///< first step whose digests differ, -1 if none
  std::uint64_t final_digest = 0;  ///< digest after the last step of the first run
  int steps = 0;
};

/// Runs `steps` steps twice from the model's initial state on two independent mjData, driving
/// every actuator with the same pseudo-random controls drawn from `seed` (within ctrlrange when
/// limited, else +-1), and compares the state digests after every step.
/// Throws InvalidArgument if steps <= 0.
RolloutCheck check_deterministic_rollout(const Model& model, int steps, std::uint64_t seed);

}  // namespace biodyn::sim
