#pragma once
// Test helper: the longest run of solved IK frames as a motion (what `mocap id` and `mocap so`
// run on), from a marker IK result.
#include "biodyn/mocap_io/marker_data.h"
#include "biodyn/mocap_io/marker_ik.h"
#include "biodyn/mocap_io/motion_csv.h"

namespace biodyn::testing {

inline mocap_io::Motion longest_solved_ik_run(const mjModel& m, const mocap_io::MarkerData& markers,
                                              const mocap_io::MarkerIkResult& ik) {
  int best_start = 0, best_len = 0, start = 0;
  const int frames = markers.frame_count();
  for (int f = 0; f <= frames; ++f) {
    if (f < frames && ik.frames[static_cast<size_t>(f)].solved) continue;
    if (f - start > best_len) best_len = f - start, best_start = start;
    start = f + 1;
  }
  mocap_io::Motion motion;
  motion.columns = mocap_io::qpos_names(m);
  motion.qpos = ik.qpos.middleRows(best_start, best_len);
  for (int f = best_start; f < best_start + best_len; ++f)
    motion.times_s.push_back(markers.time_s(f));
  return motion;
}

}  // namespace biodyn::testing
