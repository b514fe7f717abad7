// Rig calibration (calibration.h) from a wand seen through the true cameras with pixel noise,
// no rendering: every camera's centre, lens and the lab frame recovered; bad inputs named.
#include "biodyn/capture/calibration.h"

#include <catch2/catch.hpp>

#include "biodyn/capture/synthetic.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/random.h"

namespace biodyn::capture {
namespace {

// The wand wave seen by `truth`'s cameras with `noise_px` of Gaussian pixel noise.
WandObservations observe(const Rig& truth, const std::vector<std::array<Eigen::Vector3d, 3>>& wave,
                         double noise_px, std::uint64_t seed) {
  WandObservations w;
  w.abc_px.assign(truth.size(), std::vector<std::array<Eigen::Vector2d, 3>>(wave.size()));
  w.seen.assign(truth.size(), std::vector<char>(wave.size(), 0));
  for (int c = 0; c < truth.size(); ++c) {
    for (std::size_t f = 0; f < wave.size(); ++f) {
      sim::RandomStream r(sim::stream_key(seed, {c, static_cast<int>(f)}));
      bool all = true;
      for (int m = 0; m < 3; ++m) {
        bool in_front = false;
        const Eigen::Vector2d uv = truth.cameras[c].project(wave[f][m], &in_front);
        all = all && in_front && truth.cameras[c].in_image(uv);
        w.abc_px[c][f][m] = uv + noise_px * Eigen::Vector2d(r.normal(), r.normal());
      }
      w.seen[c][f] = all ? 1 : 0;
    }
  }
  return w;
}

// The L-frame's markers as `rig` (calibrated, not yet aligned) triangulates them from the true
// cameras' pixels.
std::vector<std::vector<Point3>> lframe_points(const Rig& truth, const Rig& rig, const LFrame& l) {
  std::vector<Point3> points;
  for (const Eigen::Vector3d& p : l.points_W()) {
    std::vector<std::pair<int, Eigen::Vector2d>> views;
    for (int c = 0; c < truth.size(); ++c)
      views.emplace_back(c, rig.cameras[c].undistort(truth.cameras[c].project(p)));
    Point3 q;
    double residual = 0;
    REQUIRE(triangulate_normalised(rig, views, &q.p_W, &residual));
    points.push_back(q);
  }
  return {points};
}

}  // namespace

TEST_CASE("Wand: its markers are told apart in an image, anything else is refused") {
  const Wand wand;
  const auto blobs = [](std::vector<Eigen::Vector2d> at) {
    std::vector<Blob> b;
    for (const auto& p : at) b.push_back(Blob{p, 20, 1, 255});
    return b;
  };
  std::array<Eigen::Vector2d, 3> abc;
  // A at (100, 100), C at (300, 100), B at 0.32 of the way: in any order.
  REQUIRE(identify_wand(blobs({{300, 100}, {164, 100}, {100, 100}}), wand, &abc));
  CHECK(abc[0].x() == 100);
  CHECK(abc[1].x() == 164);
  CHECK(abc[2].x() == 300);
  REQUIRE(identify_wand(blobs({{236, 100}, {300, 100}, {100, 100}}), wand, &abc));
  CHECK(abc[0].x() == 300);  // B near the right end: A is the right end
  CHECK_FALSE(identify_wand(blobs({{100, 100}, {164, 130}, {300, 100}}), wand, &abc));  // bent
  CHECK_FALSE(identify_wand(blobs({{100, 100}, {200, 100}, {300, 100}}), wand, &abc));  // centred
  CHECK_FALSE(identify_wand(blobs({{100, 100}, {300, 100}}), wand, &abc));
  CHECK_FALSE(identify_wand(blobs({{100, 100}, {164, 100}, {300, 100}, {400, 400}}), wand, &abc));
  Wand centred;
  centred.ab_m = 0.24;
  CHECK_THROWS_WITH(centred.validate(), Catch::Contains("off-centre"));
}

TEST_CASE(
    "Calibration: a wand wave and an L-frame give every camera's centre, lens and the lab frame") {
  for (const auto& [cameras, seed] : {std::pair<int, std::uint64_t>{4, 1}, {8, 2}, {12, 3}}) {
    SyntheticRigSpec spec;
    spec.cameras = cameras;
    spec.jitter_seed = seed;
    const Rig truth = make_synthetic_rig(spec);
    const Wand wand;
    const auto wave = wand_wave(wand, spec, 1200, 20, seed);  // a minute of waving
    const WandObservations seen = observe(truth, wave, 0.1, seed);
    CalibrationReport report;
    Rig rig = calibrate_from_wand(nominal_rig(truth, 0.03, seed), seen, wand, {}, &report);
    double fit_m = 0;
    align_to_lframe(lframe_points(truth, rig, LFrame{}), LFrame{}, &rig, &fit_m);
    double worst_centre = 0, worst_focal = 0, worst_rms = 0;
    for (int c = 0; c < truth.size(); ++c) {
      worst_centre = std::max(worst_centre, (rig.cameras[c].p_WC - truth.cameras[c].p_WC).norm());
      worst_focal =
          std::max(worst_focal, std::abs(rig.cameras[c].K.fx_px / truth.cameras[c].K.fx_px - 1));
      worst_rms = std::max(worst_rms, report.reprojection_rms_px[c]);
    }
    INFO(cameras << " cameras: centres within " << 1000 * worst_centre << " mm, focal lengths "
                 << 100 * worst_focal << "%, reprojection " << worst_rms << " px, wand "
                 << report.wand_ac_rms_mm << " mm, L-frame " << 1000 * fit_m << " mm");
    // Measured (0.1 px of noise, 1200 frames): 1.03, 0.74 and 0.64 mm for 4, 8 and 12 cameras;
    // 300 frames gave 3.3, 1.0, 1.7 mm (a focal length off by 0.1% moves a camera 3 m away by
    // 3 mm: the wave's spread in depth decides).
    CHECK(worst_centre < 0.002);
    CHECK(worst_focal < 0.002);
    CHECK(worst_rms < 0.3);
    CHECK(report.wand_ac_rms_mm < 0.5);
  }
}

TEST_CASE("Calibration: a camera that never saw the wand is named") {
  SyntheticRigSpec spec;
  spec.cameras = 4;
  const Rig truth = make_synthetic_rig(spec);
  const Wand wand;
  WandObservations seen = observe(truth, wand_wave(wand, spec, 200, 20, 9), 0.1, 9);
  seen.seen[2].assign(seen.frames(), 0);
  CalibrationReport report;
  CHECK_THROWS_WITH(calibrate_from_wand(nominal_rig(truth, 0.03, 9), seen, wand, {}, &report),
                    Catch::Contains("cam03") && Catch::Contains("too few"));
  Rig rig = truth;
  double fit_m = 0;
  CHECK_THROWS_WITH(align_to_lframe({{}}, LFrame{}, &rig, &fit_m), Catch::Contains("L-frame"));
}

}  // namespace biodyn::capture
