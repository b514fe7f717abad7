// Pose sequences and placing the character in a pose (poses.h).
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "biodyn/controllers/poses.h"
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
                 "place_in_pose: feet flat at rest height, CoM over the support point, at rest",
                 "[controllers]") {
  sim::Simulation sim(testing::generated_character());
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
      support_x += d.xpos[3 * foot[s]] + sole.x_min +
                   balance.support_point_fraction * (sole.x_max - sole.x_min);
    }
    CHECK(d.subtree_com[0] == Approx(support_x / 2).margin(1e-3));
    for (int i = 0; i < m.nv; ++i) CHECK(d.qvel[i] == 0);
  }
}
