// Joint groups, parameters, swing-twist limits and the contact-consistent whole-body solve.
#include <cmath>
#include <random>

#include "biodyn/controllers/control_pipeline.h"
#include "biodyn/controllers/controller_params.h"
#include "biodyn/controllers/joint_groups.h"
#include "biodyn/controllers/joint_limits.h"
#include <nlohmann/json.hpp>
#include "biodyn/models/mjcf.h"
#include "biodyn/models/rig.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/queries.h"
#include "test_support.h"

using namespace biodyn;
using controllers::JointGroup;

namespace {

constexpr double kAngleTolerance = 1e-9;  // rad: exact geometry up to rounding
constexpr double kDeg = M_PI / 180;

sim::Model character(models::Detail detail = models::Detail::kFull) {
  models::CharacterSpec spec;
  spec.detail = detail;
  return testing::load_inline(models::to_mjcf(models::generate_character(spec)));
}

}  // namespace

TEST_CASE("Joint groups cover every actuated DOF with anatomical names", "[controllers]") {
  const sim::Model model = character();
  const mjModel& m = *model.get();
  const std::vector<JointGroup> groups = models::find_joint_groups(m);
  int dofs = 0;
  for (const JointGroup& g : groups) dofs += g.dof_count;
  CHECK(dofs == m.nv - 6);  // everything but the free root
  for (const char* name : {"hip_l", "knee_r", "ankle_l", "toe_r", "shoulder_l", "elbow_r",
                           "wrist_l", "lumbar", "thorax", "neck", "head", "clavicle_r"}) {
    INFO(name);
    CHECK(models::find_group(groups, name) >= 0);
  }
}

TEST_CASE("orientation_from_angles matches MuJoCo's kinematics", "[controllers]") {
  const sim::Model model = character();
  const mjModel& m = *model.get();
  sim::Data data(m);
  mjData& d = *data.get();
  const std::vector<JointGroup> groups = models::find_joint_groups(m);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> angle(-0.6, 0.6);
  for (int trial = 0; trial < 20; ++trial) {
    mj_resetData(&m, &d);
    std::vector<Eigen::Vector3d> angles(groups.size());
    for (std::size_t g = 0; g < groups.size(); ++g) {
      angles[g] = Eigen::Vector3d(angle(rng), angle(rng), angle(rng));
      const JointGroup& gr = groups[g];
      const Eigen::Quaterniond q = controllers::orientation_from_angles(gr, angles[g]);
      if (gr.ball) {
        const int adr = m.jnt_qposadr[m.dof_jntid[gr.dof_begin]];
        d.qpos[adr] = q.w(), d.qpos[adr + 1] = q.x(), d.qpos[adr + 2] = q.y(), d.qpos[adr + 3] = q.z();
      } else {
        for (int k = 0; k < gr.dof_count; ++k)
          d.qpos[m.jnt_qposadr[m.dof_jntid[gr.dof_begin + k]]] = angles[g][k];
      }
    }
    mj_forward(&m, &d);
    for (std::size_t g = 0; g < groups.size(); ++g) {
      INFO(groups[g].name);
      const Eigen::Quaterniond want = controllers::orientation_from_angles(groups[g], angles[g]);
      const Eigen::Quaterniond got = sim::relative_orientation(m, d, groups[g].body);
      CHECK(controllers::rotation_angle(got.conjugate() * want) < kAngleTolerance);
      // And back: the angles of the orientation are the angles we put in.
      const Eigen::Vector3d back = controllers::angles_from_orientation(groups[g], got);
      for (int k = 0; k < (groups[g].ball ? 3 : groups[g].dof_count); ++k)
        CHECK(back[k] == Approx(angles[g][k]).margin(1e-9));
    }
  }
}

TEST_CASE("Anatomical signs: hip flexion moves the knee forward on both sides", "[controllers]") {
  const sim::Model model = character();
  const std::vector<JointGroup> groups = models::find_joint_groups(*model.get());
  for (const char* hip : {"hip_l", "hip_r"}) {
    const JointGroup& g = groups[static_cast<std::size_t>(models::find_group(groups, hip))];
    const Eigen::Vector3d down(0, 0, -1);
    const Eigen::Vector3d flexed = controllers::orientation_from_angles(g, {0.5, 0, 0}) * down;
    CHECK(flexed.x() > 0.4);  // thigh swings forward
    const Eigen::Vector3d abducted = controllers::orientation_from_angles(g, {0, 0.5, 0}) * down;
    CHECK(abducted.y() * g.side > 0.4);  // away from the midline
  }
}

TEST_CASE("Swing-twist split of hip orientations", "[controllers]") {
  const sim::Model model = character();
  const std::vector<JointGroup> groups = models::find_joint_groups(*model.get());
  const JointGroup& hip = groups[static_cast<std::size_t>(models::find_group(groups, "hip_r"))];
  // Pure twist and pure swing come out as such.
  const Eigen::Quaterniond twist = controllers::orientation_from_angles(hip, {0, 0, 0.4});
  const controllers::SwingTwistAngles t = controllers::swing_twist_angles(hip, twist);
  CHECK(t.internal_rotation == Approx(0.4));
  CHECK(std::abs(t.flexion) < 1e-12);
  const Eigen::Quaterniond flex = controllers::orientation_from_angles(hip, {0.7, 0, 0});
  const controllers::SwingTwistAngles f = controllers::swing_twist_angles(hip, flex);
  CHECK(f.flexion == Approx(0.7));
  CHECK(std::abs(f.internal_rotation) < 1e-12);
  // The default hip limits: 120 deg flexion inside, 40 deg extension outside (30 allowed).
  const controllers::SwingTwistLimits lim =
      *controllers::default_params(*model.get(), groups).at("hip_r").swing_twist;
  CHECK(controllers::swing_ratio(lim, {110 * kDeg, 0, 0}) < 1);
  CHECK(controllers::swing_ratio(lim, {-40 * kDeg, 0, 0}) > 1);
  CHECK(controllers::swing_ratio(lim, {0, 40 * kDeg, 0}) < 1);
  CHECK(controllers::swing_ratio(lim, {0, -40 * kDeg, 0}) > 1);  // adduction limit 30
}

TEST_CASE("Controller params: defaults from the motors, JSON overrides, clear errors",
          "[controllers]") {
  const sim::Model model = character();
  const mjModel& m = *model.get();
  const std::vector<JointGroup> groups = models::find_joint_groups(m);
  controllers::ControllerParams p = controllers::default_params(m, groups);
  const int knee = m.actuator_trnid[2 * mj_name2id(&m, mjOBJ_ACTUATOR, "knee_flexion_l")];
  (void)knee;
  const double knee_motor = m.actuator_ctrlrange[2 * mj_name2id(&m, mjOBJ_ACTUATOR, "knee_flexion_l") + 1];
  CHECK(p.at("knee_l").tau_max_Nm[0] == Approx(knee_motor));
  CHECK(p.at("knee_l").reaction_time_s == Approx(0.02));  // paper §5.1

  controllers::apply_params_json(
      R"({"joints": {"all": {"reaction_time_s": 0.1}, "knee": {"tau_max_Nm": 400},
                     "knee_r": {"reach_time_s": 0.5}}})",
      "p.json", groups, &p);
  CHECK(p.at("hip_l").reaction_time_s == Approx(0.1));
  CHECK(p.at("knee_l").tau_max_Nm[0] == Approx(400));
  CHECK(p.at("knee_r").tau_max_Nm[0] == Approx(400));
  CHECK(p.at("knee_r").reach_time_s == Approx(0.5));
  CHECK(p.at("knee_l").reach_time_s == Approx(0.3));

  // Round trip through JSON.
  controllers::ControllerParams q = controllers::default_params(m, groups);
  controllers::apply_params_json(controllers::params_to_json(p, groups).dump(), "x", groups, &q);
  for (std::size_t g = 0; g < groups.size(); ++g) {
    CHECK(q.joints[g].tau_max_Nm.isApprox(p.joints[g].tau_max_Nm));
    CHECK(q.joints[g].reaction_time_s == Approx(p.joints[g].reaction_time_s));
  }

  const auto error_of = [&](const std::string& json) {
    controllers::ControllerParams t = controllers::default_params(m, groups);
    try {
      controllers::apply_params_json(json, "p.json", groups, &t);
      t.validate(m.opt.timestep);
    } catch (const sim::InvalidArgument& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  CHECK_THAT(error_of(R"({"joints": {"kne": {}}})"), Catch::Contains("p.json: joints.kne"));
  CHECK_THAT(error_of(R"({"joints": {"hip_l": {"tau_max_Nm": [1, 2]}}})"),
             Catch::Contains("must have 3 entries"));
  CHECK_THAT(error_of(R"({"joints": {"knee": {"reaction_time_s": -1}}})"),
             Catch::Contains("joints.knee_l.reaction_time_s"));
  CHECK_THAT(error_of(R"({"joints": {"knee": {"speed": 1}}})"), Catch::Contains("unknown key"));
  CHECK_THAT(error_of("{not json"), Catch::Contains("p.json: not valid JSON"));
  CHECK_THAT(error_of(R"({"controller": {"velocity_horizon_s": 0.001}})"),
             Catch::Contains("velocity_horizon_s"));
}

TEST_CASE("Whole-body solve predicts MuJoCo's own accelerations, root untouched",
          "[controllers][dynamics]") {
  testing::MujocoWarningGuard guard;
  for (const models::Detail detail : {models::Detail::kGait, models::Detail::kFull}) {
    sim::Simulation sim(character(detail));
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
        frame.set_target(static_cast<int>(g), controllers::orientation_from_angles(groups[g], {0.3, 0, 0}), 1.0);
    }
    std::vector<mjtNum> torque(static_cast<std::size_t>(m.nv)), zero(static_cast<std::size_t>(m.nv));
    double worst = 0;
    int compared = 0;
    for (int step = 0; step < 200; ++step) {
      std::vector<mjtNum> predicted;
      bool saturated = false;
      sim.step([&](const mjModel& mm, mjData& d) {
        const controllers::JointControlStatus st = ctrl.compute(mm, d, frame, zero.data(), torque.data());
        saturated = st.saturated_dofs > 0;
        for (int i = 0; i < mm.nv; ++i) d.qfrc_applied[i] = torque[static_cast<std::size_t>(i)];
        predicted = ctrl.predicted_qacc();
      });
      ctrl.commit();
      for (int i = 0; i < 6; ++i) CHECK(torque[static_cast<std::size_t>(i)] == 0.0);  // no hand on the root
      if (saturated) continue;
      ++compared;
      for (int i = 0; i < m.nv; ++i) {
        worst = std::max(worst, std::abs(sim.data().qacc[i] - predicted[static_cast<std::size_t>(i)]));
      }
    }
    INFO(models::to_string(detail) << ": compared " << compared << " steps");
    CHECK(compared > 100);
    // Newton's tolerance is 1e-8 relative; accelerations are O(1-100).
    CHECK(worst < 1e-4);
    testing::MujocoWarningGuard::check(sim);
  }
}

TEST_CASE("Muscle limits hold exactly: |tau| <= tau_max and the reaction-time ramp",
          "[controllers]") {
  sim::Simulation sim(character(models::Detail::kGait));
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
    frame.set_target(static_cast<int>(g), controllers::orientation_from_angles(groups[g], {1.0, 0.3, 0.2}), 0.0);
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

TEST_CASE("Glue weld goes into tension when the body is lifted; honest does not",
          "[controllers][weld]") {
  for (const controllers::WeldMode mode :
       {controllers::WeldMode::kGlue, controllers::WeldMode::kHonest}) {
    sim::Simulation sim(character(models::Detail::kGait));
    const mjModel& m = sim.model();
    const models::Rig rig(m);
    const auto& groups = rig.groups();
    controllers::ControlPipelineConfig cfg;
    cfg.weld.mode = mode;
    controllers::ControlPipeline ctrl(&sim, rig, controllers::default_params(m, groups), cfg);
    ctrl.reset();
    ctrl.set_pose(controllers::pose_scenario("stand", groups, 0).front());
    double mass = 0;
    for (int b = 0; b < m.nbody; ++b) mass += m.body_mass[b];
    // Lift with 1.5x body weight on the pelvis from t = 0.5 s for 0.3 s.
    sim.schedule_push({rig.pelvis(), Eigen::Vector3d(0, 0, 1.5 * mass * 9.81), 0.5, 0.3});
    int tension = 0, welded_before_lift = 0;
    for (int step = 0; step < 500; ++step) {
      const controllers::StepReport r = ctrl.step();
      tension += r.weld_tension;
      if (sim.data().time < 0.5 && r.weld_active[0] && r.weld_active[1]) ++welded_before_lift;
    }
    INFO(controllers::to_string(mode));
    if (mode == controllers::WeldMode::kGlue) {
      CHECK(welded_before_lift > 100);
      CHECK(tension > 0);
    } else {
      CHECK(tension == 0);
    }
  }
}

TEST_CASE("Sparse and dense constraint Jacobians give the same control and weld wrenches",
          "[controllers][dynamics][weld]") {
  // The generated characters use sparse rows (faster Newton); the whole-body solve and the
  // weld wrench read rows either way. Stand glued with bent knees, both models in lockstep.
  models::PhysicsOptions dense_options;
  dense_options.sparse_jacobian = false;
  const models::Character c = models::generate_character({});
  sim::Simulation sparse(testing::load_inline(models::to_mjcf(c)));
  sim::Simulation dense(testing::load_inline(models::to_mjcf(c, dense_options)));
  REQUIRE(mj_isSparse(&sparse.model()));
  REQUIRE_FALSE(mj_isSparse(&dense.model()));
  const models::Rig rig_sparse(sparse.model()), rig_dense(dense.model());
  const auto& groups = rig_sparse.groups();
  controllers::ControlPipelineConfig cfg;
  cfg.weld.mode = controllers::WeldMode::kGlue;
  controllers::ControlPipeline a(&sparse, rig_sparse, controllers::default_params(sparse.model(), groups), cfg);
  controllers::ControlPipeline b(&dense, rig_dense, controllers::default_params(dense.model(), groups), cfg);
  const controllers::Pose squat = controllers::pose_scenario("squat", groups, 0).front();
  for (controllers::ControlPipeline* ctrl : {&a, &b}) {
    ctrl->reset_in_pose(controllers::pose_scenario("stand", groups, 0).front());
    ctrl->set_pose(squat);
  }
  double worst_torque = 0, worst_weld = 0, peak_weld = 0;
  int welded = 0;
  for (int step = 0; step < 150; ++step) {
    const controllers::StepReport ra = a.step(), rb = b.step();
    for (int i = 0; i < sparse.model().nv; ++i)
      worst_torque = std::max(worst_torque, std::abs(sparse.data().qfrc_applied[i] - dense.data().qfrc_applied[i]));
    for (std::size_t s = 0; s < 2; ++s) {
      welded += ra.weld_active[s] && rb.weld_active[s];
      worst_weld = std::max(worst_weld, (ra.weld[s].force_W - rb.weld[s].force_W).norm());
      peak_weld = std::max(peak_weld, rb.weld[s].force_W.norm());
    }
  }
  INFO("worst torque difference " << worst_torque << " N m, weld force " << worst_weld
                                  << " N of peak " << peak_weld << " N");
  CHECK(welded > 200);
  CHECK(peak_weld > 1);  // the welds carry some load (the contacts carry most)
  // Rounding only: the two factorisations add in different orders.
  CHECK(worst_torque < 1e-6);
  CHECK(worst_weld < 1e-6 * peak_weld);
}

TEST_CASE("Hinge targets are clamped inside the joint stops; ball joints are left alone",
          "[controllers]") {
  const sim::Model model = character();
  const std::vector<JointGroup> groups = models::find_joint_groups(*model.get());
  const JointGroup& knee = groups[static_cast<std::size_t>(models::find_group(groups, "knee_l"))];
  REQUIRE(knee.range_rad.size() == 1);
  const double margin = 2 * kDeg;
  CHECK(controllers::clamp_to_range(knee, Eigen::Vector3d(-0.3, 0, 0), margin)[0] ==
        Approx(knee.range_rad[0][0] + margin));
  CHECK(controllers::clamp_to_range(knee, Eigen::Vector3d(9, 0, 0), margin)[0] ==
        Approx(knee.range_rad[0][1] - margin));
  CHECK(controllers::clamp_to_range(knee, Eigen::Vector3d(1, 0, 0), margin)[0] == 1);
  const JointGroup& hip = groups[static_cast<std::size_t>(models::find_group(groups, "hip_l"))];
  CHECK(controllers::clamp_to_range(hip, Eigen::Vector3d(9, 9, 9), margin) == Eigen::Vector3d(9, 9, 9));
}

TEST_CASE("place_in_pose: feet flat at rest height, CoM over the support point, at rest",
          "[controllers]") {
  sim::Simulation sim(character());
  const mjModel& m = sim.model();
  mjData& d = sim.data();
  const models::Rig rig(m);
  const std::vector<JointGroup>& groups = rig.groups();
  const int foot[2] = {rig.leg(models::kLeft).foot, rig.leg(models::kRight).foot};
  const models::Sole& sole = rig.leg(models::kLeft).sole;
  const double rest_sole_z = d.xpos[3 * foot[0] + 2] + sole.z;  // after reset: qpos0
  for (const std::string scenario : {"stand", "squat"}) {
    const std::vector<controllers::Pose> poses = controllers::pose_scenario(scenario, groups, 0);
    const controllers::Pose& pose = scenario == "stand" ? poses[0] : poses[1];  // squat: down
    controllers::BalanceParams balance;
    sim.reset();
    const double lean = controllers::place_in_pose(m, d, rig, pose, balance);
    INFO(scenario << ", lean " << lean);
    CHECK(std::abs(lean) < balance.max_tilt_rad);
    double support_x = 0;
    for (int s = 0; s < 2; ++s) {
      // Flat: the foot frame's z axis is vertical, and the sole at its rest height.
      CHECK(d.xmat[9 * foot[s] + 8] == Approx(1).margin(1e-9));
      CHECK(d.xpos[3 * foot[s] + 2] + sole.z == Approx(rest_sole_z).margin(1e-9));
      support_x += d.xpos[3 * foot[s]] + sole.x_min + balance.support_point_fraction * (sole.x_max - sole.x_min);
    }
    CHECK(d.subtree_com[0] == Approx(support_x / 2).margin(1e-3));
    for (int i = 0; i < m.nv; ++i) CHECK(d.qvel[i] == 0);
  }
}
