// Gait events (mocap_io/gait_events.h): heel strikes from the heel's height (interpolated between
// frames) and from a force plate's onset, and the gait cycle resampled to 0-100 %.
#include "biodyn/mocap_io/gait_events.h"

#include <cmath>

#include "biodyn/mocap_io/inverse_dynamics.h"
#include "biodyn/models/rig.h"
#include "biodyn/sim/errors.h"
#include "character.h"
#include "test_support.h"

using namespace biodyn;

namespace {

constexpr double kGaitRate_hz = 100.0;
constexpr int kGaitFrames = 101;  // 0 to 1 s
constexpr double kGaitLift_m = 0.1;

double gait_time(int f) { return f / kGaitRate_hz; }

/// The standing pose with the whole body raised by a trapezoid: 0 until 0.2 s, up to kGaitLift_m at
/// 0.4 s, held to 0.6 s, down to 0 at 0.8 s. Both heels come down through 1 cm above their
/// lowest height at 0.8 - 0.2 * (0.01 / kGaitLift_m) = 0.78 s.
Eigen::MatrixXd lifted_standing(const mjModel& m) {
  Eigen::MatrixXd qpos(kGaitFrames, m.nq);
  for (int f = 0; f < kGaitFrames; ++f) {
    const double t = gait_time(f);
    const double up = std::clamp(std::min((t - 0.2) / 0.2, (0.8 - t) / 0.2), 0.0, 1.0);
    for (int k = 0; k < m.nq; ++k) qpos(f, k) = m.qpos0[k];
    qpos(f, 2) += kGaitLift_m * up;
  }
  return qpos;
}

std::vector<double> gait_times() {
  std::vector<double> t;
  for (int f = 0; f < kGaitFrames; ++f) t.push_back(gait_time(f));
  return t;
}

}  // namespace

TEST_CASE_METHOD(testing::SimulationTest,
                 "Heel strikes: the heel coming down to 1 cm above its lowest, or a plate's onset",
                 "[mocap][gait_events]") {
  const sim::Model model = testing::generated_character();
  const Eigen::MatrixXd qpos = lifted_standing(*model);
  const double expected_s = 0.8 - 0.2 * (mocap_io::kHeelStrikeHeight_m / kGaitLift_m);
  std::vector<mocap_io::HeelStrike> s =
      mocap_io::heel_strikes(*model, qpos, gait_times(), models::kRight, Eigen::MatrixXi());
  REQUIRE(s.size() == 1);
  CHECK(s[0].time_s == Approx(expected_s).margin(1e-9));
  CHECK(s[0].plate == -1);
  CHECK(s[0].kinematic_time_s == s[0].time_s);
  CHECK(std::isnan(s[0].plate_off_time_s));

  // Plate 2 (of 2) loaded by the right foot from 0.76 s to 0.95 s (its first frame unassigned,
  // as at a real onset), plate 1 by the left from the first frame (no onset seen).
  Eigen::MatrixXi feet = Eigen::MatrixXi::Constant(kGaitFrames, 2, mocap_io::kPlateUnloaded);
  feet.block(0, 0, 30, 1).setConstant(models::kLeft);
  feet.block(76, 1, 20, 1).setConstant(models::kRight);
  feet(76, 1) = mocap_io::kPlateUnassigned;
  s = mocap_io::heel_strikes(*model, qpos, gait_times(), models::kRight, feet);
  REQUIRE(s.size() == 1);
  CHECK(s[0].time_s == Approx(0.76));
  CHECK(s[0].plate == 1);
  CHECK(s[0].kinematic_time_s == Approx(expected_s).margin(1e-9));
  CHECK(s[0].plate_off_time_s == Approx(0.95));
  s = mocap_io::heel_strikes(*model, qpos, gait_times(), models::kLeft, feet);
  REQUIRE(s.size() == 1);
  CHECK(s[0].plate == -1);  // plate 1's load starts with the motion: not an onset

  CHECK_THROWS_AS(
      mocap_io::heel_strikes(*model, qpos.topRows(5), gait_times(), models::kRight, feet),
      sim::InvalidArgument);
}

TEST_CASE("Gait cycle: values resampled at 0-100 % by linear interpolation",
          "[mocap][gait_events]") {
  Eigen::MatrixXd values(kGaitFrames, 2);
  for (int f = 0; f < kGaitFrames; ++f) values.row(f) << 3.0 * gait_time(f), 1.0 - gait_time(f);
  const Eigen::MatrixXd c = mocap_io::resample_cycle(gait_times(), values, 0.123, 0.987, 11);
  REQUIRE(c.rows() == 11);
  for (int i = 0; i < 11; ++i) {
    const double t = 0.123 + (0.987 - 0.123) * i / 10.0;
    CHECK(c(i, 0) == Approx(3.0 * t).margin(1e-12));
    CHECK(c(i, 1) == Approx(1.0 - t).margin(1e-12));
  }
  CHECK_THROWS_AS(mocap_io::resample_cycle(gait_times(), values, 0.5, 1.5, 11),
                  sim::InvalidArgument);
  CHECK_THROWS_AS(mocap_io::resample_cycle(gait_times(), values, 0.5, 0.6, 1),
                  sim::InvalidArgument);
}
