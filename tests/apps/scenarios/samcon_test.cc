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
