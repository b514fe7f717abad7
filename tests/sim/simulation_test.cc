#include <cmath>

#include "biodyn/sim/errors.h"
#include "biodyn/sim/queries.h"
#include "biodyn/sim/simulation.h"
#include "test_support.h"

using biodyn::sim::Push;
using biodyn::sim::Simulation;
using biodyn::testing::load_inline;
using biodyn::testing::MujocoWarningGuard;

namespace {
// A 2 kg free box in zero gravity: pushes give closed-form velocity changes.
const char* kFloatingBox = R"(
<mujoco>
  <option gravity="0 0 0" timestep="0.001" integrator="Euler"/>
  <worldbody>
    <body name="box" pos="0 0 1">
      <freejoint/>
      <inertial pos="0 0 0" mass="2" diaginertia="0.1 0.1 0.1"/>
      <geom type="box" size="0.1 0.1 0.1" contype="0" conaffinity="0"/>
    </body>
  </worldbody>
</mujoco>)";

// Six spheres dropped on a floor with room for only two contacts.
const char* kTooManyContacts = R"(
<mujoco>
  <size nconmax="2" njmax="20"/>
  <worldbody>
    <geom name="floor" type="plane" size="5 5 0.1"/>
    <body pos="0 0 0.09"><freejoint/><geom type="sphere" size="0.1"/></body>
    <body pos="1 0 0.09"><freejoint/><geom type="sphere" size="0.1"/></body>
    <body pos="2 0 0.09"><freejoint/><geom type="sphere" size="0.1"/></body>
  </worldbody>
</mujoco>)";
}  // namespace

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "A push changes velocity by F*duration/m, then stops", "[sim][push]") {
  Simulation sim(load_inline(kFloatingBox));
  const int box = 1;
  Push p;
  p.body = box;
  p.force_W = Eigen::Vector3d(100, -40, 0);  // N
  p.start_s = 0.05;
  p.duration_s = 0.1;
  sim.schedule_push(p);
  while (sim.data().time < 0.3 - 1e-9) sim.step();
  // Impulse 10 N s and -4 N s on 2 kg: 5 m/s and -2 m/s (Euler is exact for constant force).
  constexpr double kTol = 1e-9;
  CHECK(std::abs(sim.data().qvel[0] - 5.0) < kTol);
  CHECK(std::abs(sim.data().qvel[1] + 2.0) < kTol);
  CHECK(sim.data().xfrc_applied[6 * box] == 0.0);  // released after the push
  MujocoWarningGuard::check(sim);
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest, "Pushes are validated when scheduled",
                 "[sim][push]") {
  Simulation sim(load_inline(kFloatingBox));
  Push p;
  p.body = 99;
  p.duration_s = 0.1;
  CHECK_THROWS_AS(sim.schedule_push(p), biodyn::sim::InvalidArgument);
  p.body = 1;
  p.duration_s = 0;
  CHECK_THROWS_WITH(sim.schedule_push(p), Catch::Contains("duration"));
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "Stepping counts MuJoCo warnings and routes them to the logger",
                 "[sim][warnings]") {
  Simulation sim(load_inline(kTooManyContacts));
  long counted = 0;
  for (int i = 0; i < 10; ++i) counted += sim.step().new_warnings.count[mjWARN_CONTACTFULL];
  CHECK(counted > 0);
  CHECK(sim.warnings().count[mjWARN_CONTACTFULL] >= counted);
  CHECK_THAT(sim.warnings().describe(), Catch::Contains("contact list full"));
  // MuJoCo's text reaches the logger (at load time the compiler's forward pass already
  // overflows: that warning comes back in the loader's message, also logged).
  const std::vector<std::string> logged = guard.take_messages();
  REQUIRE(!logged.empty());
  CHECK_THAT(logged.front(), Catch::Contains("contact buffer is full"));
  const long before_reset = sim.warnings().total();
  sim.reset();  // counts restart
  CHECK(sim.warnings().total() < before_reset);
  guard.take_messages();  // the reset's forward pass overflows again: expected here
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "The scratch data answers queries without disturbing the simulation",
                 "[sim][scratch]") {
  Simulation sim(load_inline(kFloatingBox));
  sim.data().qvel[0] = 1.5;
  for (int i = 0; i < 10; ++i) sim.step();
  const std::vector<double> qpos(sim.data().qpos, sim.data().qpos + sim.model().nq);
  const double time = sim.data().time;
  mjData& scratch = sim.synced_scratch();
  CHECK(scratch.qpos[0] == qpos[0]);
  scratch.qacc[0] = 3.0;
  mj_inverse(&sim.model(), &scratch);
  CHECK(std::abs(scratch.qfrc_inverse[0] - 6.0) < 1e-9);  // F = m a on the 2 kg box
  scratch.qpos[0] = 42;
  for (int i = 0; i < sim.model().nq; ++i)
    CHECK(sim.data().qpos[i] == qpos[static_cast<size_t>(i)]);
  CHECK(sim.data().time == time);
}
