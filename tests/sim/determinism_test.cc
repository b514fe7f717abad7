#include "biodyn/sim/determinism.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/simulation.h"
#include "test_support.h"

using biodyn::testing::load_inline;
using biodyn::testing::MujocoWarningGuard;

namespace {
const char* kActuatedChain = R"(
<mujoco>
  <option timestep="0.002"/>
  <worldbody>
    <geom type="plane" size="5 5 0.1"/>
    <body pos="0 0 0.5">
      <freejoint/>
      <geom type="box" size="0.2 0.1 0.05" mass="5"/>
      <body pos="0.2 0 0">
        <joint name="j1" type="hinge" axis="0 1 0" range="-1 1" limited="true" armature="0.01" damping="0.5"/>
        <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.04" mass="1"/>
        <body pos="0.3 0 0">
          <joint name="j2" type="ball" armature="0.01" damping="0.2"/>
          <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03" mass="0.5"/>
        </body>
      </body>
    </body>
  </worldbody>
  <actuator>
    <motor joint="j1" ctrlrange="-5 5" ctrllimited="true"/>
    <motor joint="j2" gear="1 0 0 0 0 0" ctrlrange="-1 1" ctrllimited="true"/>
    <motor joint="j2" gear="0 0 1 0 0 0" ctrlrange="-1 1" ctrllimited="true"/>
  </actuator>
</mujoco>)";
}  // namespace

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "Same model and inputs give bit-identical rollouts", "[sim][determinism]") {
  const biodyn::sim::Model model = load_inline(kActuatedChain);
  const auto a = biodyn::sim::check_deterministic_rollout(model, 1000, 7);
  {
    biodyn::sim::Simulation probe(model.copy());  // the test model itself stays well-behaved
    for (int i = 0; i < 1000; ++i) probe.step();
    MujocoWarningGuard::check(probe);
  }
  CHECK(a.identical);
  CHECK(a.first_mismatch_step == -1);
  // The digest sees the inputs: another seed drives another trajectory.
  const auto b = biodyn::sim::check_deterministic_rollout(model, 1000, 8);
  CHECK(b.identical);
  CHECK(a.final_digest != b.final_digest);
  // ...and repeats exactly across calls.
  CHECK(biodyn::sim::check_deterministic_rollout(model, 1000, 7).final_digest == a.final_digest);
  CHECK_THROWS_AS(biodyn::sim::check_deterministic_rollout(model, 0, 7),
                  biodyn::sim::InvalidArgument);
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest, "state_digest changes with any state bit",
                 "[sim][determinism]") {
  biodyn::sim::Simulation sim(load_inline(kActuatedChain));
  const auto d0 = biodyn::sim::state_digest(sim.model(), sim.data());
  sim.data().qvel[7] = std::nextafter(sim.data().qvel[7], 1.0);
  CHECK(biodyn::sim::state_digest(sim.model(), sim.data()) != d0);
}
