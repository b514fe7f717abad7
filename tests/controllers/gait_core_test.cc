// The walkers' gait core (gait_core.h): the IK triangle of paper §4.2 and the base-polygon
// step of §4.3.
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "biodyn/controllers/gait_core.h"
#include "biodyn/models/mjcf.h"
#include "biodyn/models/rig.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/queries.h"
#include "biodyn/sim/units.h"
#include "character.h"
#include "test_support.h"

using namespace biodyn;

TEST_CASE("The IK triangle puts the ankle on a reachable target", "[gait]") {
  const double l1 = 0.44, l2 = 0.45;
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> forward(-0.4, 0.5), down(-0.85, -0.6);
  for (int trial = 0; trial < 50; ++trial) {
    const Eigen::Vector3d r(forward(rng), 0.0, down(rng));
    if (r.norm() > std::sqrt(l1 * l1 + l2 * l2 + 2 * l1 * l2 * std::cos(5 * kRadPerDeg))) continue;
    const controllers::LegTriangle leg =
        controllers::solve_leg_triangle(l1, l2, r, 1.0, 5 * kRadPerDeg);
    INFO("target " << r.transpose());
    REQUIRE(leg.reachable);
    CHECK(leg.knee_flexion_rad >= 5 * kRadPerDeg - 1e-12);
    // Forward kinematics in the sagittal plane: thigh at hip flexion, shank knee-flexed back.
    const double a = leg.hip_flexion_rad, b = leg.hip_flexion_rad - leg.knee_flexion_rad;
    const Eigen::Vector3d ankle(l1 * std::sin(a) + l2 * std::sin(b), 0.0,
                                -l1 * std::cos(a) - l2 * std::cos(b));
    CHECK((ankle - r).norm() < 1e-9);
  }
}

TEST_CASE("The IK triangle gives the closest reachable pose for a target out of reach", "[gait]") {
  const double l1 = 0.44, l2 = 0.45;
  const Eigen::Vector3d far(0.9, 0.0, -0.7);  // 1.14 m away, the leg is 0.89 m
  const controllers::LegTriangle leg =
      controllers::solve_leg_triangle(l1, l2, far, 1.0, 5 * kRadPerDeg);
  CHECK_FALSE(leg.reachable);
  CHECK(leg.knee_flexion_rad == Approx(5 * kRadPerDeg));
  const double a = leg.hip_flexion_rad, b = leg.hip_flexion_rad - leg.knee_flexion_rad;
  const Eigen::Vector3d ankle(l1 * std::sin(a) + l2 * std::sin(b), 0.0,
                              -l1 * std::cos(a) - l2 * std::cos(b));
  // Pointing at the target, as long as the leg can be.
  CHECK(ankle.normalized().dot(far.normalized()) == Approx(1.0).epsilon(1e-9));
  CHECK(ankle.norm() ==
        Approx(std::sqrt(l1 * l1 + l2 * l2 + 2 * l1 * l2 * std::cos(5 * kRadPerDeg))));
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

TEST_CASE("The leg IK triangle puts the ankle where asked, or points the straight leg at it",
          "[gait][stones]") {
  const double l1 = 0.44, l2 = 0.45;
  // Forward kinematics of (thigh pitch, knee): the thigh hangs from the hip rotated forward by
  // the pitch; the shank bends back from the thigh by the knee angle.
  const auto ankle = [&](const controllers::LegTriangle& ik) {
    const double a = ik.hip_flexion_rad, b = ik.hip_flexion_rad - ik.knee_flexion_rad;
    return std::make_pair(l1 * std::sin(a) + l2 * std::sin(b),
                          -l1 * std::cos(a) - l2 * std::cos(b));
  };
  for (const auto& [dx, dz] : {std::make_pair(0.3, -0.75), std::make_pair(-0.25, -0.7),
                               std::make_pair(0.0, -0.5), std::make_pair(0.45, -0.6)}) {
    INFO("target " << dx << ", " << dz);
    const controllers::LegTriangle ik =
        controllers::solve_leg_triangle(l1, l2, {dx, 0, dz}, 1.0, 0.0, 2.0);
    CHECK(ik.reachable);
    CHECK(ik.knee_flexion_rad > 0);  // the knee bends backwards only
    const auto [x, z] = ankle(ik);
    CHECK(x == Approx(dx).margin(1e-9));
    CHECK(z == Approx(dz).margin(1e-9));
  }
  // Out of reach: the straight leg along the hip-target line (the closest reachable state).
  const controllers::LegTriangle far =
      controllers::solve_leg_triangle(l1, l2, {0.6, 0, -0.8}, 1.0, 0.0, 2.0);
  CHECK_FALSE(far.reachable);
  CHECK(far.knee_flexion_rad == 0.0);
  CHECK(far.hip_flexion_rad == Approx(std::atan2(0.6, 0.8)));
  // Too close: the most flexed knee allowed.
  const controllers::LegTriangle near =
      controllers::solve_leg_triangle(l1, l2, {0.0, 0, -0.1}, 1.0, 0.0, 2.0);
  CHECK_FALSE(near.reachable);
  CHECK(near.knee_flexion_rad == Approx(2.0));
}
