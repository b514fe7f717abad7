// The scenario registry and interface (scenarios/registry.h, scenario.h): every registered
// scenario builds from a config, steps, is judged by one rule, and saves and restores its whole
// state so its future repeats bit for bit.
#include "biodyn/scenarios/registry.h"

#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "biodyn/models/mjcf.h"
#include "biodyn/scenarios/scenario.h"
#include "biodyn/sim/errors.h"
#include "character.h"
#include "test_support.h"

using namespace biodyn;
using scenarios::ScenarioConfig;

namespace {

std::vector<double> state_of(const sim::Simulation& sim) {
  const mjModel& m = sim.model();
  const mjData& d = sim.data();
  std::vector<double> x(d.qpos, d.qpos + m.nq);
  x.insert(x.end(), d.qvel, d.qvel + m.nv);
  x.insert(x.end(), d.qfrc_applied, d.qfrc_applied + m.nv);
  x.push_back(d.time);
  return x;
}

// Counts the steps it sees; done after `limit`.
struct StepCounter : scenarios::StepObserver {
  long seen = 0, limit = 0;
  void on_step(const scenarios::Scenario&) override { ++seen; }
  bool done() const override { return limit > 0 && seen >= limit; }
};

}  // namespace

TEST_CASE_METHOD(
    biodyn::testing::SimulationTest,
    "The registry lists every scenario once and refuses an unknown name by listing them",
    "[scenarios][registry]") {
  const std::vector<std::string> names = scenarios::scenario_names();
  CHECK(names ==
        std::vector<std::string>{"stand", "squat", "reach", "one-leg", "walk", "stones", "mocap"});
  for (const scenarios::ScenarioInfo& info : scenarios::scenario_registry()) {
    INFO(info.name);
    CHECK_FALSE(info.summary.empty());
    CHECK(static_cast<bool>(info.make));
    CHECK_NOTHROW(scenarios::check_scenario_name(info.name));
  }
  for (const char* pose : {"stand", "squat", "reach", "one-leg"})
    CHECK(scenarios::is_pose_scenario(pose));
  for (const char* other : {"walk", "stones", "mocap", "dance"})
    CHECK_FALSE(scenarios::is_pose_scenario(other));
  CHECK_THROWS_WITH(scenarios::check_scenario_name("dance"), Catch::Contains("'dance'") &&
                                                                 Catch::Contains("stand") &&
                                                                 Catch::Contains("mocap"));
}

TEST_CASE_METHOD(
    testing::SimulationTest,
    "A config refuses, by name, what its scenario does not use or a value out of range",
    "[scenarios][registry]") {
  sim::Simulation sim(biodyn::testing::generated_character());
  const auto refused = [&](const ScenarioConfig& c, const std::string& field) {
    INFO("expects a message naming " << field);
    CHECK_THROWS_WITH(scenarios::make_scenario(&sim, c), Catch::Contains(field));
  };
  ScenarioConfig c;
  c.scenario = "stand";
  c.stop_at_s = 3;
  refused(c, "stop");
  c = {};
  c.scenario = "squat";
  c.steps_m = {0.5, 0.5};
  refused(c, "steps");
  c = {};
  c.pose_duration_s = 4;  // "walk"
  refused(c, "pose duration");
  c = {};
  c.speed_m_s = scenarios::kMaxWalkSpeed_m_s + 0.5;
  refused(c, "speed");
  c = {};
  c.heading_rate_deg_s = -(scenarios::kMaxHeadingRate_deg_s + 1);
  refused(c, "heading");
  c = {};
  c.scenario = "mocap";
  refused(c, "--motion");
  c = {};
  c.track = true;
  refused(c, "track");
  c = {};
  c.scenario = "walk";
  scenarios::WalkPush push;
  push.onset_phase = 1.0;
  c.walk_push = push;
  refused(c, "onset-phase");
  c = {};
  c.scenario = "Walk";
  refused(c, "'Walk'");
}

TEST_CASE_METHOD(testing::SimulationTest,
                 "Every simulated scenario builds at t = 0, steps upright, and repeats its future "
                 "after a restore",
                 "[scenarios][registry]") {
  sim::Simulation sim(biodyn::testing::generated_character());
  for (const std::string name : {"stand", "squat", "reach", "one-leg", "walk", "stones"}) {
    INFO(name);
    ScenarioConfig config;
    config.scenario = name;
    config.steps_start_s = 0.5;  // "stones": the planned steps from the first strike
    sim.data().time = 123;       // the build resets the simulation
    const std::unique_ptr<scenarios::Scenario> s = scenarios::make_scenario(&sim, config);
    CHECK(sim.data().time == 0);
    CHECK(s->step_index() == 0);
    CHECK(s->config().scenario == name);
    REQUIRE(s->pipeline() != nullptr);
    CHECK((s->walk() != nullptr) == config.walking());
    StepCounter counter;
    s->add_observer(&counter);
    s->run_until(0.6);
    CHECK(s->step_index() == counter.seen);
    CHECK(sim.data().time == Approx(0.6).margin(sim.model().opt.timestep));
    CHECK_FALSE(s->fallen());
    CHECK(s->fell_at_s() < 0);
    CHECK_FALSE(s->finished());

    const std::unique_ptr<scenarios::ScenarioState> saved = s->new_state();
    s->save(saved.get());
    CHECK(saved->bytes() > sizeof(mjData));
    const long at = s->step_index();
    s->run_until(1.2);
    const std::vector<double> future = state_of(sim);
    s->restore(*saved);
    CHECK(s->step_index() == at);
    s->run_until(1.2);
    CHECK(biodyn::testing::bit_identical(state_of(sim), future));
    testing::MujocoWarningGuard::check(sim);
  }
}

TEST_CASE_METHOD(testing::SimulationTest,
                 "An observer that is done ends the run, the scenario does not",
                 "[scenarios][registry]") {
  sim::Simulation sim(biodyn::testing::generated_character());
  ScenarioConfig config;
  config.scenario = "stand";
  const std::unique_ptr<scenarios::Scenario> s = scenarios::make_scenario(&sim, config);
  StepCounter counter;
  counter.limit = 25;
  s->add_observer(&counter);
  while (!s->run_over()) s->step();
  CHECK(s->step_index() == 25);
  CHECK_FALSE(s->finished());
}

TEST_CASE_METHOD(testing::SimulationTest,
                 "A simulation that diverges ends the run as a fall at the time it diverged",
                 "[scenarios][registry]") {
  // MuJoCo resets the data to the model's start when the state blows up (bad qacc): measured as
  // it was, the run went on from standing and "fell" seconds into a second walk (a velocity
  // driver's walk at 1.5 m/s printed "FELL at 1.11 s" after 24 steps and 12.4 s).
  sim::Simulation sim(biodyn::testing::generated_character());
  ScenarioConfig config;
  config.scenario = "walk";
  const std::unique_ptr<scenarios::Scenario> s = scenarios::make_scenario(&sim, config);
  s->run_until(0.5);
  REQUIRE(s->diverged_at_s() < 0);
  const std::unique_ptr<scenarios::ScenarioState> saved = s->new_state();
  s->save(saved.get());
  const double t_diverged = sim.data().time;
  sim.data().qvel[0] = 1e20;  // a blown-up state: MuJoCo's bad qvel/qacc check resets the data
  s->step();
  CHECK(sim.warnings().diverged() > 0);
  CHECK(s->diverged_at_s() == t_diverged);
  CHECK(s->fell_at_s() == t_diverged);
  CHECK(s->run_over());
  CHECK_FALSE(guard.take_messages().empty());
  // A restore to before the divergence takes it back (the viewer's rewind).
  s->restore(*saved);
  CHECK(s->diverged_at_s() < 0);
  CHECK(s->fell_at_s() < 0);
  CHECK_FALSE(s->run_over());
}
