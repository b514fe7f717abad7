// The scenario the viewer steps (scenarios/live.h): edits change the simulation, rewinding and
// resuming gives the same future bit for bit, saved parameters read back identically.
#include <cstring>
#include <vector>

#include "biodyn/scenarios/live.h"
#include "biodyn/sim/errors.h"
#include "test_support.h"

using namespace biodyn;
using scenarios::LiveConfig;
using scenarios::LiveScenario;

namespace {

std::vector<double> state_of(const LiveScenario& s) {
  const mjModel& m = s.simulation().model();
  const mjData& d = s.simulation().data();
  std::vector<double> x(d.qpos, d.qpos + m.nq);
  x.insert(x.end(), d.qvel, d.qvel + m.nv);
  x.push_back(d.time);
  return x;
}

bool bit_identical(const std::vector<double>& a, const std::vector<double>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0;
}

}  // namespace

TEST_CASE("Live walk: rewinding and resuming gives the same future, edits included",
          "[apps][live]") {
  testing::MujocoWarningGuard guard;
  LiveScenario walk(LiveConfig{});
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
  CHECK(bit_identical(state_of(walk), original));
  CHECK(walk.pushes().size() == 1);

  // Back to 0.5 s: both edits replay.
  walk.rewind_to(250);
  walk.run_until(3.0);
  CHECK(bit_identical(state_of(walk), original));

  // A new edit after a rewind starts a new future: the push is not replayed.
  walk.rewind_to(700);
  walk.set_speed(1.3);  // the same value again, but a new edit
  walk.run_until(3.0);
  CHECK(walk.pushes().empty());
  CHECK_FALSE(bit_identical(state_of(walk), original));

  CHECK_THROWS_AS(walk.rewind_to(walk.step_index() + 1), sim::InvalidArgument);
}

TEST_CASE("Live walk: a walker parameter edited mid-run changes the walk; saved params read back",
          "[apps][live]") {
  testing::MujocoWarningGuard guard;
  LiveScenario a(LiveConfig{}), b(LiveConfig{});
  a.run_until(1.0);
  b.run_until(1.0);
  REQUIRE(bit_identical(state_of(a), state_of(b)));
  controllers::TorqueGaitParams p = b.gait()->params();
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
  controllers::TorqueGaitParams reread;
  controllers::apply_torque_gait_json(saved, "saved.json", &reread);
  CHECK(controllers::torque_gait_json(reread) == saved);
  CHECK(reread.pelvis_pitch_rad == p.pelvis_pitch_rad);

  // The controller parameters likewise (biodyn pose --params).
  controllers::ControllerParams cp = b.controller_params();
  cp.joints.front().reaction_time_s = 0.04;
  b.set_controller_params(cp);
  b.step();
  LiveConfig from_saved;
  from_saved.controller_json = b.controller_params_json();
  from_saved.controller_source = "saved_controller.json";
  LiveScenario c(from_saved);
  CHECK(c.controller_params_json() == b.controller_params_json());
}

TEST_CASE("Live scenarios: standing holds; bad configs and edits are refused", "[apps][live]") {
  testing::MujocoWarningGuard guard;
  LiveConfig stand;
  stand.scenario = "stand";
  LiveScenario s(stand);
  s.run_until(2.0);
  CHECK_FALSE(s.fallen());
  CHECK(s.gait() == nullptr);
  CHECK_THROWS_AS(s.set_speed(1.0), sim::InvalidArgument);
  CHECK_THROWS_AS(s.push("nobody", Eigen::Vector3d(1, 0, 0), 0.1), sim::InvalidArgument);
  LiveConfig bad;
  bad.scenario = "dance";
  CHECK_THROWS_WITH(LiveScenario(bad), Catch::Matchers::Contains("walk"));
}
