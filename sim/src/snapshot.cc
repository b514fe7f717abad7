#include "biodyn/sim/snapshot.h"

#include <algorithm>

namespace biodyn::sim {
namespace {
std::size_t n(int count) { return static_cast<std::size_t>(count); }
}  // namespace

StateSnapshot::StateSnapshot(const mjModel& m)
    : qpos_(n(m.nq)),
      qvel_(n(m.nv)),
      act_(n(m.na)),
      warmstart_(n(m.nv)),
      eq_data_(n(m.neq * mjNEQDATA)),
      eq_active_(n(m.neq)) {}

void StateSnapshot::save(const mjModel& m, const mjData& d) {
  time_ = d.time;
  std::copy(d.qpos, d.qpos + m.nq, qpos_.begin());
  std::copy(d.qvel, d.qvel + m.nv, qvel_.begin());
  std::copy(d.act, d.act + m.na, act_.begin());
  std::copy(d.qacc_warmstart, d.qacc_warmstart + m.nv, warmstart_.begin());
  std::copy(m.eq_data, m.eq_data + m.neq * mjNEQDATA, eq_data_.begin());
  std::copy(m.eq_active, m.eq_active + m.neq, eq_active_.begin());
}

void StateSnapshot::restore(mjModel& m, mjData& d) const {
  d.time = time_;
  std::copy(qpos_.begin(), qpos_.end(), d.qpos);
  std::copy(qvel_.begin(), qvel_.end(), d.qvel);
  std::copy(act_.begin(), act_.end(), d.act);
  std::copy(warmstart_.begin(), warmstart_.end(), d.qacc_warmstart);
  std::copy(eq_data_.begin(), eq_data_.end(), m.eq_data);
  std::copy(eq_active_.begin(), eq_active_.end(), m.eq_active);
}

}  // namespace biodyn::sim
