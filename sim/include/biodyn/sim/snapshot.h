#pragma once
/// A saved simulation state to undo a step: time, qpos, qvel, act, qacc_warmstart, and the
/// equality constraints' activation and data (model fields in 2.2.2, toggled by the foot
/// welds). Pushes are re-applied from the time by Simulation, controls and qfrc_applied are
/// rewritten by controllers every step, so neither is saved. No allocation after construction.

#include <mujoco/mujoco.h>

#include <cstddef>
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

/// Everything in an mjData a later step can read, for rewinding (scenarios/live.h): every array
/// MuJoCo keeps in its buffer (the constraint and contact arrays cut to the rows in use, nefc
/// and ncon) and its counters, plus the model fields the controllers change while running
/// (eq_active, eq_data: the foot welds). Restoring it makes the following steps bit-identical to
/// the ones that followed the save. Unlike mj_copyData it skips the stack (scratch within one
/// call) and the unused rows of the njmax/nconmax arrays: ~0.1 MB instead of ~57 MB for a
/// character. The storage grows on the first saves and is reused after.
class DataCheckpoint {
 public:
  void save(const mjModel& m, const mjData& d);
  /// Restores what save() took (same model). The data's own buffers are written, not replaced.
  void restore(mjModel& m, mjData& d) const;
  bool empty() const { return !saved_; }
  /// Bytes held (for the rewind ring's report).
  std::size_t bytes() const { return arrays_.capacity() + model_fields_.capacity(); }

 private:
  bool saved_ = false;
  mjData counters_{};  // the scalar and vector fields (the pointers in it are not used)
  std::vector<unsigned char> arrays_, model_fields_;
};

}  // namespace biodyn::sim
