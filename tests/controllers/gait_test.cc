// The walking pieces that stand on their own: the IK triangle, the base-polygon rule, the
// gait parameters as data, torque windows and the gait driver's state machine and targets.
#include <cmath>
#include <nlohmann/json.hpp>
#include <random>

#include "biodyn/controllers/control_pipeline.h"
#include "biodyn/controllers/gait_core.h"
#include "biodyn/controllers/motion_tracker.h"
#include "biodyn/controllers/velocity_walker.h"
#include "biodyn/controllers/velocity_walker_params.h"
#include "biodyn/models/mjcf.h"
#include "biodyn/models/rig.h"
#include "biodyn/sim/errors.h"
#include "test_support.h"

using namespace biodyn;
using Catch::Matchers::Contains;

namespace {

constexpr double kDeg = M_PI / 180;

sim::Model character() {
  return testing::load_inline(models::to_mjcf(models::generate_character(models::CharacterSpec{})));
}

// The default character at rest with joint controllers reset on it (velocity kind); a
// positive `reaction_time_s` replaces every joint's.
struct JointsAtRest {
  explicit JointsAtRest(double reaction_time_s = 0)
      : model(character()),
        m(*model.get()),
        data(m),
        d(*data.get()),
        rig((mj_forward(&m, &d), m)),
        groups(rig.groups()),
        joints(m, rig, params(m, groups, reaction_time_s), controllers::ControllerKind::kVelocity),
        frame(rig, m.nv) {
    joints.reset(m, d, &frame);
  }
  static controllers::ControllerParams params(const mjModel& mm, const std::vector<controllers::JointGroup>& g,
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

}  // namespace

TEST_CASE("The IK triangle puts the ankle on a reachable target", "[gait]") {
  const double l1 = 0.44, l2 = 0.45;
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> forward(-0.4, 0.5), down(-0.85, -0.6);
  for (int trial = 0; trial < 50; ++trial) {
    const Eigen::Vector3d r(forward(rng), 0.0, down(rng));
    if (r.norm() > std::sqrt(l1 * l1 + l2 * l2 + 2 * l1 * l2 * std::cos(5 * kDeg))) continue;
    const controllers::LegTriangle leg = controllers::solve_leg_triangle(l1, l2, r, 1.0, 5 * kDeg);
    INFO("target " << r.transpose());
    REQUIRE(leg.reachable);
    CHECK(leg.knee_flexion_rad >= 5 * kDeg - 1e-12);
    // Forward kinematics in the sagittal plane: thigh at hip flexion, shank knee-flexed back.
    const double a = leg.hip_flexion_rad, b = leg.hip_flexion_rad - leg.knee_flexion_rad;
    const Eigen::Vector3d ankle(l1 * std::sin(a) + l2 * std::sin(b), 0.0, -l1 * std::cos(a) - l2 * std::cos(b));
    CHECK((ankle - r).norm() < 1e-9);
  }
}

TEST_CASE("The IK triangle gives the closest reachable pose for a target out of reach", "[gait]") {
  const double l1 = 0.44, l2 = 0.45;
  const Eigen::Vector3d far(0.9, 0.0, -0.7);  // 1.14 m away, the leg is 0.89 m
  const controllers::LegTriangle leg = controllers::solve_leg_triangle(l1, l2, far, 1.0, 5 * kDeg);
  CHECK_FALSE(leg.reachable);
  CHECK(leg.knee_flexion_rad == Approx(5 * kDeg));
  const double a = leg.hip_flexion_rad, b = leg.hip_flexion_rad - leg.knee_flexion_rad;
  const Eigen::Vector3d ankle(l1 * std::sin(a) + l2 * std::sin(b), 0.0, -l1 * std::cos(a) - l2 * std::cos(b));
  // Pointing at the target, as long as the leg can be.
  CHECK(ankle.normalized().dot(far.normalized()) == Approx(1.0).epsilon(1e-9));
  CHECK(ankle.norm() == Approx(std::sqrt(l1 * l1 + l2 * l2 + 2 * l1 * l2 * std::cos(5 * kDeg))));
  // Sideways: abduction leans the leg outward for either side.
  const Eigen::Vector3d out_left(0.0, 0.1, -0.8), out_right(0.0, -0.1, -0.8);
  CHECK(controllers::solve_leg_triangle(l1, l2, out_left, 1.0, 0).hip_abduction_rad > 0);
  CHECK(controllers::solve_leg_triangle(l1, l2, out_right, -1.0, 0).hip_abduction_rad > 0);
}

TEST_CASE("The base-polygon step puts the CoM on the new tolerance edge (paper 4.3)", "[gait]") {
  const double foot = 0.26;
  for (double com_from_rear : {0.3, 0.5, 0.8}) {
    const double step = controllers::base_polygon_step(com_from_rear, foot);
    // New polygon: stance heel (rear) to the new foot's toe.
    const double length = step + foot;
    CHECK(com_from_rear / length == Approx(0.75));
  }
}

TEST_CASE("Gait parameters round-trip through JSON and reject bad input by name", "[gait]") {
  const controllers::VelocityWalkerParams defaults = controllers::default_velocity_walker_params();
  REQUIRE_NOTHROW(defaults.validate());
  const nlohmann::json j = controllers::velocity_walker_json(defaults);
  controllers::VelocityWalkerParams back;
  back.phases.clear();
  controllers::apply_velocity_walker_json(j.dump(), "test.json", &back);
  CHECK(controllers::velocity_walker_json(back) == j);

  controllers::VelocityWalkerParams p = defaults;
  controllers::apply_velocity_walker_json(R"({"placement": {"capture_gain": 1.3}})", "g.json", &p);
  CHECK(p.placement.capture_gain == 1.3);
  CHECK(p.phases.size() == defaults.phases.size());
  controllers::apply_velocity_walker_json(R"({"compliance": {"stance_knee": 2.5}, "placement": {"swing_clearance_m": 0.08}})",
                               "g.json", &p);
  CHECK(p.compliance.stance_knee == 2.5);
  CHECK(p.placement.swing_clearance_m == 0.08);

  const auto fails = [&](const std::string& text, const std::string& expected) {
    controllers::VelocityWalkerParams q = defaults;
    INFO(text);
    CHECK_THROWS_WITH(controllers::apply_velocity_walker_json(text, "g.json", &q), Contains(expected));
    CHECK(controllers::velocity_walker_json(q) == j);  // untouched on error
  };
  fails(R"({"placement": {"capture_gian": 1}})", "g.json.placement.capture_gian: unknown key");
  fails(R"({"placement": {"capture_gain": "big"}})", "g.json.placement.capture_gain: must be a number");
  fails(R"({"placement": {"tolerance_fraction": 0.9}})", "gait.placement.tolerance_fraction: must be in (0, 0.5]");
  fails(R"({"states": [{"name": "a", "duration_s": 0.2}]})", "must end at the strike");
  fails(R"({"states": [{"duration_s": 0.2, "end": "strike"}]})", "g.json.states[0].name: is required");
  fails(R"({"states": [{"name": "a", "end": "later"}]})", "g.json.states[0].end: must be \"time\" or \"strike\"");
  fails(R"({"posture": {"cadence_steps_per_min": [100]}})", "needs one cadence per speed");
  fails(R"({"compliance": {"stance_knee": -1}})", "gait.compliance.stance_knee: must be in [0, 50]");
  fails(R"({"compliance": {"stiffness": 1}})", "g.json.compliance.stiffness: unknown key");
  fails(R"({"placement": {"swing_clearance_m": 0.5}})", "gait.placement.swing_clearance_m: must be in [0, 0.3] m");
  fails("{", "g.json: not valid JSON");
}

TEST_CASE("A torque window narrows one DOF's torque for one step", "[gait]") {
  JointsAtRest at_rest;
  const mjModel& m = at_rest.m;
  mjData& d = at_rest.d;
  const std::vector<controllers::JointGroup>& groups = at_rest.groups;
  controllers::JointController& joints = at_rest.joints;
  controllers::ControlFrame& frame = at_rest.frame;
  const int dof = groups[static_cast<std::size_t>(models::find_group(groups, "knee_l"))].dof_begin;
  std::vector<mjtNum> zero(static_cast<std::size_t>(m.nv), 0.0), torque(static_cast<std::size_t>(m.nv));
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

TEST_CASE("The gait driver runs its states on time and sets the tabled targets", "[gait]") {
  sim::Simulation sim(character());
  const models::Rig rig(sim.model());
  const std::vector<controllers::JointGroup>& groups = rig.groups();
  controllers::ControlPipeline ctrl(&sim, rig, controllers::default_params(sim.model(), groups), {});
  ctrl.reset_in_pose(controllers::pose_scenario("stand", groups, 0).front());
  controllers::VelocityWalkerParams params = controllers::default_velocity_walker_params();
  controllers::VelocityWalker gait(sim.model(), rig, params);
  controllers::GaitCommand command;
  command.speed_m_s = 0.0;
  gait.set_command(command);
  gait.reset(sim.model(), sim.data());
  ctrl.set_driver(&gait);
  // From standing the first state is the lift of the right foot (left in stance).
  REQUIRE(gait.phase_name() == "lift");
  CHECK(gait.stance_side() == 0);
  ctrl.step();
  const int knee_r = models::find_group(groups, "knee_r");
  const Eigen::Quaterniond want = controllers::orientation_from_angles(
      groups[static_cast<std::size_t>(knee_r)], params.phases[1].targets_rad.at("swing_knee"));
  CHECK(controllers::rotation_angle(ctrl.frame().target(knee_r).orientation.conjugate() * want) < 1e-9);
  // The right foot is released (swing), the left wanted in stance.
  CHECK_FALSE(ctrl.welds().stance(1));
  CHECK(ctrl.welds().stance(0));
  // The lift lasts its duration scaled to the cadence at this speed, then the swing starts.
  const double lift = params.phases[1].duration_s * params.posture.reference_cadence_steps_per_min /
                      params.cadence(0.0);
  while (sim.data().time < lift - 1e-9) ctrl.step();
  ctrl.step();
  CHECK(gait.phase_name() == "swing");
}

TEST_CASE("The gait driver names a target role the model does not have", "[gait]") {
  const sim::Model model = character();
  const models::Rig rig(*model.get());
  controllers::VelocityWalkerParams params = controllers::default_velocity_walker_params();
  params.phases[0].targets_rad["swing_tail"] = Eigen::Vector3d::Zero();
  CHECK_THROWS_WITH(controllers::VelocityWalker(*model.get(), rig, params),
                    Contains("targets_deg.swing_tail: the model has no joint 'tail_r'"));
}

TEST_CASE("Torque-specified DOFs: the solve holds them, converges and predicts mj_step2",
          "[gait][dynamics]") {
  // The gait makes the legs on the floor springs (lo == hi bounds). The active set used to
  // test them for release like saturated DOFs and cycled to its pass limit.
  testing::MujocoWarningGuard guard;
  sim::Simulation sim(character());
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
  frame.set_target(hip_l, controllers::orientation_from_angles(groups[static_cast<std::size_t>(hip_l)], {0.2, 0, 0}), 0.5);
  std::vector<mjtNum> zero(static_cast<std::size_t>(m.nv), 0.0), torque(static_cast<std::size_t>(m.nv));
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
      worst = std::max(worst, std::abs(sim.data().qacc[i] - predicted[static_cast<std::size_t>(i)]));
  }
  CHECK(worst < 1e-4);
  testing::MujocoWarningGuard::check(sim);
}

TEST_CASE("A compliant group gets its spring-damper torque for one step", "[gait]") {
  JointsAtRest at_rest(1.0);  // a slow reaction-time ramp the test can see
  const mjModel& m = at_rest.m;
  mjData& d = at_rest.d;
  const std::vector<controllers::JointGroup>& groups = at_rest.groups;
  controllers::JointController& joints = at_rest.joints;
  controllers::ControlFrame& frame = at_rest.frame;
  const int knee = models::find_group(groups, "knee_l");
  const int dof = groups[static_cast<std::size_t>(knee)].dof_begin;
  const auto k = static_cast<std::size_t>(dof);
  d.qvel[dof] = 0.2;
  mj_step1(&m, &d);
  std::vector<mjtNum> zero(static_cast<std::size_t>(m.nv), 0.0), torque(static_cast<std::size_t>(m.nv));
  const double prev = joints.previous_torque()[k];
  const double rate = joints.tau_max()[k] * m.opt.timestep / 1.0;
  // A target whose spring torque is within this step's ramp (half a step above tau_prev).
  const double kp = 100.0, kd = 5.0;
  const double spring = prev + 0.5 * rate;
  const double e = d.qpos[m.jnt_qposadr[m.dof_jntid[dof]]];
  const double target = e + (spring + kd * 0.2) / kp;
  frame.set_target(knee, controllers::orientation_from_angles(groups[static_cast<std::size_t>(knee)], {target, 0, 0}), 1.0);
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

TEST_CASE("A velocity wish replaces w = theta v / t for one step", "[gait]") {
  JointsAtRest at_rest;
  const mjModel& m = at_rest.m;
  mjData& d = at_rest.d;
  const std::vector<controllers::JointGroup>& groups = at_rest.groups;
  controllers::JointController& joints = at_rest.joints;
  controllers::ControlFrame& frame = at_rest.frame;
  const int hip = models::find_group(groups, "hip_r");
  const int dof = groups[static_cast<std::size_t>(hip)].dof_begin;
  mj_step1(&m, &d);
  std::vector<mjtNum> zero(static_cast<std::size_t>(m.nv), 0.0), torque(static_cast<std::size_t>(m.nv));
  const Eigen::Vector3d w(0.3, -0.2, 0.1);
  frame.begin_step();
  frame.set_velocity(hip, w);
  joints.compute(m, d, frame, zero.data(), torque.data());
  const double horizon = joints.params().velocity_horizon_s;
  for (int k = 0; k < 3; ++k)
    CHECK(joints.desired_qacc()[static_cast<std::size_t>(dof + k)] == Approx((w[k] - d.qvel[dof + k]) / horizon));
  // At rest on target the next step asks for nothing.
  frame.begin_step();
  joints.compute(m, d, frame, zero.data(), torque.data());
  for (int k = 0; k < 3; ++k) CHECK(joints.desired_qacc()[static_cast<std::size_t>(dof + k)] == Approx(0.0).margin(1e-9));
}

TEST_CASE("Tracked motion: a standing capture that jitters by centimetres between frames keeps both feet in stance",
          "[gait][track]") {
  // A retargeted stance foot jitters by up to a few centimetres between 120 Hz frames
  // (measured on CMU 131_01: 2.9 cm, read frame to frame as 3.5 m/s); read over +-50 ms the
  // foot is still. 1.5 cm alternating jitter of the whole standing body: 3.6 m/s between frames.
  const sim::Model model = character();
  const mjModel& m = *model.get();
  const int n = 120;
  std::vector<double> times(n);
  Eigen::MatrixXd qpos(n, m.nq);
  for (int f = 0; f < n; ++f) {
    times[static_cast<std::size_t>(f)] = f / 120.0;
    for (int k = 0; k < m.nq; ++k) qpos(f, k) = m.qpos0[k];
    qpos(f, 0) += (f % 2 == 0 ? 0.0075 : -0.0075);
  }
  const models::Rig rig(m);
  const controllers::TrackedMotion still = controllers::make_tracked_motion(m, rig, times, qpos);
  for (int f = 0; f < n; ++f) {
    INFO("frame " << f);
    CHECK(still.stance[static_cast<std::size_t>(f)][0]);
    CHECK(still.stance[static_cast<std::size_t>(f)][1]);
  }
  // A foot that really moves is not in stance: the whole body gliding at 1 m/s.
  for (int f = 0; f < n; ++f) qpos(f, 0) = m.qpos0[0] + times[static_cast<std::size_t>(f)] * 1.0;
  const controllers::TrackedMotion glide = controllers::make_tracked_motion(m, rig, times, qpos);
  CHECK_FALSE(glide.stance[60][0]);
  CHECK_FALSE(glide.stance[60][1]);
}
