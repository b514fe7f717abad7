// Swing-twist limits of the ball joints (joint_limits.h).
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "biodyn/controllers/controller_params.h"
#include "biodyn/controllers/joint_groups.h"
#include "biodyn/controllers/joint_limits.h"
#include "biodyn/models/mjcf.h"
#include "biodyn/models/rig.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/queries.h"
#include "biodyn/sim/units.h"
#include "character.h"
#include "test_support.h"

using namespace biodyn;
using models::JointGroup;

TEST_CASE_METHOD(biodyn::testing::SimulationTest, "Swing-twist split of hip orientations",
                 "[controllers]") {
  const sim::Model model = testing::generated_character();
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
  CHECK(controllers::swing_ratio(lim, {110 * kRadPerDeg, 0, 0}) < 1);
  CHECK(controllers::swing_ratio(lim, {-40 * kRadPerDeg, 0, 0}) > 1);
  CHECK(controllers::swing_ratio(lim, {0, 40 * kRadPerDeg, 0}) < 1);
  CHECK(controllers::swing_ratio(lim, {0, -40 * kRadPerDeg, 0}) > 1);  // adduction limit 30
}
