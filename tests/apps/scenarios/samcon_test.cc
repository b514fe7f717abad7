// SAMCON (scenarios/samcon.h): the body's own recorded walk is tracked with physics only; the
// search gives the same result on 1 and 2 threads, and its best path replayed from the start
// reproduces the search's own statistics.
#include <catch2/catch.hpp>
#include <cmath>
#include <filesystem>

#include "biodyn/mocap_io/motion_csv.h"
#include "biodyn/models/mjcf.h"
#include "biodyn/scenarios/motion_recorder.h"
#include "biodyn/scenarios/samcon.h"
#include "biodyn/scenarios/walk.h"
#include "biodyn/sim/file_io.h"
#include "biodyn/sim/model.h"
#include "recorded_walk.h"
#include "test_support.h"

using namespace biodyn;

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "SAMCON tracks the body's own walk, the same on 1 and 2 threads, and its "
                 "replay is the search",
                 "[scenarios][samcon]") {
  models::CharacterSpec spec;  // not the default body
  spec.height_m = 1.7;
  spec.mass_kg = 70;
  const std::string path = biodyn::testing::binary_dir() + "/samcon_own_walk.csv";
  biodyn::testing::record_walk_csv(spec, 1.1, 5.0, path);
  scenarios::ScenarioConfig config;
  config.scenario = "mocap";
  config.character = spec;
  config.motion_path = path;
  config.motion_from_s = 2.0;  // steady walking: the walker starts from standing
  config.motion_to_s = 4.0;
  config.track = true;
  config.tracker.lookahead_s = 0.05;  // as `mocap track` runs it
  scenarios::SamconParams params;
  params.parents = 4;
  params.children = 4;
  params.threads = 1;
  const scenarios::SamconResult one = scenarios::run_samcon(config, {}, params);
  params.threads = 2;
  const scenarios::SamconResult two = scenarios::run_samcon(config, {}, params);
  INFO("1 thread: " << one.windows_kept_up << "/" << one.windows << " windows, joint RMS "
                    << one.joint_rms_rad * 180 / M_PI << " deg, root " << one.root_max_m
                    << " m; search's " << one.search_joint_rms_rad * 180 / M_PI << " deg");
  CHECK(one.windows == 20);
  CHECK(one.windows_kept_up == one.windows);
  CHECK(one.fell_at_s < 0);
  // A small search (4 x 4); the 2 deg over 3 s is measured with the default search
  // (README, Physics tracking: 1.8-1.9 deg), this guards the small one.
  CHECK(one.joint_rms_rad < 3.0 * M_PI / 180);
  CHECK(one.root_max_m < 0.10);
  // Deterministic whatever the thread count: the same offsets, bit for bit.
  REQUIRE(one.offsets_rad.rows() == two.offsets_rad.rows());
  CHECK(one.offsets_rad == two.offsets_rad);
  CHECK(one.cost == two.cost);
  CHECK(one.joint_rms_rad == two.joint_rms_rad);
  // The replay of the best path is the search's best path.
  CHECK(one.joint_rms_rad == one.search_joint_rms_rad);
  CHECK(one.root_max_m == one.search_root_max_m);
  std::filesystem::remove(path);
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "A residual on the pelvis only when asked, and then reported",
                 "[scenarios][samcon]") {
  // The body's own walk made 40% faster by its root alone (the legs still step at the recorded
  // pace): no body keeps up with that by its joints; a residual carries it, reported.
  models::CharacterSpec spec;
  const std::string path = biodyn::testing::binary_dir() + "/samcon_residual_walk.csv";
  biodyn::testing::record_walk_csv(spec, 1.0, 4.0, path);
  mocap_io::Motion motion = mocap_io::read_motion_csv(path);
  const double x0 = motion.qpos(0, 0);
  for (Eigen::Index f = 0; f < motion.qpos.rows(); ++f)
    motion.qpos(f, 0) = x0 + 1.4 * (motion.qpos(f, 0) - x0);
  sim::write_file_atomically(path, mocap_io::format_motion_csv(motion));
  scenarios::ScenarioConfig config;
  config.scenario = "mocap";
  config.character = spec;
  config.motion_path = path;
  config.motion_from_s = 2.0;
  config.motion_to_s = 3.5;
  config.track = true;
  config.tracker.lookahead_s = 0.05;
  scenarios::SamconParams params;  // one child, no offsets: the feedback tracker alone
  params.parents = 1;
  params.children = 1;
  params.threads = 1;
  const scenarios::SamconResult alone = scenarios::run_samcon(config, {}, params);
  config.residual = true;
  const scenarios::SamconResult helped = scenarios::run_samcon(config, {}, params);
  INFO("alone: fell at " << alone.fell_at_s << " s, root " << alone.root_max_m
                         << " m; with the residual: root " << helped.root_max_m << " m, force RMS "
                         << helped.residual_force_rms_N << " N (peak "
                         << helped.residual_force_peak_N << ")");
  CHECK(alone.residual_force_peak_N == 0);
  CHECK(alone.residual_moment_peak_Nm == 0);
  CHECK((alone.fell_at_s >= 0 || alone.root_max_m > 0.15));
  CHECK(helped.fell_at_s < 0);
  CHECK(helped.root_max_m < 0.5 * alone.root_max_m);
  CHECK(helped.residual_force_rms_N > 20);  // it pulled, and it says how hard
  CHECK(helped.residual_force_peak_N >= helped.residual_force_rms_N);
  CHECK(helped.residual_moment_rms_Nm > 0);
  std::filesystem::remove(path);
}
