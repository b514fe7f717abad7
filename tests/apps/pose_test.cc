// The pose scenarios end to end: quiet standing with each weld mode and reaction time, and the
// arm reach reaching its targets.
#include "biodyn/scenarios/pose.h"

#include "biodyn/models/character.h"
#include "biodyn/models/mjcf.h"
#include "test_support.h"

using namespace biodyn;

namespace {

sim::Simulation make_sim(models::Detail detail) {
  models::CharacterSpec spec;
  spec.detail = detail;
  return sim::Simulation(testing::load_inline(models::to_mjcf(models::generate_character(spec))));
}

// Issue 3: the orientation error at each target's reach time must stay below 3 degrees.
constexpr double kReachToleranceDeg = 3.0;

}  // namespace

TEST_CASE("Quiet standing holds for every weld mode and reaction time", "[apps][pose]") {
  testing::MujocoWarningGuard guard;
  for (const controllers::WeldMode weld : {controllers::WeldMode::kOff, controllers::WeldMode::kHonest}) {
    for (const double t_r : {0.01, 0.15}) {
      sim::Simulation sim = make_sim(models::Detail::kFull);
      scenarios::PoseRunParams p;
      p.scenario = "stand";
      p.duration_s = 10;
      p.weld = weld;
      p.reaction_time_s = t_r;
      const scenarios::PoseRunResult r = scenarios::run_pose(&sim, p);
      INFO("weld " << controllers::to_string(weld) << ", t_r " << t_r);
      CHECK_FALSE(r.fallen);
      CHECK(r.weld_tension_steps == 0);
      CHECK(r.warnings.total() == 0);
      // No growing oscillation: the last window is no livelier than the first.
      REQUIRE(r.joint_velocity_rms.size() >= 2);
      CHECK(r.joint_velocity_rms.back() <= r.joint_velocity_rms.front());
      if (weld == controllers::WeldMode::kHonest) CHECK(r.weld_active_fraction > 0.5);
    }
  }
}

TEST_CASE("Arm reach: every joint within 3 degrees of its target at the reach time",
          "[apps][pose]") {
  for (const double t_r : {0.02, 0.1}) {
    sim::Simulation sim = make_sim(models::Detail::kFull);
    scenarios::PoseRunParams p;
    p.scenario = "reach";
    p.reaction_time_s = t_r;
    const scenarios::PoseRunResult r = scenarios::run_pose(&sim, p);
    INFO("t_r " << t_r);
    CHECK_FALSE(r.fallen);
    REQUIRE(r.targets.size() == 3);
    CHECK(r.max_orientation_error_deg < kReachToleranceDeg);
    CHECK(r.weld_tension_steps == 0);
  }
}

TEST_CASE("Bad pose parameters are refused with the field named", "[apps][pose]") {
  sim::Simulation sim = make_sim(models::Detail::kGait);
  scenarios::PoseRunParams p;
  p.scenario = "cartwheel";
  CHECK_THROWS_WITH(scenarios::run_pose(&sim, p), Catch::Contains("scenario: must be one of"));
  p.scenario = "reach";  // the gait character has no arms
  CHECK_THROWS_WITH(scenarios::run_pose(&sim, p), Catch::Contains("--detail full"));
  p.scenario = "stand";
  p.reaction_time_s = 5;
  CHECK_THROWS_WITH(scenarios::run_pose(&sim, p), Catch::Contains("reaction-time"));
}
