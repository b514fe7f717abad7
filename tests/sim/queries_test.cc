#include <cmath>
#include <utility>

#include "biodyn/sim/errors.h"
#include "biodyn/sim/joint_load.h"
#include "biodyn/sim/queries.h"
#include "biodyn/sim/simulation.h"
#include "test_support.h"

using biodyn::sim::Simulation;
using biodyn::testing::load_inline;
using biodyn::testing::MujocoWarningGuard;

namespace {
constexpr double kTight = 1e-9;

// A 3 kg box resting on the floor and a 1 kg free sphere in the air.
const char* kBoxAndBall = R"(
<mujoco>
  <option timestep="0.002" cone="elliptic"/>
  <worldbody>
    <geom name="floor" type="plane" size="5 5 0.1"/>
    <body name="box" pos="0 0 0.1">
      <freejoint/>
      <inertial pos="0 0 0" mass="3" diaginertia="0.02 0.02 0.02"/>
      <geom name="box" type="box" size="0.2 0.1 0.1"/>
    </body>
    <body name="ball" pos="2 0 3">
      <freejoint/>
      <inertial pos="0 0 0" mass="1" diaginertia="0.004 0.004 0.004"/>
      <geom name="ball" type="sphere" size="0.1" contype="0" conaffinity="0"/>
    </body>
  </worldbody>
</mujoco>)";

const char* kArm = R"(
<mujoco>
  <worldbody>
    <body name="upper" pos="0 0 1">
      <joint name="shoulder" type="ball"/>
      <geom type="capsule" fromto="0 0 0 0 0 -0.3" size="0.04" mass="2"/>
      <body name="lower" pos="0 0 -0.3">
        <joint name="elbow" type="hinge" axis="0 1 0"/>
        <geom type="capsule" fromto="0 0 0 0 0 -0.3" size="0.03" mass="1"/>
      </body>
    </body>
  </worldbody>
</mujoco>)";
}  // namespace

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "Centre of mass and its velocity match the closed form", "[sim][queries]") {
  Simulation sim(load_inline(kBoxAndBall));
  auto com = biodyn::sim::center_of_mass(sim.model(), sim.data());
  CHECK(std::abs(com.mass - 4.0) < kTight);
  CHECK((com.position_W - Eigen::Vector3d(0.5, 0, (3 * 0.1 + 3.0) / 4)).norm() < 1e-6);
  // Give the ball a known velocity; the box rests: CoM velocity = (1 kg * v) / 4 kg.
  sim.data().qvel[6] = 4.0;
  sim.data().qvel[8] = -2.0;
  sim.forward();
  com = biodyn::sim::center_of_mass(sim.model(), sim.data());
  CHECK((com.velocity_W - Eigen::Vector3d(1.0, 0, -0.5)).norm() < kTight);
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "Floor contacts report where and how hard the floor pushes", "[sim][queries]") {
  Simulation sim(load_inline(kBoxAndBall));
  for (int i = 0; i < 500; ++i) sim.step();  // settle 1 s
  sim.forward();
  std::vector<biodyn::sim::FloorContact> contacts;
  const int floor = 0;  // geom 0 is the floor
  biodyn::sim::floor_contacts(sim.model(), sim.data(), floor, &contacts);
  REQUIRE(contacts.size() == 4);  // box on plane: four corners
  double normal = 0;
  Eigen::Vector3d tangential = Eigen::Vector3d::Zero();
  for (const auto& c : contacts) {
    CHECK(c.body == sim.model().geom_bodyid[1]);
    CHECK(c.normal_W.z() > 0.999);
    CHECK(std::abs(c.position_W.z()) < 1e-3);
    CHECK(c.normal_force > 0);
    normal += c.normal_force;
    tangential += c.tangential_force_W;
  }
  const double weight = 3.0 * 9.81;
  CHECK(std::abs(normal - weight) < 0.01 * weight);  // at rest the floor carries the box
  CHECK(tangential.norm() < 1e-3 * weight);
  MujocoWarningGuard::check(sim);
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "Relative orientations and ball-joint quaternions", "[sim][queries]") {
  Simulation sim(load_inline(kArm));
  const mjModel& m = sim.model();
  const double angle = 0.7;
  // shoulder: 0.4 rad about x; elbow: 0.7 rad about y.
  const Eigen::Quaterniond q_sh(Eigen::AngleAxisd(0.4, Eigen::Vector3d::UnitX()));
  sim.data().qpos[0] = q_sh.w();
  sim.data().qpos[1] = q_sh.x();
  sim.data().qpos[2] = q_sh.y();
  sim.data().qpos[3] = q_sh.z();
  sim.data().qpos[4] = angle;
  sim.forward();
  const int lower = mj_name2id(&m, mjOBJ_BODY, "lower");
  const Eigen::Quaterniond rel = biodyn::sim::relative_orientation(m, sim.data(), lower);
  const Eigen::Quaterniond expected(Eigen::AngleAxisd(angle, Eigen::Vector3d::UnitY()));
  CHECK(rel.angularDistance(expected) < 1e-9);
  const Eigen::Quaterniond shoulder = biodyn::sim::joint_quaternion(m, sim.data(), 0);
  CHECK(shoulder.angularDistance(q_sh) < 1e-12);
  CHECK(biodyn::sim::relative_orientation(m, sim.data(), 1).angularDistance(q_sh) < 1e-9);
  CHECK_THROWS(biodyn::sim::joint_quaternion(m, sim.data(), 1));  // a hinge
  const auto pose = biodyn::sim::body_pose(m, sim.data(), lower);
  // lower's origin hangs 0.3 m below the shoulder, rotated 0.4 rad about x.
  CHECK((pose.position_W - (Eigen::Vector3d(0, 0, 1) + q_sh * Eigen::Vector3d(0, 0, -0.3))).norm() <
        1e-9);
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "Mechanical energy is conserved by a frictionless free flight", "[sim][queries]") {
  Simulation sim(load_inline(kBoxAndBall));
  sim.data().qvel[6] = 1.0;
  sim.data().qvel[8] = 3.0;
  sim.data().qvel[9] = 2.0;  // spin
  sim.forward();
  const double e0 = biodyn::sim::mechanical_energy(sim.model(), sim.data());
  // Ball: 0.5*1*(1+9) + 0.5*0.004*4 kinetic; potential of both bodies.
  const double expected = 0.5 * 10 + 0.5 * 0.004 * 4 + 9.81 * (3 * 0.1 + 1 * 3);
  CHECK(std::abs(e0 - expected) < 1e-6);
}

namespace {
// A 2 kg bar, its centre 0.5 m out, on a hinge about y whose range stops it at horizontal
// (gravity turns it towards -range); a motor of gear 1 and ctrlrange +-12 N m on the hinge.
const char* kBarOnStop = R"(
<mujoco>
  <option timestep="0.002"/>
  <worldbody>
    <body name="bar" pos="0 0 1">
      <joint name="hinge" type="hinge" axis="0 -1 0" limited="true" range="0 90"/>
      <geom type="capsule" fromto="0 0 0 1 0 0" size="0.02" mass="2"/>
    </body>
  </worldbody>
  <actuator>
    <motor joint="hinge" gear="1" ctrllimited="true" ctrlrange="-12 12"/>
  </actuator>
</mujoco>)";
}  // namespace

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "A range stop's torque is what it carries, and the load meter adds the motor's",
                 "[sim][queries]") {
  Simulation sim(load_inline(kBarOnStop));
  const mjModel& m = sim.model();
  const double gravity_torque = 2 * 9.81 * 0.5;  // 9.81 N m: the stop and the motor share it
  std::vector<mjtNum> row(1), stop(1);
  biodyn::sim::JointLoadStats stats;
  CHECK(biodyn::sim::motor_limits_per_dof(m) == std::vector<double>{12.0});
  biodyn::sim::JointLoadMeter meter(m, {4.0});  // judged against 4 N m
  // The motor's torque through the actuator (ctrl) or applied directly (qfrc_applied, as the
  // control pipeline applies joint torques): the same load.
  for (const auto& [motor, through_ctrl] : {std::pair{0.0, true}, {3.0, true}, {3.0, false}}) {
    sim.data().ctrl[0] = through_ctrl ? motor : 0.0;
    sim.data().qfrc_applied[0] = through_ctrl ? 0.0 : motor;
    for (int i = 0; i < 500; ++i) sim.step();  // 1 s on the stop
    biodyn::sim::joint_stop_torques(m, sim.data(), row.data(), stop.data());
    INFO("motor " << motor << " N m: stop " << stop[0] << " N m");
    // At rest the stop carries what the motor does not (its soft constraint sags a little).
    CHECK(std::abs(stop[0] - (gravity_torque - motor)) < 0.02 * gravity_torque);
    CHECK(std::abs(sim.data().qpos[0]) < 0.01);
    // Motor + stop = the gravity torque, over 4 N m: a load of ~2.45.
    const double load = meter.measure(m, sim.data(), &stats);
    CHECK(std::abs(load - gravity_torque / 4) < 0.05);
  }
  CHECK(stats.steps == 3);
  CHECK(stats.over_steps == 3);
  CHECK(stats.over_longest == 3);
  CHECK(stats.load_peak_dof == 0);
  CHECK(stats.stop_peak_dof == 0);
  CHECK(std::abs(stats.stop_peak_Nm - gravity_torque) < 0.02 * gravity_torque);
  // A stretch above 1 adds to excess_sum once it outlasts the impact time (10 ms: 5 steps).
  CHECK(stats.excess_sum == 0);
  for (int i = 0; i < 4; ++i) meter.measure(m, sim.data(), &stats);
  CHECK(stats.over_run == 7);
  const double excess = gravity_torque / 4 - 1;
  CHECK(std::abs(stats.excess_sum - 2 * excess * excess) < 0.1);
  // Lifted off the stop by a motor stronger than gravity: no stop torque, and a load under 1
  // ends the stretch.
  sim.data().ctrl[0] = 12.0;
  sim.data().qfrc_applied[0] = 0.0;
  biodyn::sim::JointLoadMeter strong(m, {20.0});
  for (int i = 0; i < 100; ++i) sim.step();
  biodyn::sim::joint_stop_torques(m, sim.data(), row.data(), stop.data());
  CHECK(stop[0] == 0.0);
  CHECK(strong.measure(m, sim.data(), &stats) < 1);
  CHECK(stats.over_run == 0);
  CHECK_THROWS_AS(biodyn::sim::JointLoadMeter(m, {1.0, 2.0}), biodyn::sim::InvalidArgument);
}
