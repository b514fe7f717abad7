#include <cmath>

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
