// The joint controllers (joint_controller.h): the whole-body solve, the muscle limits.
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "biodyn/controllers/control_frame.h"
#include "biodyn/controllers/controller_params.h"
#include "biodyn/controllers/joint_controller.h"
#include "biodyn/models/mjcf.h"
#include "biodyn/models/rig.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/queries.h"
#include "biodyn/sim/units.h"
#include "character.h"
#include "test_support.h"

using namespace biodyn;
using models::JointGroup;

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "Whole-body solve predicts MuJoCo's own accelerations, root untouched",
                 "[controllers][dynamics]") {
  for (const models::Detail detail : {models::Detail::kGait, models::Detail::kFull}) {
    sim::Simulation sim(testing::generated_character(detail));
    const mjModel& m = sim.model();
    const models::Rig rig(m);
    const std::vector<JointGroup>& groups = rig.groups();
    controllers::JointController ctrl(m, rig, controllers::default_params(m, groups),
                                      controllers::ControllerKind::kVelocity);
    controllers::ControlFrame frame(rig, m.nv);
    sim.forward();
    ctrl.reset(m, sim.data(), &frame);
    // Bend the knees a little so the targets ask for motion with both feet on the ground.
    for (std::size_t g = 0; g < groups.size(); ++g) {
      if (groups[g].name.rfind("knee", 0) == 0)
        frame.set_target(static_cast<int>(g),
                         controllers::orientation_from_angles(groups[g], {0.3, 0, 0}), 1.0);
    }
    std::vector<mjtNum> torque(static_cast<std::size_t>(m.nv)),
        zero(static_cast<std::size_t>(m.nv));
    double worst = 0;
    int compared = 0;
    for (int step = 0; step < 200; ++step) {
      std::vector<mjtNum> predicted;
      bool saturated = false;
      sim.step([&](const mjModel& mm, mjData& d) {
        const controllers::JointControlStatus st =
            ctrl.compute(mm, d, frame, zero.data(), torque.data());
        saturated = st.saturated_dofs > 0;
        for (int i = 0; i < mm.nv; ++i) d.qfrc_applied[i] = torque[static_cast<std::size_t>(i)];
        predicted = ctrl.predicted_qacc();
      });
      ctrl.commit();
      for (int i = 0; i < 6; ++i)
        CHECK(torque[static_cast<std::size_t>(i)] == 0.0);  // no hand on the root
      if (saturated) continue;
      ++compared;
      for (int i = 0; i < m.nv; ++i) {
        worst =
            std::max(worst, std::abs(sim.data().qacc[i] - predicted[static_cast<std::size_t>(i)]));
      }
    }
    INFO(models::to_string(detail) << ": compared " << compared << " steps");
    CHECK(compared > 100);
    // Newton's tolerance is 1e-8 relative; accelerations are O(1-100).
    CHECK(worst < 1e-4);
    testing::MujocoWarningGuard::check(sim);
  }
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "Muscle limits hold exactly: |tau| <= tau_max and the reaction-time ramp",
                 "[controllers]") {
  sim::Simulation sim(testing::generated_character(models::Detail::kGait));
  const mjModel& m = sim.model();
  const models::Rig rig(m);
  const std::vector<JointGroup>& groups = rig.groups();
  controllers::ControllerParams p = controllers::default_params(m, groups);
  for (auto& j : p.joints) j.reaction_time_s = 0.1;
  controllers::JointController ctrl(m, rig, p, controllers::ControllerKind::kVelocity);
  controllers::ControlFrame frame(rig, m.nv);
  sim.forward();
  ctrl.reset(m, sim.data(), &frame);
  // An unreachable demand: every joint to a far target immediately.
  for (std::size_t g = 0; g < groups.size(); ++g)
    frame.set_target(static_cast<int>(g),
                     controllers::orientation_from_angles(groups[g], {1.0, 0.3, 0.2}), 0.0);
  std::vector<mjtNum> torque(static_cast<std::size_t>(m.nv)), zero(static_cast<std::size_t>(m.nv));
  std::vector<mjtNum> prev = ctrl.previous_torque();
  bool saw_saturation = false;
  for (int step = 0; step < 100; ++step) {
    sim.step([&](const mjModel& mm, mjData& d) {
      const auto st = ctrl.compute(mm, d, frame, zero.data(), torque.data());
      saw_saturation = saw_saturation || st.saturated_dofs > 0;
      for (int i = 0; i < mm.nv; ++i) d.qfrc_applied[i] = torque[static_cast<std::size_t>(i)];
    });
    ctrl.commit();
    for (int i = 6; i < m.nv; ++i) {
      const double tau_max = ctrl.tau_max()[static_cast<std::size_t>(i)];
      const double step_limit = tau_max * m.opt.timestep / 0.1;
      CHECK(std::abs(torque[static_cast<std::size_t>(i)]) <= tau_max * (1 + 1e-12));
      CHECK(std::abs(torque[static_cast<std::size_t>(i)] - prev[static_cast<std::size_t>(i)]) <=
            step_limit * (1 + 1e-9));
    }
    prev = ctrl.previous_torque();
  }
  CHECK(saw_saturation);
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "Torque-specified DOFs: the solve holds them, converges and predicts mj_step2",
                 "[gait][dynamics]") {
  // The gait makes the legs on the floor springs (lo == hi bounds). The active set used to
  // test them for release like saturated DOFs and cycled to its pass limit.
  sim::Simulation sim(testing::generated_character());
  const mjModel& m = sim.model();
  const models::Rig rig(m);
  const std::vector<controllers::JointGroup>& groups = rig.groups();
  controllers::JointController joints(m, rig, controllers::default_params(m, groups),
                                      controllers::ControllerKind::kVelocity);
  controllers::ControlFrame frame(rig, m.nv);
  sim.forward();
  joints.reset(m, sim.data(), &frame);
  std::vector<int> springs;
  for (const char* name : {"knee_l", "ankle_l", "hip_r", "knee_r", "ankle_r"})
    springs.push_back(models::find_group(groups, name));
  const int hip_l = models::find_group(groups, "hip_l");
  frame.set_target(
      hip_l,
      controllers::orientation_from_angles(groups[static_cast<std::size_t>(hip_l)], {0.2, 0, 0}),
      0.5);
  std::vector<mjtNum> zero(static_cast<std::size_t>(m.nv), 0.0),
      torque(static_cast<std::size_t>(m.nv));
  double worst = 0;
  for (int step = 0; step < 100; ++step) {
    std::vector<mjtNum> predicted, expected(static_cast<std::size_t>(m.nv), 0.0);
    controllers::JointControlStatus st;
    sim.step([&](const mjModel& mm, mjData& d) {
      frame.begin_step();
      for (const int g : springs) frame.set_spring(g, 400.0, 40.0);
      st = joints.compute(mm, d, frame, zero.data(), torque.data());
      predicted = joints.predicted_qacc();
      for (int i = 0; i < mm.nv; ++i) d.qfrc_applied[i] = torque[static_cast<std::size_t>(i)];
    });
    REQUIRE(st.converged);
    joints.commit();
    for (int i = 0; i < m.nv; ++i)
      worst =
          std::max(worst, std::abs(sim.data().qacc[i] - predicted[static_cast<std::size_t>(i)]));
  }
  CHECK(worst < 1e-4);
  testing::MujocoWarningGuard::check(sim);
}
