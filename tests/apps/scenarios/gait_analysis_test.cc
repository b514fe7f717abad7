// Gait analysis (gait_analysis.h): the normative curves, and a motion made to follow them
// analysed back, with its events from ground forces and from the kinematics alone.
#include <catch2/catch.hpp>
#include <cmath>

#include "biodyn/controllers/joint_groups.h"
#include "biodyn/models/mjcf.h"
#include "biodyn/models/rig.h"
#include "biodyn/models/tables.h"
#include "biodyn/scenarios/gait_analysis.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/model.h"
#include "biodyn/sim/units.h"

using namespace biodyn;

namespace {

constexpr double kCycle_s = 1.0, kRate_hz = 100, kStance = 0.6;
constexpr int kCycles = 8;

/// A walk whose sagittal leg angles are the normative mean curves (the left leg half a cycle
/// behind the right), the pelvis moving forward at 1.2 m/s, and each foot loaded (700 N) for
/// the first 60 % of its cycle.
scenarios::GaitInput normative_walk(const mjModel& m, bool with_forces) {
  Eigen::MatrixXd mean, sd;
  scenarios::normative_gait_curves(&mean, &sd);
  const models::Rig rig(m);
  const int frames = static_cast<int>(kCycles * kCycle_s * kRate_hz) + 1;
  scenarios::GaitInput in;
  in.model = &m;
  in.qpos.resize(frames, m.nq);
  in.foot_force_N.setZero(frames, 2);
  for (int f = 0; f < frames; ++f) {
    const double t = f / kRate_hz;
    in.times_s.push_back(t);
    for (int q = 0; q < m.nq; ++q) in.qpos(f, q) = m.qpos0[q];
    in.qpos(f, 0) = 1.2 * t;
    for (int side = 0; side < 2; ++side) {
      const double phase = std::fmod(t / kCycle_s + (side == models::kLeft ? 0.5 : 0.0), 1.0);
      const double u = phase * (scenarios::kGaitCyclePoints - 1);
      const int i = std::min(static_cast<int>(u), scenarios::kGaitCyclePoints - 2);
      const Eigen::RowVectorXd a = (1 - (u - i)) * mean.row(i) + (u - i) * mean.row(i + 1);
      const models::RigLeg& leg = rig.leg(side);
      const auto& groups = rig.groups();
      const models::JointGroup& hip = groups[static_cast<std::size_t>(leg.hip)];
      const Eigen::Quaterniond q = controllers::orientation_from_angles(
          hip, Eigen::Vector3d(a(scenarios::kGaitHip) * kRadPerDeg, 0, 0));
      const int hq = m.jnt_qposadr[m.dof_jntid[hip.dof_begin]];
      in.qpos(f, hq) = q.w();
      in.qpos(f, hq + 1) = q.x();
      in.qpos(f, hq + 2) = q.y();
      in.qpos(f, hq + 3) = q.z();
      for (const auto& [group, joint] : {std::pair{leg.knee, scenarios::kGaitKnee},
                                         std::pair{leg.ankle, scenarios::kGaitAnkle}}) {
        const models::JointGroup& g = groups[static_cast<std::size_t>(group)];
        in.qpos(f, m.jnt_qposadr[m.dof_jntid[g.dof_begin]]) = a(joint) * kRadPerDeg;
      }
      in.foot_force_N(f, side) = phase < kStance ? 700 : 0;
    }
  }
  if (!with_forces) in.foot_force_N.resize(0, 0);
  return in;
}

}  // namespace

TEST_CASE("The normative gait curves pass through the table's key values and wrap round",
          "[scenarios][gait]") {
  Eigen::MatrixXd mean, sd;
  scenarios::normative_gait_curves(&mean, &sd);
  REQUIRE(mean.rows() == scenarios::kGaitCyclePoints);
  for (const models::NormativeGaitRow& r : models::normative_gait()) {
    const int p = static_cast<int>(std::lround(r.percent));
    CHECK(mean(p, scenarios::kGaitHip) == Approx(r.hip_mean_deg).margin(1e-9));
    CHECK(mean(p, scenarios::kGaitKnee) == Approx(r.knee_mean_deg).margin(1e-9));
    CHECK(sd(p, scenarios::kGaitAnkle) == Approx(r.ankle_sd_deg).margin(1e-9));
  }
  CHECK((mean.row(0) - mean.row(scenarios::kGaitCyclePoints - 1)).norm() < 1e-9);
  // Textbook landmarks (references.md): knee swing peak 60-65 deg at ~70-75 %, hip range ~40-45.
  Eigen::Index peak = 0;
  CHECK(mean.col(scenarios::kGaitKnee).maxCoeff(&peak) == Approx(62).margin(3));
  CHECK(peak >= 68);
  CHECK(peak <= 76);
  CHECK(mean.col(scenarios::kGaitHip).maxCoeff() - mean.col(scenarios::kGaitHip).minCoeff() ==
        Approx(42.5).margin(3));
}

TEST_CASE("A bad normative table is refused naming the file, line and field", "[scenarios][gait]") {
  const std::string header = "percent,hip_mean,hip_sd,knee_mean,knee_sd,ankle_mean,ankle_sd\n";
  CHECK_THROWS_WITH(models::parse_normative_gait(header + "0,30,6,5,5,0,4\n0,1,1,1,1,1,1\n"),
                    Catch::Contains("normative_gait.csv:3: percent"));
  CHECK_THROWS_WITH(models::parse_normative_gait(header + "0,30,-6,5,5,0,4\n"),
                    Catch::Contains("hip_sd: expected a positive SD"));
  CHECK_THROWS_WITH(models::parse_normative_gait(header + "0,30,6,5,5,0,4\n50,1,1,1,1,1,1\n"),
                    Catch::Contains("from 0 to 100"));
}

TEST_CASE("A motion that follows the normative curves is analysed back to them",
          "[scenarios][gait]") {
  const sim::Model model =
      sim::Model::from_string(models::to_mjcf(models::generate_character({})), "character");
  SECTION("events from the ground forces") {
    const scenarios::GaitAnalysis g = scenarios::analyse_gait(normative_walk(*model, true));
    CHECK(g.events == "ground force");
    CHECK(g.cycles >= 2 * (kCycles - 2));
    CHECK(g.cycles_left_out == 0);
    CHECK(g.cadence_steps_per_min == Approx(120).margin(0.5));
    CHECK(g.stance_percent == Approx(100 * kStance).margin(1.5));
    CHECK(g.double_support_percent == Approx(200 * kStance - 100).margin(1.5));
    CHECK(g.speed_m_s == Approx(1.2).margin(0.02));
    for (int j = 0; j < 3; ++j) {
      CHECK(g.correlation[static_cast<std::size_t>(j)] > 0.999);
      CHECK(g.rms_from_normative_deg[static_cast<std::size_t>(j)] < 0.5);
    }
    CHECK(g.knee_swing_peak_deg == Approx(62).margin(1.5));
    CHECK(g.knee_loading_peak_deg == Approx(18.5).margin(1.5));
    // Mid single support is at 30 % here (the other foot leaves at 10 %, lands at 50 %).
    CHECK(g.knee_midstance_deg == Approx(10).margin(1));
    CHECK(g.ankle_plantarflexion_toe_off_deg == Approx(10).margin(1.5));
    CHECK(g.hip_range_deg == Approx(42.5).margin(2));
    CHECK(std::abs(g.trunk_lean_mean_deg) < 0.5);
    for (const scenarios::GaitFigure& f : g.figures) {
      if (f.name.find("correlation") != std::string::npos) CHECK(f.met());
    }
  }
  SECTION("events from the heel and toe relative to the pelvis (no forces)") {
    const scenarios::GaitAnalysis g = scenarios::analyse_gait(normative_walk(*model, false));
    CHECK(g.events.find("Zeni") != std::string::npos);
    CHECK(g.cycles >= 2 * (kCycles - 3));
    CHECK(g.cadence_steps_per_min == Approx(120).margin(1));
    CHECK(g.correlation[scenarios::kGaitHip] > 0.95);
    CHECK(g.correlation[scenarios::kGaitKnee] > 0.9);
    CHECK(g.stance_percent > 50);
    CHECK(g.stance_percent < 75);
  }
}

TEST_CASE("Gait analysis refuses bad sizes and a motion without gait cycles", "[scenarios][gait]") {
  const sim::Model model =
      sim::Model::from_string(models::to_mjcf(models::generate_character({})), "character");
  scenarios::GaitInput in = normative_walk(*model, true);
  scenarios::GaitInput wrong = in;
  wrong.times_s.pop_back();
  CHECK_THROWS_AS(scenarios::analyse_gait(wrong), sim::InvalidArgument);
  wrong = in;
  wrong.foot_force_N = Eigen::MatrixXd::Zero(in.qpos.rows(), 3);
  CHECK_THROWS_AS(scenarios::analyse_gait(wrong), sim::InvalidArgument);
  scenarios::GaitInput standing = in;
  standing.foot_force_N.setConstant(400);
  CHECK_THROWS_WITH(scenarios::analyse_gait(standing), Catch::Contains("no complete gait cycle"));
  scenarios::GaitInput late = in;
  late.from_s = 100;
  CHECK_THROWS_WITH(scenarios::analyse_gait(late), Catch::Contains("no complete gait cycle"));
}
