// Regression on a real clip: CMU subject 131 trial 01 ("start walk stop") as converted to BVH
// by the bvh11 project (shared/data/README.md). Forward kinematics is checked against MuJoCo's
// own kinematics of a model built from the same hierarchy.

#include <tinyxml2.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "biodyn/mocap_io/bvh.h"
#include "biodyn/models/tables.h"
#include "biodyn/sim/file_io.h"
#include "biodyn/sim/model.h"
#include "test_support.h"

using namespace biodyn;
using biodyn::testing::MujocoWarningGuard;
using mocap_io::BvhChannel;
using mocap_io::BvhMotion;
using mocap_io::BvhUnits;

namespace {

constexpr double kFkTolerance_m = 1e-9;       // brief: BVH FK equals MuJoCo's to 1e-9 m
constexpr double kRotationTolerance = 1e-12;  // rotation matrix entries, MuJoCo vs BVH FK
constexpr double kRoundTripTolerance = 1e-6;  // 10 significant digits keep values to 1e-6
constexpr double kRoundTripFkTolerance_m = 1e-6;
constexpr double kFrameTimeTolerance_s = 1e-12;
constexpr int kFkFrameStride = 10;  // every 10th frame through MuJoCo
// CMU's origin lies on the lab floor and a walker or stander always has a foot on it; the foot
// joints and end sites are skeletal points, not the sole, so they sit up to about the ankle
// height above it (Winter 2009 Fig. 4.1: 0.039 H, ~7 cm) and a little below when a toe end site
// sinks through the rolled-over shoe.
constexpr double kLowestFootMin_m = -0.05;
constexpr double kLowestFootMax_m = 0.10;
// Adult stature range the clip's skeleton must scale to with the CMU preset.
constexpr double kStatureMin_m = 1.5;
constexpr double kStatureMax_m = 2.0;
constexpr double kPi = 3.14159265358979323846;

std::string cmu_path() {
  return biodyn::testing::source_dir() + "/../shared/data/mocap/bvh/cmu_131_01_start_walk_stop.bvh";
}

const BvhMotion& cmu() {
  static const BvhMotion motion = mocap_io::read_bvh(cmu_path());
  return motion;
}

bool is_position(BvhChannel c) {
  return c == BvhChannel::kXposition || c == BvhChannel::kYposition || c == BvhChannel::kZposition;
}

Eigen::Vector3d axis(BvhChannel c) {
  switch (c) {
    case BvhChannel::kXposition:
    case BvhChannel::kXrotation:
      return Eigen::Vector3d::UnitX();
    case BvhChannel::kYposition:
    case BvhChannel::kYrotation:
      return Eigen::Vector3d::UnitY();
    default:
      return Eigen::Vector3d::UnitZ();
  }
}

std::string vec3(const Eigen::Vector3d& v) {
  std::ostringstream s;
  s.precision(17);
  s << v.x() << " " << v.y() << " " << v.z();
  return s.str();
}

std::string body_name(int j) { return "j" + std::to_string(j); }
std::string joint_name(int j, std::size_t k) { return body_name(j) + "c" + std::to_string(k); }

/// MJCF of the hierarchy (file axes and units): each BVH joint a body at its OFFSET. Position
/// channels are slide joints along the parent's axes declared first (the body's pos drops
/// those OFFSET components, so the slide value replaces them); rotation channels are hinges in
/// listed order, so each turns about the axes the earlier ones left: intrinsic composition.
std::string mjcf_from_bvh(const BvhMotion& m) {
  tinyxml2::XMLDocument doc;
  tinyxml2::XMLElement* mujoco = doc.NewElement("mujoco");
  doc.InsertEndChild(mujoco);
  mujoco->SetAttribute("model", "bvh_hierarchy");
  tinyxml2::XMLElement* world = mujoco->InsertNewChildElement("worldbody");
  std::vector<tinyxml2::XMLElement*> bodies;
  for (std::size_t i = 0; i < m.joints.size(); ++i) {
    const mocap_io::BvhJoint& bj = m.joints[i];
    const int j = static_cast<int>(i);
    tinyxml2::XMLElement* body =
        (bj.parent < 0 ? world : bodies[bj.parent])->InsertNewChildElement("body");
    bodies.push_back(body);
    body->SetAttribute("name", body_name(j).c_str());
    Eigen::Vector3d pos = bj.offset;
    for (BvhChannel c : bj.channels) {
      if (is_position(c)) pos = pos.cwiseProduct(Eigen::Vector3d::Ones() - axis(c));
    }
    body->SetAttribute("pos", vec3(pos).c_str());
    // Moving bodies need mass; its value does not enter kinematics.
    tinyxml2::XMLElement* inertial = body->InsertNewChildElement("inertial");
    inertial->SetAttribute("pos", "0 0 0");
    inertial->SetAttribute("mass", 1.0);
    inertial->SetAttribute("diaginertia", "1 1 1");
    for (bool slides : {true, false}) {
      for (std::size_t k = 0; k < bj.channels.size(); ++k) {
        if (is_position(bj.channels[k]) != slides) continue;
        tinyxml2::XMLElement* joint = body->InsertNewChildElement("joint");
        joint->SetAttribute("name", joint_name(j, k).c_str());
        joint->SetAttribute("type", slides ? "slide" : "hinge");
        joint->SetAttribute("axis", vec3(axis(bj.channels[k])).c_str());
      }
    }
  }
  tinyxml2::XMLPrinter printer;
  doc.Print(&printer);
  return printer.CStr();
}

/// Sets qpos from frame f's values (rotations degrees -> radians).
void set_qpos(const BvhMotion& m, const mjModel& model, int f, mjData* d) {
  for (std::size_t i = 0; i < m.joints.size(); ++i) {
    const mocap_io::BvhJoint& bj = m.joints[i];
    for (std::size_t k = 0; k < bj.channels.size(); ++k) {
      const int id = mj_name2id(&model, mjOBJ_JOINT, joint_name(static_cast<int>(i), k).c_str());
      REQUIRE(id >= 0);
      const double v = m.values(f, bj.first_channel + static_cast<int>(k));
      d->qpos[model.jnt_qposadr[id]] = is_position(bj.channels[k]) ? v : v * kPi / 180.0;
    }
  }
}

}  // namespace

TEST_CASE("CMU clip: hierarchy, frames and channel orders as in the file", "[bvh][regression]") {
  const BvhMotion& m = cmu();
  int joints = 0, end_sites = 0;
  for (const auto& j : m.joints) (j.end_site ? end_sites : joints)++;
  CHECK(joints == 31);
  CHECK(end_sites == 7);  // two toes, head, two finger tips, two thumbs
  CHECK(m.frame_count() == 994);
  CHECK(m.channel_count() == 6 + 30 * 3);
  CHECK(std::abs(m.frame_time_s - 0.0083333) < kFrameTimeTolerance_s);

  const int hips = m.find("Hips");
  REQUIRE(hips == 0);
  CHECK(m.joints[hips].parent == -1);
  CHECK(m.joints[hips].channels ==
        std::vector<BvhChannel>{BvhChannel::kXposition, BvhChannel::kYposition,
                                BvhChannel::kZposition, BvhChannel::kZrotation,
                                BvhChannel::kYrotation, BvhChannel::kXrotation});
  const std::vector<BvhChannel> zyx{BvhChannel::kZrotation, BvhChannel::kYrotation,
                                    BvhChannel::kXrotation};
  const std::vector<BvhChannel> zxy{BvhChannel::kZrotation, BvhChannel::kXrotation,
                                    BvhChannel::kYrotation};
  for (const char* name : {"LeftKnee", "Chest", "LeftCollar", "RightCollar"}) {
    INFO(name);
    REQUIRE(m.find(name) >= 0);
    CHECK(m.joints[m.find(name)].channels == zyx);
  }
  for (const char* name : {"LeftShoulder", "RightElbow", "LThumb"}) {
    INFO(name);
    REQUIRE(m.find(name) >= 0);
    CHECK(m.joints[m.find(name)].channels == zxy);
  }
  const int knee = m.find("LeftKnee");
  CHECK(m.joints[knee].parent == m.find("LeftHip"));
  CHECK(m.joints[knee].offset.isApprox(Eigen::Vector3d(2.49329, -6.85026, 0.0)));
  const int toe_end = m.find("LeftToe_end");
  REQUIRE(toe_end >= 0);
  CHECK(m.joints[toe_end].end_site);
  CHECK(m.joints[toe_end].parent == m.find("LeftToe"));
  // First and last values of the file.
  CHECK(m.values(0, 0) == 5.23);
  CHECK(m.values(0, 2) == -33.8986);
  CHECK(m.values(m.frame_count() - 1, m.channel_count() - 1) == 19.734);
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "CMU clip: forward kinematics equals MuJoCo's kinematics of the same hierarchy",
                 "[bvh][regression]") {
  const BvhMotion& m = cmu();
  const BvhUnits units = BvhUnits::cmu();
  const Eigen::Matrix3d R_WF = mocap_io::file_to_world(units.up);
  sim::Model model = biodyn::testing::load_inline(mjcf_from_bvh(m));
  REQUIRE(model->nq == m.channel_count());
  sim::Data data(*model);
  double max_position_error = 0, max_rotation_error = 0;
  int frames = 0;
  for (int f = 0; f < m.frame_count(); f += kFkFrameStride, ++frames) {
    set_qpos(m, *model, f, data.get());
    mj_kinematics(model.get(), data.get());
    const mocap_io::BvhPose pose = mocap_io::forward_kinematics(m, f, units);
    for (std::size_t i = 0; i < m.joints.size(); ++i) {
      const int body = model.id(mjOBJ_BODY, body_name(static_cast<int>(i)));
      const Eigen::Map<const Eigen::Vector3d> xpos(data->xpos + 3 * body);
      const Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> xmat(data->xmat +
                                                                                9 * body);
      const Eigen::Vector3d p_W = units.metres_per_unit * (R_WF * xpos);
      max_position_error =
          std::max(max_position_error, (p_W - pose.positions_W.col(static_cast<int>(i))).norm());
      max_rotation_error =
          std::max(max_rotation_error, (R_WF * xmat - pose.rotations_W[i]).cwiseAbs().maxCoeff());
    }
  }
  for (int w = 0; w < mjNWARNING; ++w) CHECK(data->warning[w].number == 0);
  INFO("max FK deviation from MuJoCo over " << frames << " frames: " << max_position_error
                                            << " m, rotation " << max_rotation_error);
  CHECK(frames == 100);
  CHECK(max_position_error < kFkTolerance_m);
  CHECK(max_rotation_error < kRotationTolerance);
}

TEST_CASE("CMU clip: the skeleton stands on the floor and has an adult size", "[bvh][regression]") {
  const BvhMotion& m = cmu();
  std::vector<int> feet;
  for (const char* name :
       {"LeftAnkle", "LeftToe", "LeftToe_end", "RightAnkle", "RightToe", "RightToe_end"}) {
    feet.push_back(m.find(name));
    REQUIRE(feet.back() >= 0);
  }
  double lowest_min = 1e9, lowest_max = -1e9;
  for (int f = 0; f < m.frame_count(); ++f) {
    const mocap_io::BvhPose pose = mocap_io::forward_kinematics(m, f, BvhUnits::cmu());
    double lowest = 1e9;
    for (int j : feet) lowest = std::min(lowest, pose.positions_W(2, j));
    lowest_min = std::min(lowest_min, lowest);
    lowest_max = std::max(lowest_max, lowest);
  }
  INFO("lowest foot point per frame, m: " << lowest_min << " to " << lowest_max);
  CHECK(lowest_min > kLowestFootMin_m);
  CHECK(lowest_max < kLowestFootMax_m);

  // Stature from the leg: hip-knee-ankle length over de Leva's thigh + shank share of stature
  // (de Leva 1996 Table 1: HJC-KJC and KJC-lateral malleolus). The head end site is no vertex
  // (CMU's head bone is short), so the skeleton's own top is not used.
  const auto length_m = [&](const char* joint) {
    return BvhUnits::cmu().metres_per_unit * m.joints[m.find(joint)].offset.norm();
  };
  const models::Tables& t = models::default_tables();
  const double leg_share = (t.de_leva_row("thigh", models::Sex::kMale).length_mm +
                            t.de_leva_row("shank", models::Sex::kMale).length_mm) /
                           (1000 * models::de_leva_reference_height_m(models::Sex::kMale));
  for (const auto& [knee, ankle] :
       {std::pair{"LeftKnee", "LeftAnkle"}, {"RightKnee", "RightAnkle"}}) {
    const double stature_m = (length_m(knee) + length_m(ankle)) / leg_share;
    INFO(knee << ": stature from the leg " << stature_m << " m");
    CHECK(stature_m > kStatureMin_m);
    CHECK(stature_m < kStatureMax_m);
  }
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest, "CMU clip: format_bvh and write_bvh round trips",
                 "[bvh][regression]") {
  const BvhMotion& m = cmu();
  const auto check_same = [&](const BvhMotion& back) {
    REQUIRE(back.joints.size() == m.joints.size());
    for (std::size_t i = 0; i < m.joints.size(); ++i) {
      INFO(m.joints[i].name);
      CHECK(back.joints[i].name == m.joints[i].name);
      CHECK(back.joints[i].parent == m.joints[i].parent);
      CHECK(back.joints[i].end_site == m.joints[i].end_site);
      CHECK(back.joints[i].channels == m.joints[i].channels);
      CHECK(back.joints[i].first_channel == m.joints[i].first_channel);
      CHECK((back.joints[i].offset - m.joints[i].offset).cwiseAbs().maxCoeff() <
            kRoundTripTolerance);
    }
    REQUIRE(back.frame_count() == m.frame_count());
    REQUIRE(back.channel_count() == m.channel_count());
    CHECK(std::abs(back.frame_time_s - m.frame_time_s) < kFrameTimeTolerance_s);
    const double value_error = (back.values - m.values).cwiseAbs().maxCoeff();
    double fk_error = 0;
    for (int f = 0; f < m.frame_count(); f += kFkFrameStride) {
      const auto a = mocap_io::forward_kinematics(m, f, BvhUnits::cmu());
      const auto b = mocap_io::forward_kinematics(back, f, BvhUnits::cmu());
      fk_error = std::max(fk_error, (a.positions_W - b.positions_W).cwiseAbs().maxCoeff());
    }
    INFO("round trip: values " << value_error << ", FK " << fk_error << " m");
    CHECK(value_error < kRoundTripTolerance);
    CHECK(fk_error < kRoundTripFkTolerance_m);
  };
  SECTION("format_bvh -> parse_bvh") {
    check_same(mocap_io::parse_bvh(mocap_io::format_bvh(m), "<formatted>"));
  }
  SECTION("write_bvh -> read_bvh") {
    const std::string path = biodyn::testing::binary_dir() + "/bvh_cmu_round_trip.bvh";
    mocap_io::write_bvh(path, m);
    check_same(mocap_io::read_bvh(path));
    std::FILE* temp = std::fopen((path + biodyn::sim::kPartialFileSuffix).c_str(), "r");
    CHECK(temp == nullptr);  // renamed into place, nothing left behind
    if (temp) std::fclose(temp);
    std::remove(path.c_str());
  }
}
