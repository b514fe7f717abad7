#include "biodyn/sim/snapshot.h"

#include <mujoco/mjxmacro.h>

#include <algorithm>
#include <cstring>
#include <iterator>
#include <string_view>

#include "biodyn/sim/errors.h"

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

namespace {

// Calls f(pointer, bytes in use) for every array of mjData (mjxmacro.h lists them). Arrays with
// njmax rows or columns are in use up to nefc, the contact array up to ncon: MuJoCo lays the
// rows in use out first (dense efc_J is nefc x nv, efc_JT nv x nefc, efc_AR nefc x nefc; sparse
// row addresses are cumulative), and reads nothing past them.
template <typename Data, typename F>
void for_each_array(const mjModel* m, Data* d, F&& f) {
  MJDATA_POINTERS_PREAMBLE(m)
  (void)nv;  // the preamble declares nv and njmax for the macro's sizes
  (void)njmax;
  const auto in_use = [&](const char* dim, std::size_t size) -> std::size_t {
    const std::string_view name(dim);
    if (name.find("njmax") != std::string_view::npos) return static_cast<std::size_t>(d->nefc);
    if (name == "nconmax") return static_cast<std::size_t>(d->ncon);
    return size;
  };
#define X(type, name, nr, nc)                                              \
  f(d->name, sizeof(type) * in_use(#nr, static_cast<std::size_t>(m->nr)) * \
                 in_use(#nc, static_cast<std::size_t>(nc)));
  MJDATA_POINTERS
#undef X
}

}  // namespace

void DataCheckpoint::save(const mjModel& m, const mjData& d) {
  std::size_t total = 0;
  for_each_array(&m, &d, [&](const void*, std::size_t bytes) { total += bytes; });
  arrays_.resize(total);  // reuses the storage once it has grown
  unsigned char* out = arrays_.data();
  for_each_array(&m, &d, [&](const void* p, std::size_t bytes) {
    if (bytes > 0) std::memcpy(out, p, bytes);
    out += bytes;
  });
  counters_ = d;
  const std::size_t eq_data = sizeof(mjtNum) * static_cast<std::size_t>(m.neq * mjNEQDATA);
  model_fields_.resize(eq_data + static_cast<std::size_t>(m.neq));
  if (m.neq > 0) {
    std::memcpy(model_fields_.data(), m.eq_data, eq_data);
    std::memcpy(model_fields_.data() + eq_data, m.eq_active, static_cast<std::size_t>(m.neq));
  }
  saved_ = true;
}

void DataCheckpoint::restore(mjModel& m, mjData& d) const {
  if (!saved_) throw Error("DataCheckpoint::restore: nothing was saved");
    // The counters first: they size the arrays in use.
#define X(type, name) d.name = counters_.name;
  X(int, pstack)
  X(int, maxuse_stack)
  X(int, maxuse_con)
  X(int, maxuse_efc)
  X(int, solver_iter)
  X(int, solver_nnz)
  X(int, ne)
  X(int, nf)
  X(int, nefc)
  X(int, ncon)
  X(mjtNum, time)
#undef X
  std::copy(std::begin(counters_.warning), std::end(counters_.warning), std::begin(d.warning));
  std::copy(std::begin(counters_.timer), std::end(counters_.timer), std::begin(d.timer));
  std::copy(std::begin(counters_.solver), std::end(counters_.solver), std::begin(d.solver));
  std::copy(std::begin(counters_.solver_fwdinv), std::end(counters_.solver_fwdinv),
            std::begin(d.solver_fwdinv));
  std::copy(std::begin(counters_.energy), std::end(counters_.energy), std::begin(d.energy));
  const unsigned char* in = arrays_.data();
  for_each_array(&m, &d, [&](void* p, std::size_t bytes) {
    if (bytes > 0) std::memcpy(p, in, bytes);
    in += bytes;
  });
  const std::size_t eq_data = sizeof(mjtNum) * static_cast<std::size_t>(m.neq * mjNEQDATA);
  if (m.neq > 0) {
    std::memcpy(m.eq_data, model_fields_.data(), eq_data);
    std::memcpy(m.eq_active, model_fields_.data() + eq_data, static_cast<std::size_t>(m.neq));
  }
}

}  // namespace biodyn::sim
