// The pose scenarios end to end (issue 3, "must show"): quiet standing with each weld mode,
// stability across reaction times, squat and reach accuracy, the PD comparison, standing pushes.
#include "biodyn/scenarios/pose.h"

#include "biodyn/models/character.h"
#include "biodyn/models/mjcf.h"
#include "character.h"
#include "test_support.h"

using namespace biodyn;

namespace {

sim::Simulation make_sim(models::Detail detail) {
  return sim::Simulation(testing::generated_character(detail));
}

// Issue 3: the orientation error at each target's reach time must stay below 3 degrees.
constexpr double kReachToleranceDeg = 3.0;

}  // namespace

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "Quiet standing 60 s: upright, CoM inside the support polygon",
                 "[apps][pose][slow]") {
  for (const controllers::WeldMode weld :
       {controllers::WeldMode::kOff, controllers::WeldMode::kHonest}) {
    sim::Simulation sim = make_sim(models::Detail::kFull);
    scenarios::PoseRunParams p;
    p.config.scenario = "stand";
    p.config.pose_duration_s = 60;
    p.config.weld = weld;
    const scenarios::PoseRunResult r = scenarios::run_pose(&sim, p);
    INFO("weld " << controllers::to_string(weld));
    CHECK_FALSE(r.fallen);
    CHECK(r.com_outside_support_s == 0);
    CHECK(r.max_foot_displacement_m < 0.005);
    CHECK(r.weld_tension_steps == 0);
    CHECK(r.warnings.total() == 0);
    if (weld == controllers::WeldMode::kHonest) CHECK(r.weld_active_fraction > 0.5);
  }
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "Stable from t_r = 10 ms to 150 ms: 30 s without a fall or a growing oscillation",
                 "[apps][pose][slow]") {
  for (const double t_r : {0.01, 0.02, 0.05, 0.1, 0.15}) {
    sim::Simulation sim = make_sim(models::Detail::kFull);
    scenarios::PoseRunParams p;
    p.config.scenario = "stand";
    p.config.pose_duration_s = 30;
    p.config.reaction_time_s = t_r;
    const scenarios::PoseRunResult r = scenarios::run_pose(&sim, p);
    INFO("t_r " << t_r);
    CHECK_FALSE(r.fallen);
    CHECK(r.weld_tension_steps == 0);
    CHECK(r.warnings.total() == 0);
    // Joint-velocity RMS per 5 s window: the last no livelier than the first, and every
    // window quiet (standing still: well under 0.05 rad/s).
    REQUIRE(r.joint_velocity_rms.size() == 6);
    CHECK(r.joint_velocity_rms.back() <= r.joint_velocity_rms.front());
    for (const double rms : r.joint_velocity_rms) CHECK(rms < 0.05);
  }
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "Squat-and-stand and arm reach: within 3 degrees at every reach time",
                 "[apps][pose]") {
  for (const std::string scenario : {"squat", "reach"}) {
    for (const double t_r : {0.02, 0.1}) {
      sim::Simulation sim = make_sim(models::Detail::kFull);
      scenarios::PoseRunParams p;
      p.config.scenario = scenario;
      p.config.reaction_time_s = t_r;
      const scenarios::PoseRunResult r = scenarios::run_pose(&sim, p);
      INFO(scenario << ", t_r " << t_r);
      CHECK_FALSE(r.fallen);
      REQUIRE(r.targets.size() == 3);
      // Against the targets the controller was given: the pose plus the balance's lean
      // (max_pose_error_deg, against the bare pose, also counts that deliberate lean).
      CHECK(r.max_orientation_error_deg < kReachToleranceDeg);
      CHECK(r.weld_tension_steps == 0);
      CHECK(r.com_outside_support_s == 0);
    }
  }
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest, "Weight shift onto one leg and back",
                 "[apps][pose]") {
  for (const double t_r : {0.02, 0.1}) {
    sim::Simulation sim = make_sim(models::Detail::kFull);
    scenarios::PoseRunParams p;
    p.config.scenario = "one-leg";
    p.config.reaction_time_s = t_r;
    const scenarios::PoseRunResult r = scenarios::run_pose(&sim, p);
    INFO("t_r " << t_r);
    CHECK_FALSE(r.fallen);
    CHECK(r.max_orientation_error_deg < kReachToleranceDeg);
    CHECK(r.weld_tension_steps == 0);
  }
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest, "The PD controller stands on the same interface",
                 "[apps][pose]") {
  sim::Simulation sim = make_sim(models::Detail::kFull);
  scenarios::PoseRunParams p;
  p.config.scenario = "stand";
  p.config.pose_duration_s = 10;
  p.config.controller = controllers::ControllerKind::kPd;
  const scenarios::PoseRunResult r = scenarios::run_pose(&sim, p);
  CHECK(r.controller == "pd");
  CHECK_FALSE(r.fallen);
  CHECK(r.max_orientation_error_deg < kReachToleranceDeg);
  CHECK(r.weld_tension_steps == 0);
  CHECK(r.warnings.total() == 0);
}

// Floor for the standing push (0.2 s on the pelvis, no stepping). Without a step the capture
// point xi = c + v / omega0 (omega0 = sqrt(g / z_c) ~ 3.1 1/s) must stay over the feet: about
// 0.1 m behind and 0.15 m in front of / beside the CoM here, so a body can at most take
// delta-v ~ 0.3 m/s backward and ~ 0.45 m/s forward or sideways (~120 N and ~180 N for 0.2 s on
// 80 kg). The floor is 100 N (delta-v 0.25 m/s) in every direction: most of the backward bound,
// over half of the others. Measured: see controllers/README.md (biodyn stand-push).
constexpr double kStandingPushFloorN = 100;

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "Standing push of 100 N for 0.2 s is survived without stepping in every direction",
                 "[apps][pose][push]") {
  for (const controllers::WeldMode weld :
       {controllers::WeldMode::kOff, controllers::WeldMode::kHonest}) {
    for (const double deg : {0.0, 180.0, 90.0}) {
      sim::Simulation sim = make_sim(models::Detail::kFull);
      scenarios::PoseRunParams p;
      p.config.scenario = "stand";
      p.config.pose_duration_s = 4.2;
      p.config.weld = weld;
      scenarios::TimedPush push;
      push.force_N = kStandingPushFloorN;
      push.duration_s = 0.2;
      push.direction_deg = deg;
      p.config.pose_push = push;
      const scenarios::PoseRunResult r = scenarios::run_pose(&sim, p);
      INFO("weld " << controllers::to_string(weld) << ", direction " << deg << " deg");
      CHECK(r.survived_push);
      CHECK(r.weld_tension_steps == 0);
    }
  }
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "The push scan stops at the first failure and reports the force below it",
                 "[apps][pose][push]") {
  sim::Simulation sim = make_sim(models::Detail::kFull);
  scenarios::PoseRunParams base;
  scenarios::PushScanParams scan;
  scan.resolution_N = 150;  // coarse: 150 N is survived forward, 300 N is not
  scan.max_force_N = 600;
  scan.settle_s = 2.0;
  const scenarios::StandingPushScan s = scenarios::scan_standing_push(&sim, base, 0.0, scan);
  CHECK(s.max_survived_N == 150);
  CHECK(s.first_failure_N == 300);
  CHECK(s.runs == 2);
  CHECK(s.weld == "honest");
  scan.resolution_N = 0;
  CHECK_THROWS_WITH(scenarios::scan_standing_push(&sim, base, 0.0, scan),
                    Catch::Contains("resolution"));
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "Bad pose parameters are refused with the field named", "[apps][pose]") {
  sim::Simulation sim = make_sim(models::Detail::kGait);
  scenarios::PoseRunParams p;
  p.config.scenario = "cartwheel";
  CHECK_THROWS_WITH(scenarios::run_pose(&sim, p), Catch::Contains("scenario: must be one of"));
  p.config.scenario = "reach";  // the gait character has no arms
  CHECK_THROWS_WITH(scenarios::run_pose(&sim, p), Catch::Contains("--detail full"));
  p.config.scenario = "stand";
  p.config.reaction_time_s = 5;
  CHECK_THROWS_WITH(scenarios::run_pose(&sim, p), Catch::Contains("reaction-time"));
}
