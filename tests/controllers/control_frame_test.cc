// The control frame's per-step commands (control_frame.h): a torque window, a spring and a
// velocity wish, each for one step.
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

namespace {

// The fixture: the default character at rest with joint controllers reset on it (velocity
// kind); a positive `reaction_time_s` replaces every joint's.
struct JointsAtRest : biodyn::testing::SimulationTest {
  explicit JointsAtRest(double reaction_time_s = 0)
      : model(testing::generated_character()),
        m(*model.get()),
        data(m),
        d(*data.get()),
        rig((mj_forward(&m, &d), m)),
        groups(rig.groups()),
        joints(m, rig, params(m, groups, reaction_time_s), controllers::ControllerKind::kVelocity),
        frame(rig, m.nv) {
    joints.reset(m, d, &frame);
  }
  static controllers::ControllerParams params(const mjModel& mm,
                                              const std::vector<controllers::JointGroup>& g,
                                              double reaction_time_s) {
    controllers::ControllerParams p = controllers::default_params(mm, g);
    if (reaction_time_s > 0)
      for (auto& j : p.joints) j.reaction_time_s = reaction_time_s;
    return p;
  }
  sim::Model model;
  const mjModel& m;
  sim::Data data;
  mjData& d;
  models::Rig rig;
  const std::vector<controllers::JointGroup>& groups;
  controllers::JointController joints;
  controllers::ControlFrame frame;
};

// The same with a slow reaction-time ramp a test can see (1 s).
struct SlowJointsAtRest : JointsAtRest {
  SlowJointsAtRest() : JointsAtRest(1.0) {}
};

}  // namespace

TEST_CASE_METHOD(JointsAtRest, "A torque window narrows one DOF's torque for one step", "[gait]") {
  const int dof = groups[static_cast<std::size_t>(models::find_group(groups, "knee_l"))].dof_begin;
  std::vector<mjtNum> zero(static_cast<std::size_t>(m.nv), 0.0),
      torque(static_cast<std::size_t>(m.nv));
  mj_step1(&m, &d);
  frame.begin_step();
  frame.limit_torque(dof, 3.0, 4.0);
  joints.compute(m, d, frame, zero.data(), torque.data());
  CHECK(torque[static_cast<std::size_t>(dof)] >= 3.0 - 1e-9);
  CHECK(torque[static_cast<std::size_t>(dof)] <= 4.0 + 1e-9);
  // A window the muscle cannot reach this step (rate limit): the nearest reachable torque.
  joints.commit();
  const double prev = joints.previous_torque()[static_cast<std::size_t>(dof)];
  const double rate = joints.tau_max()[static_cast<std::size_t>(dof)] * m.opt.timestep /
                      joints.params().joints[0].reaction_time_s;
  frame.begin_step();
  frame.limit_torque(dof, prev + 10 * rate, prev + 20 * rate);
  joints.compute(m, d, frame, zero.data(), torque.data());
  CHECK(torque[static_cast<std::size_t>(dof)] == Approx(prev + rate));
  // For one step: the next step's frame is free of it again.
  frame.begin_step();
  joints.compute(m, d, frame, zero.data(), torque.data());
  CHECK(torque[static_cast<std::size_t>(dof)] != Approx(prev + rate));
}

TEST_CASE_METHOD(SlowJointsAtRest, "A compliant group gets its spring-damper torque for one step",
                 "[gait]") {
  const int knee = models::find_group(groups, "knee_l");
  const int dof = groups[static_cast<std::size_t>(knee)].dof_begin;
  const auto k = static_cast<std::size_t>(dof);
  d.qvel[dof] = 0.2;
  mj_step1(&m, &d);
  std::vector<mjtNum> zero(static_cast<std::size_t>(m.nv), 0.0),
      torque(static_cast<std::size_t>(m.nv));
  const double prev = joints.previous_torque()[k];
  const double rate = joints.tau_max()[k] * m.opt.timestep / 1.0;
  // A target whose spring torque is within this step's ramp (half a step above tau_prev).
  const double kp = 100.0, kd = 5.0;
  const double spring = prev + 0.5 * rate;
  const double e = d.qpos[m.jnt_qposadr[m.dof_jntid[dof]]];
  const double target = e + (spring + kd * 0.2) / kp;
  frame.set_target(
      knee,
      controllers::orientation_from_angles(groups[static_cast<std::size_t>(knee)], {target, 0, 0}),
      1.0);
  frame.begin_step();
  frame.set_spring(knee, kp, kd);
  joints.compute(m, d, frame, zero.data(), torque.data());
  CHECK(torque[k] == Approx(spring).margin(1e-6));
  // Stiff gains: held to the reaction-time ramp.
  frame.begin_step();
  frame.set_spring(knee, 1e5, 0.0);
  joints.compute(m, d, frame, zero.data(), torque.data());
  CHECK(torque[k] == Approx(prev + rate));
  // For one step: without a new command the next step prescribes the knee's acceleration
  // again, and the whole-body solve asks for another torque than the spring's.
  frame.begin_step();
  joints.compute(m, d, frame, zero.data(), torque.data());
  CHECK(torque[k] != Approx(spring).margin(1e-6));
}

TEST_CASE_METHOD(JointsAtRest, "A velocity wish replaces w = theta v / t for one step", "[gait]") {
  const int hip = models::find_group(groups, "hip_r");
  const int dof = groups[static_cast<std::size_t>(hip)].dof_begin;
  mj_step1(&m, &d);
  std::vector<mjtNum> zero(static_cast<std::size_t>(m.nv), 0.0),
      torque(static_cast<std::size_t>(m.nv));
  const Eigen::Vector3d w(0.3, -0.2, 0.1);
  frame.begin_step();
  frame.set_velocity(hip, w);
  joints.compute(m, d, frame, zero.data(), torque.data());
  const double horizon = joints.params().velocity_horizon_s;
  for (int k = 0; k < 3; ++k)
    CHECK(joints.desired_qacc()[static_cast<std::size_t>(dof + k)] ==
          Approx((w[k] - d.qvel[dof + k]) / horizon));
  // At rest on target the next step asks for nothing.
  frame.begin_step();
  joints.compute(m, d, frame, zero.data(), torque.data());
  for (int k = 0; k < 3; ++k)
    CHECK(joints.desired_qacc()[static_cast<std::size_t>(dof + k)] == Approx(0.0).margin(1e-9));
}
