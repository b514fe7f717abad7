// The scenario the viewer steps (scenarios/live.h): edits change the simulation, rewinding and
// resuming gives the same future bit for bit, saved parameters read back identically.
#include <cstring>
#include <vector>

#include "biodyn/mocap_io/motion_csv.h"
#include "biodyn/mocap_io/retarget.h"
#include "biodyn/models/mjcf.h"
#include "biodyn/scenarios/live.h"
#include "biodyn/scenarios/walk.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/file_io.h"
#include "cli_runner.h"
#include "test_support.h"

using namespace biodyn;
using scenarios::LiveScenario;
using scenarios::ScenarioConfig;

namespace {

std::vector<double> state_of(const LiveScenario& s) {
  const mjModel& m = s.simulation().model();
  const mjData& d = s.simulation().data();
  std::vector<double> x(d.qpos, d.qpos + m.nq);
  x.insert(x.end(), d.qvel, d.qvel + m.nv);
  x.push_back(d.time);
  return x;
}

}  // namespace

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "Live walk: rewinding and resuming gives the same future, edits included",
                 "[apps][live]") {
  LiveScenario walk(ScenarioConfig{});
  walk.run_until(1.0);
  walk.set_speed(1.3);
  walk.run_until(1.5);
  walk.push("pelvis", Eigen::Vector3d(0, 80, 0), 0.2);
  walk.run_until(3.0);
  const long end = walk.step_index();
  const std::vector<double> original = state_of(walk);
  REQUIRE(walk.pushes().size() == 1);
  CHECK_FALSE(walk.fallen());

  // Back to 1.2 s (after the speed change, before the push), forward again: same state at 3 s.
  walk.rewind_to(600);
  CHECK(walk.time_s() == Approx(1.2));
  walk.run_until(3.0);
  CHECK(walk.step_index() == end);
  CHECK(biodyn::testing::bit_identical(state_of(walk), original));
  CHECK(walk.pushes().size() == 1);

  // Back to 0.5 s: both edits replay.
  walk.rewind_to(250);
  walk.run_until(3.0);
  CHECK(biodyn::testing::bit_identical(state_of(walk), original));

  // A new edit after a rewind starts a new future: the push is not replayed.
  walk.rewind_to(700);
  walk.set_speed(1.3);  // the same value again, but a new edit
  walk.run_until(3.0);
  CHECK(walk.pushes().empty());
  CHECK_FALSE(biodyn::testing::bit_identical(state_of(walk), original));

  CHECK_THROWS_AS(walk.rewind_to(walk.step_index() + 1), sim::InvalidArgument);

  // An edit made but not applied before a rewind (a panel edit while scrubbed back) takes
  // effect at the point rewound to, and the old future after it is gone.
  walk.set_speed(1.5);
  walk.rewind_to(1000);
  walk.run_until(2.5);
  CHECK(walk.config().speed_m_s == 1.5);
  CHECK(walk.gait()->speed_command() == 1.5);
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "Live walk: rewinding restores a checkpoint (at most 0.5 s replayed), exact after "
                 "30 s of edits",
                 "[apps][live]") {
  const auto full_state = [](const LiveScenario& s) {
    const mjModel& m = s.simulation().model();
    const mjData& d = s.simulation().data();
    std::vector<double> x = state_of(s);
    x.insert(x.end(), d.qacc_warmstart, d.qacc_warmstart + m.nv);
    x.insert(x.end(), d.ctrl, d.ctrl + m.nu);
    x.insert(x.end(), m.eq_data, m.eq_data + m.neq * mjNEQDATA);
    for (int e = 0; e < m.neq; ++e) x.push_back(m.eq_active[e]);
    x.push_back(static_cast<double>(s.gait()->strike_count()));
    x.push_back(static_cast<double>(s.gait()->phase()));
    return x;
  };
  LiveScenario walk(ScenarioConfig{});
  walk.run_until(3.0);
  controllers::TorqueWalkerParams p = walk.gait()->params();
  p.pelvis_pitch_rad += 0.05;
  walk.set_gait_params(p);
  walk.run_until(12.0);
  walk.push("pelvis", Eigen::Vector3d(0, 60, 0), 0.2);
  walk.run_until(20.0);
  walk.set_weld_mode(controllers::WeldMode::kOff);  // welds released mid-run
  walk.run_until(25.0);
  walk.set_speed(1.2);
  walk.run_until(30.0);
  REQUIRE_FALSE(walk.fallen());
  const std::vector<double> original = full_state(walk);
  const long end = walk.step_index();
  WARN("32 checkpoints hold " << walk.checkpoint_bytes() / 1024 << " KiB");
  CHECK(walk.checkpoint_bytes() < 32u * 1024 * 1024);

  // 27.3 s: from the checkpoint at 27.0 s, 150 steps replayed; the speed edit at 25 s is in it.
  walk.rewind_to(13650);
  CHECK(walk.last_rewind_replayed_steps() == 150);
  walk.run_until(30.0);
  REQUIRE(walk.step_index() == end);
  CHECK(biodyn::testing::bit_identical(full_state(walk), original));

  // 19.9 s, before the weld edit: the weld mode comes back with the replayed edit.
  walk.rewind_to(9950);
  CHECK(walk.last_rewind_replayed_steps() < 250);
  CHECK(walk.config().weld == controllers::WeldMode::kHonest);
  walk.run_until(30.0);
  CHECK(walk.config().weld == controllers::WeldMode::kOff);
  CHECK(biodyn::testing::bit_identical(full_state(walk), original));

  // 2 s is older than the ring (16 s): replayed from t = 0, as exact.
  walk.rewind_to(1000);
  CHECK(walk.last_rewind_replayed_steps() == 1000);
  walk.run_until(30.0);
  CHECK(biodyn::testing::bit_identical(full_state(walk), original));

  // A new edit drops the checkpoints after it: rewinding into the new future uses its own.
  walk.rewind_to(12000);
  walk.set_speed(0.8);
  walk.run_until(30.0);
  const std::vector<double> changed = full_state(walk);
  CHECK_FALSE(biodyn::testing::bit_identical(changed, original));
  walk.rewind_to(14000);
  CHECK(walk.last_rewind_replayed_steps() == 0);  // the new checkpoint at 28.0 s
  walk.run_until(30.0);
  CHECK(biodyn::testing::bit_identical(full_state(walk), changed));
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "Live squat: rewinding across pose changes from a checkpoint is exact",
                 "[apps][live]") {
  ScenarioConfig squat;
  squat.scenario = "squat";
  squat.weld = controllers::WeldMode::kGlue;
  LiveScenario s(squat);
  s.run_until(6.0);
  const std::vector<double> original = state_of(s);
  s.rewind_to(1100);  // 2.2 s, from the checkpoint at 2.0 s
  CHECK(s.last_rewind_replayed_steps() == 100);
  s.run_until(6.0);
  CHECK(biodyn::testing::bit_identical(state_of(s), original));
}

TEST_CASE_METHOD(
    biodyn::testing::SimulationTest,
    "Live stones: the paper's stepping stones, walked as biodyn walk --steps walks them",
    "[apps][live][stones]") {
  ScenarioConfig config;
  config.scenario = "stones";
  config.speed_m_s = 0.7;  // the plan's mean step at the gait's cadence (walk_test.cc)
  config.weld = controllers::WeldMode::kOff;
  LiveScenario live(config);
  const std::vector<scenarios::Stone>& stones = live.stones();
  // To the strike on the last stone: each stone is drawn where its foot then lands, off by the
  // length error along the heading (the walker plans lengths, not widths: across, by how far
  // the swing foot strayed).
  while (live.time_s() < 14.0 && !(stones.size() == 6 && !std::isnan(stones.back().walked_m)))
    live.step();
  REQUIRE(stones.size() == 6);
  {
    const mjModel& m = live.simulation().model();
    const mjData& d = live.simulation().data();
    const scenarios::Stone& last = stones.back();
    const int foot = mj_name2id(&m, mjOBJ_BODY, last.side == 0 ? "foot_l" : "foot_r");
    const Eigen::Vector2d off =
        Eigen::Vector2d(d.xpos[3 * foot], d.xpos[3 * foot + 1]) - last.ankle_W;
    const Eigen::Vector2d along(std::cos(last.heading_rad), std::sin(last.heading_rad));
    const double off_along = off.dot(along),
                 off_across = std::abs(off.x() * along.y() - off.y() * along.x());
    WARN("last stone at " << d.time << " s: the foot lands " << 100 * off_along
                          << " cm ahead of it (walked - target "
                          << 100 * (last.walked_m - last.target_m) << " cm), " << 100 * off_across
                          << " cm across");
    CHECK(off_along == Approx(last.walked_m - last.target_m).margin(0.01));
    CHECK(off_across < 0.05);
  }
  live.run_until(14.0);
  CHECK_FALSE(live.fallen());
  REQUIRE(stones.size() == 6);

  sim::Simulation sim(sim::Model::from_string(
      models::to_mjcf(models::generate_character(config.character)), "generated character"));
  scenarios::WalkRunParams p;
  p.duration_s = 14;
  p.config.scenario = "stones";
  p.config.speed_m_s = 0.7;
  p.config.weld = controllers::WeldMode::kOff;
  p.config.steps_m = scenarios::paper_stepping_stones_m();
  const scenarios::WalkRunResult r = scenarios::run_walk(&sim, p);
  REQUIRE(r.stones);
  REQUIRE(r.stones->lengths_m.size() == 6);
  for (std::size_t i = 0; i < stones.size(); ++i) {
    INFO("stone " << i + 1 << ": target " << stones[i].target_m << " m, walked "
                  << stones[i].walked_m << " m (biodyn walk: " << r.stones->lengths_m[i] << " m)");
    CHECK(stones[i].target_m == p.config.steps_m[i]);
    CHECK(stones[i].walked_m == Approx(r.stones->lengths_m[i]).margin(1e-9));
    CHECK(std::abs(stones[i].walked_m - stones[i].target_m) < 0.05);
    if (i > 0) CHECK(stones[i].side != stones[i - 1].side);
  }

  // Rewound into the stones (7.3 s, from a checkpoint): the same walk, the same stones.
  const std::vector<double> end_state = state_of(live);
  const std::vector<scenarios::Stone> walked = stones;
  live.rewind_to(3650);
  CHECK(stones.size() < walked.size());
  live.run_until(14.0);
  CHECK(biodyn::testing::bit_identical(state_of(live), end_state));
  REQUIRE(stones.size() == walked.size());
  CHECK(stones.back().walked_m == walked.back().walked_m);
  CHECK(stones.back().ankle_W == walked.back().ankle_W);

  ScenarioConfig walk_with_steps;
  walk_with_steps.steps_m = {0.5};
  CHECK_THROWS_WITH(LiveScenario(walk_with_steps), Catch::Matchers::Contains("stones scenario"));
  config.steps_m = {0.5, 2.0};
  CHECK_THROWS_WITH(LiveScenario(config), Catch::Matchers::Contains("planned step 2"));
}

TEST_CASE_METHOD(
    biodyn::testing::SimulationTest,
    "Live walk: a walker parameter edited mid-run changes the walk, saved params read back",
    "[apps][live]") {
  LiveScenario a(ScenarioConfig{}), b(ScenarioConfig{});
  a.run_until(1.0);
  b.run_until(1.0);
  REQUIRE(biodyn::testing::bit_identical(state_of(a), state_of(b)));
  controllers::TorqueWalkerParams p = b.gait()->params();
  p.pelvis_pitch_rad += 0.1;  // lean forward: the walk speeds up
  b.set_gait_params(p);
  a.run_until(3.0);
  b.run_until(3.0);
  const double xa = a.simulation().data().subtree_com[3 * 1];
  const double xb = b.simulation().data().subtree_com[3 * 1];
  CHECK(xb > xa + 0.02);  // the leaning walker is ahead (measured: see the WARN)
  WARN("pelvis pitch +0.1 rad from 1 s: CoM at 3 s " << xb << " m vs " << xa << " m");

  // The walker's JSON (biodyn walk --params) reads back to the same parameters.
  const std::string saved = b.gait_params_json();
  controllers::TorqueWalkerParams reread;
  controllers::apply_torque_walker_json(saved, "saved.json", &reread);
  CHECK(controllers::torque_walker_json(reread) == saved);
  CHECK(reread.pelvis_pitch_rad == p.pelvis_pitch_rad);

  // The controller parameters likewise (biodyn pose --params).
  controllers::ControllerParams cp = *b.controller_params();
  cp.joints.front().reaction_time_s = 0.04;
  b.set_controller_params(cp);
  b.step();
  ScenarioConfig from_saved;
  from_saved.controller_json = b.controller_params_json();
  from_saved.controller_source = "saved_controller.json";
  LiveScenario c(from_saved);
  CHECK(c.controller_params_json() == b.controller_params_json());
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "Live scenarios: standing holds, bad configs and edits are refused",
                 "[apps][live]") {
  ScenarioConfig stand;
  stand.scenario = "stand";
  LiveScenario s(stand);
  s.run_until(2.0);
  CHECK_FALSE(s.fallen());
  CHECK(s.gait() == nullptr);
  CHECK_THROWS_AS(s.set_speed(1.0), sim::InvalidArgument);
  CHECK_THROWS_AS(s.push("nobody", Eigen::Vector3d(1, 0, 0), 0.1), sim::InvalidArgument);
  // A push no one stands through: down by the scenarios' rule (fall_watch.h).
  s.push("pelvis", Eigen::Vector3d(800, 0, 0), 0.5);
  s.run_until(5.0);
  CHECK(s.fallen());
  ScenarioConfig bad;
  bad.scenario = "dance";
  CHECK_THROWS_WITH(LiveScenario(bad), Catch::Matchers::Contains("walk"));
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "Live mocap: a retargeted BVH plays kinematically on the character, looping",
                 "[apps][live][slow]") {
  ScenarioConfig config;
  config.scenario = "mocap";
  config.motion_path =
      biodyn::testing::source_dir() + "/../shared/data/mocap/bvh/cmu_131_01_start_walk_stop.bvh";
  LiveScenario play(config);
  REQUIRE(play.playback());
  const mjModel& m = play.simulation().model();
  // Frame 0 at t = 0; at 1.0 s the frame at or before 1.0 s of the 120 Hz clip (frame 120).
  const std::vector<double> start = state_of(play);
  play.run_until(1.0);
  CHECK(play.time_s() == Approx(1.0));
  const std::vector<double> at1 = state_of(play);
  CHECK_FALSE(biodyn::testing::bit_identical(start, at1));
  CHECK_FALSE(play.fallen());
  CHECK_THROWS_AS(play.push("pelvis", Eigen::Vector3d(100, 0, 0), 0.2), sim::InvalidArgument);
  play.rewind_to(0);
  CHECK(biodyn::testing::bit_identical(state_of(play), start));
  // The same motion from its CSV (what biodyn mocap retarget writes) plays the same frames.
  const mocap_io::RetargetResult r =
      mocap_io::retarget_bvh(mocap_io::read_bvh(config.motion_path),
                             mocap_io::builtin_joint_map("cmu"), config.character, [] {
                               mocap_io::RetargetOptions o;
                               o.source = "cmu";
                               return o;
                             }());
  const std::string csv = biodyn::testing::binary_dir() + "/live_scenario_motion.csv";
  sim::write_file_atomically(csv, mocap_io::format_motion_csv(r.motion));
  ScenarioConfig from_csv = config;
  from_csv.motion_path = csv;
  LiveScenario play_csv(from_csv);
  play_csv.run_until(1.0);
  const std::vector<double> csv_at1 = state_of(play_csv);
  // qpos as written to 9+ significant digits: equal to the in-memory motion within 1e-8.
  REQUIRE(csv_at1.size() == at1.size());
  for (int k = 0; k < m.nq; ++k)
    CHECK(csv_at1[static_cast<std::size_t>(k)] ==
          Approx(at1[static_cast<std::size_t>(k)]).margin(1e-8));
  ScenarioConfig no_motion;
  no_motion.scenario = "mocap";
  CHECK_THROWS_WITH(LiveScenario(no_motion), Catch::Matchers::Contains("--motion"));

  // A part of the motion (--motion-from/--motion-to): replayed from 0; from frame 480 on, its
  // frame at 0.504 s (between frames) is the whole motion's at frame 480's time + 0.504 s.
  ScenarioConfig part = from_csv;
  const double t480 = r.motion.times_s[480] - r.motion.times_s[0];
  part.motion_from_s = t480;
  part.motion_to_s = t480 + 2.0;
  LiveScenario play_part(part);
  CHECK(play_part.motion_length_s() == Approx(2.0).margin(1.0 / 120));
  play_part.run_until(0.504);
  play_csv.run_until(t480 + 0.504);
  const std::vector<double> part_at = state_of(play_part), whole_at = state_of(play_csv);
  for (int k = 0; k < m.nq; ++k)
    CHECK(part_at[static_cast<std::size_t>(k)] ==
          Approx(whole_at[static_cast<std::size_t>(k)]).margin(1e-12));
  part.motion_from_s = 20.0;
  part.motion_to_s = -1;
  CHECK_THROWS_WITH(LiveScenario(part),
                    Catch::Matchers::Contains("fewer than 2 solved frames to play from 20") &&
                        Catch::Matchers::Contains("long"));
  part.motion_from_s = 3.0;
  part.motion_to_s = 2.0;
  CHECK_THROWS_WITH(LiveScenario(part),
                    Catch::Matchers::Contains("motion to: must be after motion from"));
  part.motion_from_s = -1.0;
  part.motion_to_s = -1;
  CHECK_THROWS_WITH(LiveScenario(part),
                    Catch::Matchers::Contains("motion from: must be a time >= 0"));
  ScenarioConfig walk_from;
  walk_from.motion_from_s = 1.0;
  CHECK_THROWS_WITH(LiveScenario(walk_from), Catch::Matchers::Contains("only the mocap scenario"));
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "Live mocap --track: the controllers follow a motion this body can do, the root "
                 "is never pushed",
                 "[apps][live][track]") {
  // A motion this body can do: 6 s of its own walk (qpos every 4 ms), as a motion CSV.
  LiveScenario walk(ScenarioConfig{});
  const mjModel& wm = walk.simulation().model();
  mocap_io::Motion motion;
  motion.columns = mocap_io::qpos_names(wm);
  std::vector<std::vector<double>> rows;
  while (walk.time_s() < 6.0 - 1e-9) {
    if (walk.step_index() % 2 == 0) {
      motion.times_s.push_back(walk.time_s());
      rows.emplace_back(walk.simulation().data().qpos, walk.simulation().data().qpos + wm.nq);
    }
    walk.step();
  }
  motion.qpos.resize(static_cast<Eigen::Index>(rows.size()), wm.nq);
  for (std::size_t r = 0; r < rows.size(); ++r)
    for (int k = 0; k < wm.nq; ++k)
      motion.qpos(static_cast<Eigen::Index>(r), k) = rows[r][static_cast<std::size_t>(k)];
  const std::string dir = testing::fresh_dir("live_test", "track").string();
  const std::string path = dir + "/own_walk.csv";
  sim::write_file_atomically(path, mocap_io::format_motion_csv(motion));

  ScenarioConfig config;
  config.scenario = "mocap";
  config.motion_path = path;
  config.track = true;
  // Open loop first: the joints only follow the motion.
  config.tracker.balance = false;
  LiveScenario open(config);
  REQUIRE(open.tracker() != nullptr);
  CHECK_FALSE(open.playback());  // physics, not a kinematic copy
  double root_force = 0;
  while (open.time_s() < 6.0 - 1e-9) {
    open.step();
    for (int k = 0; k < 6; ++k)
      root_force = std::max(root_force, std::abs(open.simulation().data().qfrc_applied[k]));
  }
  const auto& st = open.tracking_stats();
  WARN("open loop on its own walk: joint error RMS "
       << st.joint_rms_rad() * 57.29578 << " deg (max " << st.joint_max_rad * 57.29578
       << "), root off by up to " << st.root_max_m << " m, fell at " << open.fell_at_s() << " s");
  CHECK(root_force == 0.0);
  // The joints follow the motion while the body is up (measured 2.9 deg RMS); open loop
  // nothing keeps the trunk or the balance and even this walk falls (measured at 3.5 s);
  // the fall is reported.
  CHECK(st.samples > 10);
  CHECK(st.joint_rms_rad() < 5.0 / 57.29578);
  CHECK(open.fell_at_s() > 0.5);
  CHECK_FALSE(open.tracking_report().kept_up());

  // With the balance feedback (the default): the hips and ankles leave the motion to balance,
  // still only through joint torques, and the body keeps up with its own walk to its end
  // (measured: joints 2.4 deg RMS, no fall in 6 s).
  config.tracker.balance = true;
  LiveScenario track(config);
  root_force = 0;
  while (track.time_s() < 6.0 - 1e-9) {
    track.step();
    for (int k = 0; k < 6; ++k)
      root_force = std::max(root_force, std::abs(track.simulation().data().qfrc_applied[k]));
  }
  WARN("with balance feedback: joint error RMS "
       << track.tracking_stats().joint_rms_rad() * 57.29578 << " deg, root off by up to "
       << track.tracking_stats().root_max_m << " m, fell at " << track.fell_at_s() << " s");
  CHECK(root_force == 0.0);
  CHECK_FALSE(biodyn::testing::bit_identical(state_of(track), state_of(open)));
  CHECK(track.fell_at_s() < 0);
  CHECK(track.tracking_report().kept_up());
  CHECK(track.tracking_stats().joint_rms_rad() < 5.0 / 57.29578);

  // The same walk captured 5 cm higher: floored first, so its feet's contacts are read as
  // before and it is tracked the same way.
  mocap_io::Motion raised = motion;
  raised.qpos.col(2).array() += 0.05;  // pelvis_z
  const std::string raised_path = dir + "/own_walk_raised.csv";
  sim::write_file_atomically(raised_path, mocap_io::format_motion_csv(raised));
  ScenarioConfig raised_config = config;
  raised_config.motion_path = raised_path;
  LiveScenario raised_track(raised_config);
  raised_track.run_until(6.0);
  CHECK(raised_track.track_start_lift_m() == Approx(-0.05).margin(1e-9));
  CHECK(raised_track.tracking_report().kept_up());
  CHECK(raised_track.tracking_stats().joint_rms_rad() ==
        Approx(track.tracking_stats().joint_rms_rad()).margin(0.5 / 57.29578));

  // Rewinding a tracked run is exact as well.
  const std::vector<double> end = state_of(track);
  track.rewind_to(1100);
  track.run_until(6.0);
  CHECK(biodyn::testing::bit_identical(state_of(track), end));

  // After the motion's end the targets hold its last frame, mid-stride: the error is counted
  // only while the motion lasts, and a fall after its end still counts as kept up.
  const long samples = track.tracking_stats().samples;
  track.run_until(8.0);
  WARN("after the motion's end: fell at " << track.fell_at_s() << " s");
  CHECK(track.tracking_stats().samples == samples);
  CHECK(track.tracking_report().kept_up());

  config.tracker.lookahead_s = 0;
  CHECK_THROWS_WITH(LiveScenario(config), Catch::Matchers::Contains("lookahead"));
  ScenarioConfig walk_track;
  walk_track.track = true;
  CHECK_THROWS_WITH(LiveScenario(walk_track), Catch::Matchers::Contains("only the mocap scenario"));
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "Live terrain: the viewer's walk has the hill in its scene and climbs it",
                 "[apps][live][terrain]") {
  scenarios::ScenarioConfig config;
  config.terrain.kind = models::Terrain::Kind::kHill;
  scenarios::LiveScenario s(config);
  const mjModel& m = s.simulation().model();
  CHECK(mj_name2id(&m, mjOBJ_GEOM, "terrain_ramp_up") >= 0);
  CHECK(mj_name2id(&m, mjOBJ_GEOM, "terrain_plateau") >= 0);
  const double z0 = s.simulation().data().subtree_com[2];
  s.run_until(12.0);  // on the plateau by then (it starts at 10 m)
  CHECK_FALSE(s.scenario().fallen());
  CHECK(s.simulation().data().subtree_com[2] - z0 > 0.25);
  config.terrain.slope_deg = -1;
  CHECK_THROWS_WITH(scenarios::LiveScenario(config), Catch::Contains("terrain slope"));
}
