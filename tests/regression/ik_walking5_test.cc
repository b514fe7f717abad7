// Regression (issue 24): marker IK of OpenSim's walking5.c3d scaled and placed from the capture
// itself, checked against what the capture says independently of the fit: the pelvis heading
// against the anterior superior iliac spines' axis, and the model's hip centres against the
// capture software's hip joint centres (LHJC, RHJC). On 777bb0d the heading was off by -17 deg
// (the right pelvis markers started on the left and the placement moved every marker, the joint
// centres too, so nothing anchored the pelvis) and the hip centres by ~5 cm.

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "biodyn/mocap_io/c3d.h"
#include "biodyn/mocap_io/marker_ik.h"
#include "biodyn/mocap_io/scaling.h"
#include "biodyn/models/marker_set.h"
#include "biodyn/models/mjcf.h"
#include "biodyn/models/rig.h"
#include "biodyn/sim/model.h"
#include "biodyn/sim/units.h"
#include "test_support.h"

using namespace biodyn;

namespace {

const std::string kWalking5 =
    biodyn::testing::source_dir() + "/../shared/data/mocap/c3d/opensim_walking5.c3d";

// The bounds.
constexpr double kHeadingBound_deg = 2.0;
constexpr double kHipCentreBound_m = 0.01;
constexpr double kFrameRmsBound_m = 0.02;
constexpr double kFrameMaxBound_m = 0.04;

/// Heading (deg, about z from +x) of a horizontal direction.
double heading_deg(const Eigen::Vector3d& v) { return kDegPerRad * std::atan2(v.y(), v.x()); }

double wrapped_deg(double a) { return std::remainder(a, 360.0); }

struct Walking5Ik {
  mocap_io::MarkerData markers;
  models::CharacterSpec spec;
  sim::Model model;
  mocap_io::MarkerIkResult ik;
};

/// The CLI's pipeline without a separate static trial: scale and place from the trial itself.
Walking5Ik solve_walking5(mocap_io::MarkerData markers) {
  const models::MarkerSet set = models::builtin_marker_set("opensim_walking5");
  const mocap_io::ScaleResult scaled =
      mocap_io::scale_from_static(models::CharacterSpec{}, false, set, markers);
  sim::Model model = sim::Model::from_string(
      models::to_mjcf(models::generate_character(scaled.spec)), "walking5 subject");
  std::vector<double> weights;
  for (const std::string& l : markers.labels) weights.push_back(set.weight(l));
  mocap_io::MarkerIkResult ik = mocap_io::solve_marker_ik(*model, markers, weights);
  return Walking5Ik{std::move(markers), scaled.spec, std::move(model), std::move(ik)};
}

const Walking5Ik& walking5_ik() {
  static const Walking5Ik run = solve_walking5(mocap_io::read_c3d(kWalking5).markers);
  return run;
}

/// Pelvis heading minus the ASIS axis's forward (deg) over the solved frames: mean and worst.
struct HeadingError {
  double mean_deg = 0.0, worst_deg = 0.0;
  int frames = 0;
};

HeadingError pelvis_heading_error(const Walking5Ik& run) {
  const mjModel& m = *run.model;
  const models::Rig rig(m);
  sim::Data d(m);
  const int lasi = run.markers.find("LASI"), rasi = run.markers.find("RASI");
  HeadingError out;
  for (int f = 0; f < run.markers.frame_count(); ++f) {
    if (!run.ik.frames[static_cast<size_t>(f)].solved) continue;
    if (!run.markers.visible(f, lasi) || !run.markers.visible(f, rasi)) continue;
    for (int k = 0; k < m.nq; ++k) d->qpos[k] = run.ik.qpos(f, k);
    mj_kinematics(&m, d.get());
    // Forward is the left-pointing ASIS axis turned by -90 deg; the pelvis's forward is its x.
    const Eigen::Vector3d left = run.markers.position(f, lasi) - run.markers.position(f, rasi);
    const Eigen::Vector3d x_pelvis(d->xmat[9 * rig.pelvis()], d->xmat[9 * rig.pelvis() + 3],
                                   d->xmat[9 * rig.pelvis() + 6]);
    const double diff = wrapped_deg(heading_deg(x_pelvis) - (heading_deg(left) - 90.0));
    out.mean_deg += diff;
    out.worst_deg = std::max(out.worst_deg, std::abs(diff));
    ++out.frames;
  }
  out.mean_deg /= std::max(out.frames, 1);
  return out;
}

}  // namespace

TEST_CASE("walking5 IK: pelvis heading follows the ASIS axis, hip centres the capture's HJC",
          "[mocap][ik][slow]") {
  const Walking5Ik& run = walking5_ik();
  const mjModel& m = *run.model;
  const models::Rig rig(m);
  sim::Data d(m);
  const int lhjc = run.markers.find("LHJC"), rhjc = run.markers.find("RHJC");
  const int thigh_l = rig.body("thigh_l"), thigh_r = rig.body("thigh_r");
  double hip_sq[2] = {0, 0}, hip_max[2] = {0, 0};
  int hip_frames = 0;
  for (int f = 0; f < run.markers.frame_count(); ++f) {
    if (!run.ik.frames[static_cast<size_t>(f)].solved) continue;
    for (int k = 0; k < m.nq; ++k) d->qpos[k] = run.ik.qpos(f, k);
    mj_kinematics(&m, d.get());
    if (run.markers.visible(f, lhjc) && run.markers.visible(f, rhjc)) {
      const int body[2] = {thigh_l, thigh_r}, col[2] = {lhjc, rhjc};
      for (int s = 0; s < 2; ++s) {
        const double e =
            (Eigen::Vector3d(d->xpos + 3 * body[s]) - run.markers.position(f, col[s])).norm();
        hip_sq[s] += e * e;
        hip_max[s] = std::max(hip_max[s], e);
      }
      ++hip_frames;
    }
  }
  const HeadingError heading = pelvis_heading_error(run);
  REQUIRE(heading.frames > 400);
  REQUIRE(hip_frames > 400);
  INFO("pelvis heading - ASIS axis: mean " << heading.mean_deg << " deg, worst frame "
                                           << heading.worst_deg << " deg over " << heading.frames
                                           << " frames");
  INFO("hip centre - HJC: RMS left " << 1000 * std::sqrt(hip_sq[0] / hip_frames) << " mm, right "
                                     << 1000 * std::sqrt(hip_sq[1] / hip_frames)
                                     << " mm; worst frame " << 1000 * hip_max[0] << " / "
                                     << 1000 * hip_max[1] << " mm");
  CHECK(std::abs(heading.mean_deg) < kHeadingBound_deg);
  CHECK(std::sqrt(hip_sq[0] / hip_frames) < kHipCentreBound_m);
  CHECK(std::sqrt(hip_sq[1] / hip_frames) < kHipCentreBound_m);
}

TEST_CASE("walking5 IK: every solved frame fits within 2 cm RMS and 4 cm max",
          "[mocap][ik][slow]") {
  const Walking5Ik& run = walking5_ik();
  int solved = 0;
  double worst_rms = 0.0, worst_max = 0.0;
  for (const mocap_io::MarkerIkFrame& fr : run.ik.frames) {
    if (!fr.solved) continue;
    ++solved;
    worst_rms = std::max(worst_rms, fr.rms_error_m);
    worst_max = std::max(worst_max, fr.max_error_m);
  }
  INFO(solved << " frames solved; worst frame RMS " << 1000 * worst_rms << " mm, largest marker "
              << "error " << 1000 * worst_max << " mm");
  // Frames 415-980 show the pelvis and enough markers (566 on 777bb0d).
  CHECK(solved >= 560);
  CHECK(worst_rms < kFrameRmsBound_m);
  CHECK(worst_max < kFrameMaxBound_m);
  // The estimated stature: walking5's subject, from its leg and trunk measurements.
  CHECK(run.spec.height_m > 1.6);
  CHECK(run.spec.height_m < 2.0);
}

TEST_CASE("walking5 IK: the heading holds for the same walk in any direction of the lab",
          "[mocap][ik][slow]") {
  // Held out: the capture turned about the vertical by seeded random angles (and moved), as
  // if the lab's x axis pointed elsewhere; the fit must not prefer any lab direction.
  std::mt19937 rng(24);
  std::uniform_real_distribution<double> angle(-biodyn::kPi, biodyn::kPi), shift(-3.0, 3.0);
  for (int trial = 0; trial < 2; ++trial) {
    mocap_io::MarkerData markers = mocap_io::read_c3d(kWalking5).markers;
    const double a = angle(rng);
    const Eigen::Matrix3d r = Eigen::AngleAxisd(a, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    const Eigen::Vector3d t(shift(rng), shift(rng), 0.0);
    for (int f = 0; f < markers.frame_count(); ++f) {
      for (int i = 0; i < markers.marker_count(); ++i) {
        if (!markers.visible(f, i)) continue;
        markers.positions_m.row(f).segment<3>(3 * i) = (r * markers.position(f, i) + t).transpose();
      }
    }
    const HeadingError heading = pelvis_heading_error(solve_walking5(std::move(markers)));
    INFO("lab turned by " << kDegPerRad * a << " deg: pelvis heading - ASIS axis mean "
                          << heading.mean_deg << " deg, worst " << heading.worst_deg);
    REQUIRE(heading.frames > 400);
    CHECK(std::abs(heading.mean_deg) < kHeadingBound_deg);
  }
}
