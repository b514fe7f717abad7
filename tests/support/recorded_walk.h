#pragma once
// Test helper: the torque walker's walk of a body, recorded at 100 Hz (scenarios/
// motion_recorder.h) and written as a motion CSV with its body in the header: the body's own
// walk as a "capture" for tracking and evaluation tests.
#include <catch2/catch.hpp>
#include <cmath>
#include <string>

#include "biodyn/mocap_io/motion_csv.h"
#include "biodyn/models/mjcf.h"
#include "biodyn/scenarios/motion_recorder.h"
#include "biodyn/scenarios/walk.h"
#include "biodyn/sim/file_io.h"
#include "biodyn/sim/model.h"

namespace biodyn::testing {

inline void record_walk_csv(const models::CharacterSpec& spec, double speed_m_s, double duration_s,
                            const std::string& path) {
  sim::Simulation sim(
      sim::Model::from_string(models::to_mjcf(models::generate_character(spec)), "walker"));
  scenarios::WalkRunParams p;
  p.duration_s = duration_s;
  p.config.character = spec;
  p.config.speed_m_s = speed_m_s;
  const double dt = sim.model().opt.timestep;
  scenarios::MotionRecorder recorder(sim.model(), static_cast<int>(std::lround(0.01 / dt)),
                                     std::lround(duration_s / dt) + 1);
  p.observers.push_back(&recorder);
  REQUIRE_FALSE(scenarios::run_walk(&sim, p).fallen);
  const scenarios::RecordedMotion rec = recorder.motion();
  mocap_io::Motion motion;
  motion.columns = mocap_io::qpos_names(sim.model());
  motion.times_s = rec.times_s;
  motion.qpos = rec.qpos;
  mocap_io::set_motion_body(&motion, spec);
  sim::write_file_atomically(path, mocap_io::format_motion_csv(motion));
}

}  // namespace biodyn::testing
