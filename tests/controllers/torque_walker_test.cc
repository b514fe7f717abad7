// The torque walker (SIMBICON on the generated character): it walks from standing, by joint
// torques and foot contacts only.
#include <cmath>
#include <vector>

#include "biodyn/controllers/control_pipeline.h"
#include "biodyn/controllers/gait_core.h"
#include "biodyn/controllers/support_polygon.h"
#include "biodyn/controllers/torque_walker.h"
#include "biodyn/models/mjcf.h"
#include "biodyn/models/rig.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/queries.h"
#include "biodyn/sim/simulation.h"
#include "character.h"
#include "test_support.h"

using namespace biodyn;

namespace {

struct WalkResult {
  bool fallen = false;
  double time_s = 0, distance_m = 0, lateral_m = 0, root_force_max = 0;
  int strikes = 0;
  double mean_step_m = 0;
  std::vector<int> state_order;  // each state entered, in order (first 12)
  double state0_time_s = 0;      // time spent in state 0
  int state0_entries = 0;
  double state0_both_feet = 0;  // fraction of state 0's steps with both feet on the floor
  int base_polygon_steps = 0;
  double tolerance_area_ratio = 0;  // tolerance / support polygon area, at the last evaluation
  bool tolerance_inside_support = false;
};

double polygon_area(const std::vector<Eigen::Vector2d>& p) {
  double a = 0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    const Eigen::Vector2d& u = p[i];
    const Eigen::Vector2d& v = p[(i + 1) % p.size()];
    a += u.x() * v.y() - u.y() * v.x();
  }
  return a / 2;
}

// Walks the default character from standing for `duration_s` with the default parameters.
WalkResult walk(double duration_s, const char* weld,
                const controllers::TorqueWalkerParams& params = controllers::TorqueWalkerParams{}) {
  sim::Simulation sim(testing::generated_character());
  const mjModel& m = sim.model();
  mjData& d = sim.data();
  const models::Rig rig(m);
  const auto& groups = rig.groups();
  controllers::ControlPipelineConfig config;
  config.weld.mode = controllers::parse_weld_mode(weld);
  controllers::ControlPipeline controller(&sim, rig, controllers::default_params(m, groups),
                                          config);
  controller.reset_in_pose(controllers::pose_scenario("stand", groups, 0)[0]);
  controllers::TorqueWalker gait(rig, params);
  const int floor = rig.floor_geom();
  const int feet[2] = {rig.leg(models::kLeft).foot, rig.leg(models::kRight).foot};
  const int toes[2] = {rig.leg(models::kLeft).toes, rig.leg(models::kRight).toes};
  const auto down = [&](int s) {
    return sim::floor_contact_count(m, d, floor, feet[s]) > 0 ||
           sim::floor_contact_count(m, d, floor, toes[s]) > 0;
  };
  gait.reset(d);
  controller.set_driver(&gait);
  const double x0 = d.qpos[0], y0 = d.qpos[1], z0 = d.qpos[2], t0 = d.time;
  WalkResult r;
  double steps = 0;
  int counted = 0, last = 0, state = -1, state0_steps = 0, both_feet_steps = 0;
  while (d.time - t0 < duration_s) {
    controller.step();
    if (gait.phase() != state) {
      state = gait.phase();
      if (r.state_order.size() < 12) r.state_order.push_back(state);
      if (state == 0) ++r.state0_entries;
    }
    if (state == 0) {
      r.state0_time_s += m.opt.timestep;
      ++state0_steps;
      if (down(0) && down(1)) ++both_feet_steps;
    }
    for (int k = 0; k < 6; ++k)
      r.root_force_max = std::max(r.root_force_max, std::abs(d.qfrc_applied[k]));
    if (gait.strike_count() != last) {
      last = gait.strike_count();
      if (last > 4) {  // past the start
        steps += gait.last_strike().step_length_m;
        ++counted;
      }
    }
    if (d.qpos[2] < 0.7 * z0) {
      r.fallen = true;
      break;
    }
  }
  r.time_s = d.time - t0;
  r.distance_m = d.qpos[0] - x0;
  r.lateral_m = d.qpos[1] - y0;
  r.strikes = gait.strike_count();
  r.mean_step_m = counted ? steps / counted : 0;
  r.state0_both_feet = state0_steps ? static_cast<double>(both_feet_steps) / state0_steps : 0;
  r.base_polygon_steps = gait.base_polygon_steps();
  const auto& support = gait.support_polygon();
  const auto& tolerance = gait.tolerance_polygon();
  if (support.size() >= 3 && tolerance.size() == support.size()) {
    r.tolerance_area_ratio = polygon_area(tolerance) / polygon_area(support);
    r.tolerance_inside_support = true;
    for (const Eigen::Vector2d& q : tolerance)
      r.tolerance_inside_support &= controllers::inside_convex(support, q);
  }
  return r;
}

// The joint torques (torque_max_Nm per DOF, the free joint's 0) of a torque walker's first
// drive() after its reset on `d`, the left foot its stance; `heading_rad` gets its heading.
std::vector<double> first_drive_torques(const models::Rig& rig, const mjModel& m, const mjData& d,
                                        const controllers::TorqueWalkerParams& p,
                                        double* heading_rad = nullptr) {
  controllers::TorqueWalker walker(rig, p);
  walker.reset(d);
  REQUIRE(walker.stance_side() == models::kLeft);
  controllers::ControlFrame frame(rig, m.nv);
  frame.begin_step();
  const controllers::StepReport report{};
  walker.drive({m, d, rig, report}, &frame);
  if (heading_rad) *heading_rad = walker.heading_rad();
  std::vector<double> tau(static_cast<std::size_t>(m.nv));
  for (int v = 6; v < m.nv; ++v) tau[static_cast<std::size_t>(v)] = frame.command(v).torque_max_Nm;
  return tau;
}

}  // namespace

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "The torque walker walks from standing by joint torques and contacts only",
                 "[gait][walk]") {
  for (const char* weld : {"off", "honest"}) {
    INFO("weld " << weld);
    const WalkResult r = walk(10.0, weld);
    CHECK_FALSE(r.fallen);
    CHECK(r.time_s >= 10.0 - 1e-9);
    // Measured 60 s from standing: 66 m (1.1 m/s), 137 steps/min, steps 0.51 m.
    CHECK(r.distance_m / r.time_s > 0.8);
    CHECK(r.distance_m / r.time_s < 1.4);
    CHECK(std::abs(r.lateral_m) < 1.0);
    CHECK(r.strikes >= 15);
    CHECK(r.mean_step_m > 0.4);
    CHECK(r.root_force_max == 0.0);  // nothing pushes the root
  }
}

TEST_CASE_METHOD(
    biodyn::testing::SimulationTest,
    "The walker's states are data: a double support state added in front runs in order",
    "[gait][walk]") {
  controllers::TorqueWalkerParams p;
  controllers::TorqueWalkerPhase ds;
  ds.name = "double support";
  ds.duration_s = 0.08;
  ds.swing_foot_down = true;
  ds.swing_hip_rad = -0.3;  // the trailing thigh behind the hip
  ds.swing_knee_rad = 0.3;
  ds.swing_ankle_rad = -0.2;  // push-off
  ds.stance_knee_rad = p.phases[0].stance_knee_rad;
  ds.stance_ankle_rad = p.phases[0].stance_ankle_rad;
  p.phases.insert(p.phases.begin(), ds);
  const WalkResult r = walk(10.0, "honest", p);
  CHECK_FALSE(r.fallen);
  // From standing the first step starts with the lift (state 1), then 1, 2, 0, 1, 2, 0, ...
  REQUIRE(r.state_order.size() >= 7);
  CHECK(r.state_order[0] == 1);
  for (std::size_t i = 1; i < r.state_order.size(); ++i)
    CHECK(r.state_order[i] == (r.state_order[i - 1] + 1) % 3);
  // Each double support lasts its duration (one state per strike) with both feet down.
  REQUIRE(r.state0_entries >= 10);
  CHECK(r.state0_time_s / r.state0_entries == Approx(0.08).margin(0.004));
  CHECK(r.state0_both_feet > 0.8);
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "Base-polygon balance: the rule leaves the tuned gait alone and moves steps when "
                 "the CoM runs off",
                 "[gait][walk]") {
  // The tuned gait: its velocity feedback already steps further than the rule asks, so the
  // rule moves no step and the walk is the same with it off (measured: 0 steps at 0.5-1.5 m/s).
  controllers::TorqueWalkerParams off;
  off.base_polygon_rule = false;
  const WalkResult with_rule = walk(8.0, "honest");
  const WalkResult without = walk(8.0, "honest", off);
  CHECK_FALSE(with_rule.fallen);
  CHECK(with_rule.base_polygon_steps == 0);
  CHECK(with_rule.distance_m == without.distance_m);
  // Tolerance polygon: the support polygon scaled by 2 x 25% about its centre: a quarter of its
  // area, inside it.
  CHECK(with_rule.tolerance_area_ratio == Approx(0.25).margin(1e-9));
  CHECK(with_rule.tolerance_inside_support);
  // Without the sagittal feedback and with the late swing's thigh behind the vertical, the
  // CoM runs ahead of the stance foot's tolerance polygon: the rule lengthens steps.
  controllers::TorqueWalkerParams weak;
  weak.sagittal_cd = weak.sagittal_cv = 0;
  weak.phases[1].swing_hip_rad = -0.1;
  const WalkResult ruled = walk(2.0, "honest", weak);
  CHECK(ruled.base_polygon_steps >= 1);
  weak.base_polygon_rule = false;
  CHECK(walk(2.0, "honest", weak).base_polygon_steps == 0);
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "The torque walker rejects invalid parameters and models without legs by name",
                 "[gait]") {
  const sim::Model model = testing::generated_character();
  const mjModel& m = *model.get();
  const models::Rig rig(m);
  controllers::TorqueWalkerParams p;
  p.phases[0].duration_s = 0;
  CHECK_THROWS_WITH(controllers::TorqueWalker(rig, p),
                    Catch::Matchers::Contains("states[0].duration_s"));
  p = controllers::TorqueWalkerParams{};
  p.phases[1].ends_at_strike = false;  // no state ends at the strike
  CHECK_THROWS_WITH(controllers::TorqueWalker(rig, p),
                    Catch::Matchers::Contains("states[1].end") &&
                        Catch::Matchers::Contains("must end at the strike"));
  p = controllers::TorqueWalkerParams{};
  p.phases[1].name = p.phases[0].name;
  CHECK_THROWS_WITH(controllers::TorqueWalker(rig, p), Catch::Matchers::Contains("states[1].name"));
  p = controllers::TorqueWalkerParams{};
  p.phases.clear();
  CHECK_THROWS_WITH(controllers::TorqueWalker(rig, p),
                    Catch::Matchers::Contains("at least one state"));
  p = controllers::TorqueWalkerParams{};
  p.damping_time_s = -1;
  CHECK_THROWS_WITH(controllers::TorqueWalker(rig, p), Catch::Matchers::Contains("damping_time_s"));
  p = controllers::TorqueWalkerParams{};
  p.start_shift_s = 1.5;  // a start's weight shift, not a stand
  CHECK_THROWS_WITH(controllers::TorqueWalker(rig, p),
                    Catch::Matchers::Contains("start_shift_s") &&
                        Catch::Matchers::Contains("must be in [0, 1] s"));
  p = controllers::TorqueWalkerParams{};
  p.start_shift_reach_s = 0;
  CHECK_THROWS_WITH(controllers::TorqueWalker(rig, p),
                    Catch::Matchers::Contains("start_shift_reach_s"));
  const sim::Model ball = testing::load_inline(
      "<mujoco><worldbody><body name='pelvis'><freejoint/><geom "
      "size='0.1'/></body></worldbody></mujoco>");
  const models::Rig ball_rig(*ball.get());
  CHECK_THROWS_WITH(controllers::TorqueWalker(ball_rig, controllers::TorqueWalkerParams{}),
                    Catch::Matchers::Contains("thigh_l"));
}

TEST_CASE("The torque walker's parameter file round-trips and overrides only what it names",
          "[gait]") {
  controllers::TorqueWalkerParams p;
  p.phases[0].duration_s = 0.41;
  p.phases[1].swing_knee_rad = 0.3;
  p.hip_kp = 912.5;
  p.speed_integral_rad_per_m = 0.0;
  controllers::TorqueWalkerParams q;
  controllers::apply_torque_walker_json(controllers::torque_walker_json(p), "saved.json", &q);
  CHECK(controllers::torque_walker_json(q) == controllers::torque_walker_json(p));
  CHECK(q.hip_kp == 912.5);
  controllers::TorqueWalkerParams r;
  controllers::apply_torque_walker_json(R"({"knee_kp": 300})", "partial.json", &r);
  CHECK(r.knee_kp == 300);
  CHECK(r.hip_kp == controllers::TorqueWalkerParams{}.hip_kp);
  // Errors leave the params as they were.
  CHECK_THROWS_WITH(
      controllers::apply_torque_walker_json(R"({"knee_kp": "stiff"})", "bad.json", &r),
      Catch::Matchers::Contains("bad.json.knee_kp") && Catch::Matchers::Contains("number"));
  CHECK(r.knee_kp == 300);
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "The torque walker rejects a step plan out of range, naming the step",
                 "[gait][stones]") {
  const sim::Model model = testing::generated_character();
  const models::Rig rig(*model.get());
  controllers::TorqueWalker gait(rig, controllers::TorqueWalkerParams{});
  CHECK_THROWS_WITH(gait.plan_steps({0.5, -0.2}), Catch::Matchers::Contains("planned step 2") &&
                                                      Catch::Matchers::Contains("-0.2"));
  gait.plan_steps({0.5, 0.3});
  CHECK(gait.planned_steps_left() == 2);
  // Widths: one per length, each within [-0.3, 0.8] m.
  CHECK_THROWS_WITH(gait.plan_steps({0.5, 0.3}, {0.2}),
                    Catch::Matchers::Contains("one per planned step"));
  CHECK_THROWS_WITH(
      gait.plan_steps({0.5, 0.3}, {0.2, 0.9}),
      Catch::Matchers::Contains("planned step 2 width") && Catch::Matchers::Contains("0.9"));
  gait.plan_steps({0.5, 0.3, 0.4}, {0.2, -0.05, 0.1});
  CHECK(gait.planned_steps_left() == 3);
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "The stance knee's weight support is the torque that presses the body's weight "
                 "through the ankle",
                 "[gait]") {
  // Coros et al. 2010's virtual force on the stance leg: tau = J' f, f the share of the body's
  // weight the foot presses down. A knee bent forward of the hip-ankle line gets extension
  // torque m g x (the ankle's horizontal offset from the knee), nothing else changes.
  sim::Simulation sim(testing::generated_character());
  const mjModel& m = sim.model();
  mjData& d = sim.data();
  const models::Rig rig(m);
  const models::RigLeg& left = rig.leg(models::kLeft);
  const int knee_dof = rig.groups()[static_cast<std::size_t>(left.knee)].dof_begin;
  d.qpos[m.jnt_qposadr[m.dof_jntid[knee_dof]]] = 0.5;  // the left (stance) knee bent 29 deg
  mj_forward(&m, &d);
  auto stance_torques = [&](double support) {
    controllers::TorqueWalkerParams p;
    p.stance_weight_support = support;
    return first_drive_torques(rig, m, d, p);
  };
  const std::vector<double> off = stance_torques(0), on = stance_torques(1);
  const int knee_joint = m.dof_jntid[knee_dof];
  const int ankle_joint = m.dof_jntid[rig.groups()[static_cast<std::size_t>(left.ankle)].dof_begin];
  double mass = 0;
  for (int b = 1; b < m.nbody; ++b) mass += m.body_mass[b];
  // The ankle lies behind the bent knee: pressing the weight down through it needs extension.
  const double behind = (d.xanchor[3 * knee_joint] - d.xanchor[3 * ankle_joint]);
  REQUIRE(behind > 0.1);
  const double expected = -mass * 9.81 * behind;  // flexion positive
  CHECK(on[static_cast<std::size_t>(knee_dof)] - off[static_cast<std::size_t>(knee_dof)] ==
        Approx(expected).epsilon(0.02));
  for (int v = 6; v < m.nv; ++v) {
    if (v == knee_dof) continue;
    INFO("dof " << v);
    CHECK(on[static_cast<std::size_t>(v)] == off[static_cast<std::size_t>(v)]);
  }
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "With velocity actuation the walker sets targets, springs and velocity wishes, "
                 "never torques",
                 "[gait]") {
  // The paper's velocity-based controllers (§3) under the same gait: the swing leg and the
  // upper body reach targets (their torques from the whole-body solve), the legs with a foot on
  // the floor are springs, the hips carry velocity wishes (stance: the pelvis's world
  // orientation, §4.1; swing: the thigh's heading-frame goal).
  sim::Simulation sim(testing::generated_character());
  const mjModel& m = sim.model();
  mjData& d = sim.data();
  const models::Rig rig(m);
  mj_forward(&m, &d);
  controllers::TorqueWalker walker(rig, controllers::TorqueWalkerParams{});
  walker.set_actuation(controllers::WalkerActuation::kVelocity);
  walker.reset(d);
  controllers::ControlFrame frame(rig, m.nv);
  frame.begin_step();
  const controllers::StepReport report{};
  walker.drive({m, d, rig, report}, &frame);
  using controllers::DofMode;
  const auto mode = [&](int group) {
    return frame.command(rig.groups()[static_cast<std::size_t>(group)].dof_begin).mode;
  };
  const auto torque_fixed = [&](int group) {
    const controllers::DofCommand& c =
        frame.command(rig.groups()[static_cast<std::size_t>(group)].dof_begin);
    return std::isfinite(c.torque_min_Nm) && c.torque_min_Nm == c.torque_max_Nm;
  };
  const models::RigLeg& stance = rig.leg(walker.stance_side());
  const models::RigLeg& swing = rig.leg(1 - walker.stance_side());
  CHECK(mode(stance.knee) == DofMode::kSpring);
  CHECK(mode(stance.ankle) == DofMode::kSpring);
  CHECK(mode(swing.knee) == DofMode::kTarget);
  CHECK(mode(swing.ankle) == DofMode::kTarget);
  CHECK(mode(swing.hip) == DofMode::kVelocity);
  CHECK(mode(stance.hip) == DofMode::kVelocity);  // the stance foot is on the floor
  CHECK(mode(rig.group("lumbar")) == DofMode::kTarget);
  for (std::size_t g = 0; g < rig.groups().size(); ++g) {
    INFO(rig.groups()[g].name);
    CHECK_FALSE(torque_fixed(static_cast<int>(g)));
  }
  // The same walker with torques: every DOF's torque prescribed.
  walker.set_actuation(controllers::WalkerActuation::kTorque);
  frame.begin_step();
  walker.drive({m, d, rig, report}, &frame);
  for (std::size_t g = 0; g < rig.groups().size(); ++g) {
    INFO(rig.groups()[g].name);
    CHECK(torque_fixed(static_cast<int>(g)));
  }
  CHECK(controllers::parse_walker_actuation("velocity", "--controller") ==
        controllers::WalkerActuation::kVelocity);
  CHECK_THROWS_WITH(controllers::parse_walker_actuation("pd", "--controller"),
                    Catch::Matchers::Contains("--controller: expected torque or velocity"));
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "In the air the stance hip turns its thigh upright, not the pelvis", "[gait]") {
  // flight_stance_thigh: with neither foot on the floor a hip torque turns the light legs far
  // more than the pelvis, so the stance hip's torque is the one that brings its thigh upright in
  // the heading frame, damped relative to the pelvis; with a foot on the floor it is SIMBICON's
  // torso torque as before.
  sim::Simulation sim(testing::generated_character());
  const mjModel& m = sim.model();
  mjData& d = sim.data();
  const models::Rig rig(m);
  const models::RigLeg& left = rig.leg(models::kLeft);
  const int hip_dof = rig.groups()[static_cast<std::size_t>(left.hip)].dof_begin;
  // The left (stance) thigh turned 0.3 rad about its y (extension), the pelvis as generated.
  const double turn = 0.3;
  d.qpos[m.jnt_qposadr[m.dof_jntid[hip_dof]]] = std::cos(turn / 2);
  d.qpos[m.jnt_qposadr[m.dof_jntid[hip_dof]] + 2] = std::sin(turn / 2);
  double heading_rad = 0;  // the walker's heading at its reset
  const auto stance_hip_torque_W = [&](bool flight_stance_thigh, double lift_m) {
    d.qpos[2] = m.qpos0[2] + lift_m;
    mj_forward(&m, &d);
    controllers::TorqueWalkerParams p;
    p.flight_stance_thigh = flight_stance_thigh;
    const std::vector<double> tau = first_drive_torques(rig, m, d, p, &heading_rad);
    Eigen::Vector3d t_B;
    for (int k = 0; k < 3; ++k) t_B[k] = tau[static_cast<std::size_t>(hip_dof + k)];
    return Eigen::Vector3d(sim::quat_at(d.xquat + 4 * left.thigh) * t_B);
  };
  // On the floor: the same torque either way.
  const Eigen::Vector3d floor_on = stance_hip_torque_W(true, -0.02);
  REQUIRE((controllers::foot_touches_floor(m, d, rig, models::kLeft) ||
           controllers::foot_touches_floor(m, d, rig, models::kRight)));
  CHECK(floor_on.isApprox(stance_hip_torque_W(false, -0.02)));
  // In the air: towards the thigh upright (the rotation that undoes its turn), and not the
  // torso torque.
  const Eigen::Vector3d air_on = stance_hip_torque_W(true, 0.3);
  REQUIRE_FALSE(controllers::foot_touches_floor(m, d, rig, models::kLeft));
  REQUIRE_FALSE(controllers::foot_touches_floor(m, d, rig, models::kRight));
  const Eigen::Quaterniond q_heading(Eigen::AngleAxisd(heading_rad, Eigen::Vector3d::UnitZ()));
  const Eigen::AngleAxisd to_upright(q_heading *
                                     sim::quat_at(d.xquat + 4 * left.thigh).conjugate());
  const Eigen::Vector3d axis = to_upright.angle() * to_upright.axis();
  INFO("in the air " << air_on.transpose() << ", to upright " << axis.transpose());
  REQUIRE(axis.norm() > 0.2);
  CHECK(air_on.normalized().dot(axis.normalized()) > 0.99);
  CHECK_FALSE(air_on.isApprox(stance_hip_torque_W(false, 0.3), 0.1));
  // The thigh turning relative to the pelvis: the torque changes against that turn.
  d.qvel[hip_dof + 1] = 1.0;  // rad/s about the thigh's y
  const Eigen::Vector3d air_turning = stance_hip_torque_W(true, 0.3);
  const Eigen::Vector3d w_relative =
      sim::vec3_at(d.cvel + 6 * left.thigh) - sim::vec3_at(d.cvel + 6 * rig.pelvis());
  REQUIRE(w_relative.norm() > 0.9);
  CHECK((air_turning - air_on).normalized().dot(-w_relative.normalized()) > 0.99);
  // The whole body turning together (the root's angular velocity, the hip at rest): no change.
  d.qvel[hip_dof + 1] = 0;
  d.qvel[5] = 1.0;  // rad/s, the free joint's angular velocity about its z
  CHECK(stance_hip_torque_W(true, 0.3).isApprox(air_on, 1e-9));
}
