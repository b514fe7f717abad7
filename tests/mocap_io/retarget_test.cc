// Retargeting BVH motion to generated characters (retarget.h): joint maps as data, the
// character's own BVH, a motion retargeted back onto the body that made it, and the CMU walk on
// 1.50 m and 2.00 m bodies (issue 5: stance-foot slide < 1 cm per step, no ground penetration
// > 5 mm).

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>

#include "biodyn/mocap_io/retarget.h"
#include "biodyn/models/mjcf.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/model.h"
#include "test_support.h"

using namespace biodyn;
using Catch::Matchers::Contains;
using mocap_io::BvhMotion;
using mocap_io::JointMap;
using mocap_io::RetargetResult;

namespace {

const std::string kCmuWalk = "/../shared/data/mocap/bvh/cmu_131_01_start_walk_stop.bvh";

/// A joint map's text with `keypoints` as its keypoints object.
std::string map_with(const std::string& keypoints) {
  return R"({"name": "test", "keypoints": {)" + keypoints + "}}";
}
const std::string kLegs =
    R"("pelvis": {"joints": ["LH", "RH"], "frame": "Hips"},
       "thigh_l": "LH", "thigh_r": "RH", "shank_l": "LK", "shank_r": "RK",
       "foot_l": "LA", "foot_r": "RA", "toes_l": "LT", "toes_r": "RT")";

void check_map_error(const std::string& text, const std::string& field, const std::string& what) {
  INFO(text);
  try {
    mocap_io::parse_joint_map(text, "maps/test.json");
    FAIL("no error");
  } catch (const sim::InvalidArgument& e) {
    CHECK_THAT(e.what(), Contains("maps/test.json"));
    CHECK_THAT(e.what(), Contains(field));
    CHECK_THAT(e.what(), Contains(what));
  }
}

BvhMotion cmu_walk() { return mocap_io::read_bvh(biodyn::testing::source_dir() + kCmuWalk); }

/// m, world positions of the bodies named like the BVH's joints, from MuJoCo's kinematics.
Eigen::Matrix3Xd body_positions(const mjModel& m, mjData* d, const BvhMotion& bvh) {
  mj_kinematics(&m, d);
  Eigen::Matrix3Xd out = Eigen::Matrix3Xd::Zero(3, bvh.joints.size());
  for (size_t j = 0; j < bvh.joints.size(); ++j) {
    if (bvh.joints[j].end_site) continue;
    const int body = mj_name2id(&m, mjOBJ_BODY, bvh.joints[j].name.c_str());
    REQUIRE(body >= 0);
    out.col(static_cast<long>(j)) = Eigen::Vector3d(d->xpos + 3 * body);
  }
  return out;
}

}  // namespace

TEST_CASE("Joint maps: bad fields are errors naming the file, the field, the rule and the value",
          "[retarget]") {
  REQUIRE(mocap_io::parse_joint_map(map_with(kLegs), "maps/test.json").keypoints.size() == 9);
  check_map_error("{", "not valid JSON", "");
  check_map_error(map_with(kLegs + R"(, "head": {"joints": "H", "weight": 1e400})"),
                  "not valid JSON", "1e400");
  check_map_error(map_with(kLegs + R"(, "elbow_l": "LE")"), "keypoints.elbow_l",
                  "unknown keypoint 'elbow_l'");
  check_map_error(map_with(kLegs + R"(, "head": {"joints": "H", "weight": -1})"),
                  "keypoints.head.weight", "-1");
  check_map_error(map_with(kLegs + R"(, "head": {"joints": "H", "wieght": 1})"), "keypoints.head",
                  "unknown field 'wieght'");
  check_map_error(map_with(kLegs + R"(, "head": {"joints": []})"), "keypoints.head.joints",
                  "at least one joint");
  std::string no_toes = kLegs;
  no_toes = no_toes.substr(0, no_toes.find(R"(, "toes_r")"));
  check_map_error(map_with(no_toes), "keypoints", "missing required keypoint 'toes_r'");
  check_map_error(
      R"({"name": "t", "units": {"metres_per_unit": 0, "up": "y"}, "keypoints": {)" + kLegs + "}}",
      "units.metres_per_unit", "0");
  check_map_error(
      R"({"name": "t", "units": {"metres_per_unit": 1, "up": "x"}, "keypoints": {)" + kLegs + "}}",
      "units.up", "\"x\"");
  check_map_error(map_with(kLegs + R"(, "toes_l": "LA")"), "keypoints.toes_l", "given twice");
  CHECK_THROWS_WITH(mocap_io::builtin_joint_map("vicon"), Contains("cmu"));
}

TEST_CASE_METHOD(
    biodyn::testing::SimulationTest,
    "Joint maps: the built-in maps parse, CMU resolves on the CMU clip, a missing joint "
    "is named",
    "[retarget]") {
  for (const std::string& name : mocap_io::builtin_joint_map_names()) {
    INFO(name);
    const JointMap map = mocap_io::builtin_joint_map(name);
    CHECK(map.name == name);
    CHECK(map.find("pelvis") != nullptr);
  }
  const BvhMotion walk = cmu_walk();
  const JointMap cmu = mocap_io::resolve_joint_map(mocap_io::builtin_joint_map("cmu"), walk, "w");
  CHECK(cmu.find("toes_l_end") != nullptr);  // the optional End Site is there
  // The CMU clip lacks Mixamo's names: the error names the BVH, the map, the keypoint and joint.
  try {
    mocap_io::resolve_joint_map(mocap_io::builtin_joint_map("mixamo"), walk, "walk.bvh");
    FAIL("no error");
  } catch (const sim::InvalidArgument& e) {
    CHECK_THAT(e.what(), Contains("walk.bvh"));
    CHECK_THAT(e.what(), Contains("mixamo"));
    CHECK_THAT(e.what(), Contains("keypoint foot_l"));
    CHECK_THAT(e.what(), Contains("'LeftFoot'"));
  }
  // A namespace prefix is ignored ("mixamorig:Hips" matches "Hips").
  BvhMotion prefixed = walk;
  for (auto& j : prefixed.joints) j.name = "rig:" + j.name;
  CHECK(mocap_io::find_bvh_joint(prefixed, "LeftKnee") >= 0);
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "Retargeting refuses a map with a zero-length leg bone and absurd frame times",
                 "[retarget]") {
  BvhMotion walk = cmu_walk();
  walk.values.conservativeResize(40, Eigen::NoChange);
  const models::CharacterSpec spec;
  // Toes on the ankle joint: the foot would have no direction.
  JointMap bad = mocap_io::builtin_joint_map("cmu");
  for (auto& k : bad.keypoints) {
    if (k.keypoint == "toes_l") k.joints = {"LeftAnkle"};
  }
  mocap_io::RetargetOptions options;
  options.source = "walk.bvh";
  try {
    mocap_io::retarget_bvh(walk, bad, spec, options);
    FAIL("no error");
  } catch (const sim::InvalidArgument& e) {
    CHECK_THAT(e.what(), Contains("walk.bvh"));
    CHECK_THAT(e.what(), Contains("foot_l and toes_l"));
  }
  for (const double frame_time : {1e-12, 1e308}) {
    BvhMotion odd = walk;
    odd.frame_time_s = frame_time;
    CHECK_THROWS_WITH(
        mocap_io::retarget_bvh(odd, mocap_io::builtin_joint_map("cmu"), spec, options),
        Contains("frame time must be within"));
  }
  // Lengths that overflow in metres.
  options.units = mocap_io::BvhUnits{1e300, mocap_io::UpAxis::kY};
  CHECK_THROWS_WITH(mocap_io::retarget_bvh(walk, mocap_io::builtin_joint_map("cmu"), spec, options),
                    Contains("not finite or beyond"));
}

TEST_CASE_METHOD(
    biodyn::testing::SimulationTest,
    "Character BVH: its forward kinematics is MuJoCo's body positions for random poses",
    "[retarget]") {
  models::CharacterSpec spec;
  const models::Character c = models::generate_character(spec);
  const sim::Model model = sim::Model::from_string(models::to_mjcf(c), "character");
  sim::Data data(*model);
  // Random poses inside the joint ranges, the root moved and turned.
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  constexpr int kFrames = 20;
  Eigen::MatrixXd qpos(kFrames, model->nq);
  for (int f = 0; f < kFrames; ++f) {
    mju_copy(data->qpos, model->qpos0, model->nq);
    for (int j = 0; j < model->njnt; ++j) {
      mjtNum* q = data->qpos + model->jnt_qposadr[j];
      if (model->jnt_type[j] == mjJNT_HINGE) {
        q[0] = model->jnt_range[2 * j] +
               u(rng) * (model->jnt_range[2 * j + 1] - model->jnt_range[2 * j]);
      } else if (model->jnt_type[j] == mjJNT_BALL || model->jnt_type[j] == mjJNT_FREE) {
        mjtNum* quat = q + (model->jnt_type[j] == mjJNT_FREE ? 3 : 0);
        if (model->jnt_type[j] == mjJNT_FREE) {
          q[0] = u(rng) - 0.5;
          q[1] = u(rng) - 0.5;
          q[2] = 0.9 + 0.2 * u(rng);
        }
        const double max_angle = model->jnt_type[j] == mjJNT_BALL && model->jnt_limited[j]
                                     ? model->jnt_range[2 * j + 1]
                                     : 3.0;
        mjtNum axis[3] = {u(rng) - 0.5, u(rng) - 0.5, u(rng) - 0.5};
        mju_normalize3(axis);
        mju_axisAngle2Quat(quat, axis, u(rng) * max_angle);
      }
    }
    for (int k = 0; k < model->nq; ++k) qpos(f, k) = data->qpos[k];
  }
  for (const mocap_io::BvhUnits units : {mocap_io::BvhUnits{0.01, mocap_io::UpAxis::kY},
                                         mocap_io::BvhUnits{1.0, mocap_io::UpAxis::kZ}}) {
    const BvhMotion bvh = mocap_io::character_bvh(c, *model, qpos, 1.0 / 120.0, units);
    REQUIRE(bvh.frame_count() == kFrames);
    REQUIRE(bvh.joints.size() >= c.segments.size());
    // Through the text format too: what a user's viewer reads.
    const BvhMotion reread = mocap_io::parse_bvh(mocap_io::format_bvh(bvh), "character.bvh");
    double worst = 0.0;
    for (int f = 0; f < kFrames; ++f) {
      for (int k = 0; k < model->nq; ++k) data->qpos[k] = qpos(f, k);
      const Eigen::Matrix3Xd expected = body_positions(*model, data.get(), bvh);
      const mocap_io::BvhPose pose = mocap_io::forward_kinematics(reread, f, units);
      for (size_t j = 0; j < bvh.joints.size(); ++j) {
        if (bvh.joints[j].end_site) continue;
        worst = std::max(
            worst, (pose.positions_W.col(static_cast<long>(j)) - expected.col(static_cast<long>(j)))
                       .norm());
      }
    }
    INFO("metres per unit " << units.metres_per_unit);
    CHECK(worst < 1e-6);  // the text keeps 10 significant digits
  }
  CHECK_THROWS_AS(mocap_io::character_bvh(c, *model, Eigen::MatrixXd::Zero(2, 3), 0.01),
                  sim::InvalidArgument);
}

TEST_CASE_METHOD(
    biodyn::testing::SimulationTest,
    "Retargeting: the CMU walk on 1.50 m and 2.00 m bodies keeps stance feet planted and "
    "on the ground",
    "[retarget][regression]") {
  const BvhMotion walk = cmu_walk();
  const JointMap cmu = mocap_io::builtin_joint_map("cmu");
  for (const double height : {1.50, 2.00}) {
    models::CharacterSpec spec;
    spec.height_m = height;
    mocap_io::RetargetOptions options;
    options.source = "cmu_131_01";
    double last_progress = 0.0;
    const RetargetResult r = mocap_io::retarget_bvh(walk, cmu, spec, options, [&](double p) {
      CHECK(p >= last_progress);
      last_progress = p;
    });
    const mocap_io::RetargetStats& s = r.stats;
    INFO("height " << height);
    CHECK(last_progress == 1.0);
    CHECK(s.frames == walk.frame_count());
    CHECK(s.unsolved_frames == 0);
    CHECK(r.motion.qpos.rows() == walk.frame_count());
    CHECK(r.bvh.frame_count() == walk.frame_count());
    // Root motion scaled by the leg-length ratio.
    CHECK(s.scale == Approx(s.character_leg_m / s.bvh_leg_m));
    CHECK(s.character_travel_m / s.bvh_travel_m == Approx(s.scale).epsilon(0.03));
    // Nothing sinks into the floor by more than 5 mm (the issue's bound).
    CHECK(s.max_penetration_m <= mocap_io::kRetargetPenetrationBound_m);
    // Stance feet: the clip has ~17 stances of either foot (walking, a kneel on the left knee
    // with the toes tucked, a stop standing on the left heel with the forefoot raised).
    CHECK(r.steps.size() >= 14);
    int under_1cm = 0;
    for (const mocap_io::StanceStep& step : r.steps) {
      std::string limits;
      for (const std::string& j : step.joints_at_limit) limits += " " + j;
      std::printf("retarget %.2f m: step %c frames %d-%d slide %.1f mm, off floor %.1f mm%s%s\n",
                  height, step.side, step.first_frame, step.last_frame, 1e3 * step.slide_m,
                  1e3 * step.height_error_m, limits.empty() ? "" : ", at limit:", limits.c_str());
      if (step.slide_m < 0.01) {
        ++under_1cm;
      } else {
        // A step that slides 1 cm or more does so only where the capture's pose is beyond the
        // character's range of motion: that leg is on a joint limit at its worst frame.
        INFO("step " << step.side << " " << step.first_frame << "-" << step.last_frame << " slide "
                     << step.slide_m);
        CHECK_FALSE(step.joints_at_limit.empty());
        CHECK(step.slide_m < 0.03);
      }
      CHECK(step.height_error_m < 0.02);
    }
    std::printf(
        "retarget %.2f m: %d of %zu steps slide < 1 cm, max %.1f mm; penetration %.1f mm; "
        "keypoint RMS %.1f mm; %.0f frames/s\n",
        height, under_1cm, r.steps.size(), 1e3 * s.max_slide_m, 1e3 * s.max_penetration_m,
        1e3 * s.keypoint_rms_m, s.frames / s.total_seconds);
    // Measured: 17 of 18 (1.50 m) and 17 of 19 (2.00 m); the others are in the kneel and the
    // stop, with the ankle, toes or knee on their limits. A regression guard, not the goal.
    CHECK(under_1cm >= 16);
    CHECK(s.keypoint_rms_m < 0.04);
  }
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "Retargeting: the character's own BVH retargets back onto the same body",
                 "[retarget]") {
  // A motion the character can do exactly (the CMU walk on the default body, first 300 frames:
  // walking, no kneel), written as its BVH, retargeted through the built-in "biodyn" map onto
  // that body: the joint centres come back where they were.
  BvhMotion walk = cmu_walk();
  walk.values.conservativeResize(300, Eigen::NoChange);
  models::CharacterSpec spec;
  const RetargetResult first =
      mocap_io::retarget_bvh(walk, mocap_io::builtin_joint_map("cmu"), spec);
  const BvhMotion own = mocap_io::parse_bvh(mocap_io::format_bvh(first.bvh), "own.bvh");
  const RetargetResult again =
      mocap_io::retarget_bvh(own, mocap_io::builtin_joint_map("biodyn"), spec);
  CHECK(again.stats.scale == Approx(1.0).epsilon(1e-3));
  CHECK(again.stats.unsolved_frames == 0);

  const models::Character c = models::generate_character(spec);
  const sim::Model model = sim::Model::from_string(models::to_mjcf(c), "character");
  sim::Data a(*model), b(*model);
  double sum_sq = 0.0, worst = 0.0;
  long n = 0;
  for (int f = 0; f < walk.frame_count(); ++f) {
    for (int k = 0; k < model->nq; ++k) {
      a->qpos[k] = first.motion.qpos(f, k);
      b->qpos[k] = again.motion.qpos(f, k);
    }
    mj_kinematics(model.get(), a.get());
    mj_kinematics(model.get(), b.get());
    for (int body = 1; body < model->nbody; ++body) {
      const double e =
          (Eigen::Vector3d(a->xpos + 3 * body) - Eigen::Vector3d(b->xpos + 3 * body)).norm();
      sum_sq += e * e;
      worst = std::max(worst, e);
      ++n;
    }
  }
  const double rms = std::sqrt(sum_sq / static_cast<double>(n));
  std::printf("retarget own BVH back: joint centres RMS %.2f mm, max %.2f mm\n", 1e3 * rms,
              1e3 * worst);
  // Not exact: the retargeter rebuilds the swing feet (level roll near contacts, the toes and
  // the ankle's inversion on their limits) rather than copying them, and each pass has its own
  // contact plants. Measured: RMS 10.7 mm, the largest miss 10 cm on a swing foot's toes.
  CHECK(rms < 0.015);
  CHECK(worst < 0.15);
}
