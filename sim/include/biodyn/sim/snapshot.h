#pragma once
/// A saved simulation state to undo a step: time, qpos, qvel, act, qacc_warmstart, and the
/// equality constraints' activation and data (model fields in 2.2.2, toggled by the foot
/// welds). Pushes are re-applied from the time by Simulation, controls and qfrc_applied are
/// rewritten by controllers every step, so neither is saved. No allocation after construction.

#include <mujoco/mujoco.h>

#include <vector>

namespace biodyn::sim {

class StateSnapshot {
 public:
  explicit StateSnapshot(const mjModel& m);
  void save(const mjModel& m, const mjData& d);
  /// Restores what save() took; the caller reruns mj_forward or steps again.
  void restore(mjModel& m, mjData& d) const;

 private:
  double time_ = 0;
  std::vector<mjtNum> qpos_, qvel_, act_, warmstart_, eq_data_;
  std::vector<mjtByte> eq_active_;
};

}  // namespace biodyn::sim
