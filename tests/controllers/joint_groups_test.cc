// Joint-group angle arithmetic (joint_groups.h): anatomical angles, relative quaternions, stops.
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "biodyn/controllers/joint_groups.h"
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

constexpr double kAngleTolerance = 1e-9;  // rad: exact geometry up to rounding

}  // namespace

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "orientation_from_angles matches MuJoCo's kinematics", "[controllers]") {
  const sim::Model model = testing::generated_character();
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
        d.qpos[adr] = q.w(), d.qpos[adr + 1] = q.x(), d.qpos[adr + 2] = q.y(),
        d.qpos[adr + 3] = q.z();
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

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "Anatomical signs: hip flexion moves the knee forward on both sides",
                 "[controllers]") {
  const sim::Model model = testing::generated_character();
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

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "Hinge targets are clamped inside the joint stops, ball joints are left alone",
                 "[controllers]") {
  const sim::Model model = testing::generated_character();
  const std::vector<JointGroup> groups = models::find_joint_groups(*model.get());
  const JointGroup& knee = groups[static_cast<std::size_t>(models::find_group(groups, "knee_l"))];
  REQUIRE(knee.range_rad.size() == 1);
  const double margin = 2 * kRadPerDeg;
  CHECK(controllers::clamp_to_range(knee, Eigen::Vector3d(-0.3, 0, 0), margin)[0] ==
        Approx(knee.range_rad[0][0] + margin));
  CHECK(controllers::clamp_to_range(knee, Eigen::Vector3d(9, 0, 0), margin)[0] ==
        Approx(knee.range_rad[0][1] - margin));
  CHECK(controllers::clamp_to_range(knee, Eigen::Vector3d(1, 0, 0), margin)[0] == 1);
  const JointGroup& hip = groups[static_cast<std::size_t>(models::find_group(groups, "hip_l"))];
  CHECK(controllers::clamp_to_range(hip, Eigen::Vector3d(9, 9, 9), margin) ==
        Eigen::Vector3d(9, 9, 9));
}
