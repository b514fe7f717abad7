// Multi-view reconstruction (reconstruct.h) on the character's 26 markers filmed by synthetic
// cameras: every marker two cameras see is found, within a millimetre, with no ghost.
#include "biodyn/capture/reconstruct.h"

#include <catch2/catch.hpp>

#include "biodyn/capture/evaluation.h"
#include "biodyn/capture/synthetic.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/model.h"
#include "biodyn/sim/random.h"
#include "biodyn/viewer/headless_gl.h"
#include "filmed_character.h"

namespace biodyn::capture {
namespace {

// Films `frames` random poses of the default character (joints within +-0.3 rad of standing,
// turned about z) with `rig` and reconstructs them.
CaptureScore film_and_reconstruct(const Rig& rig, const ImageFormation& formation, int frames,
                                  const ReconstructionParams& params = {}) {
  testing::FilmedCharacter filmed;
  mjModel& m = *filmed.model.get();
  mjData* d = mj_makeData(&m);
  const std::vector<int>& sites = filmed.sites;
  SyntheticCameras cameras(m, rig, sites, formation);
  Reconstructor reconstructor(rig, params);
  std::vector<BlobDetector> detectors(rig.size());
  std::vector<cv::Mat> images;
  std::vector<std::vector<MarkerView>> views;
  std::vector<std::vector<Blob>> blobs(rig.size());
  std::vector<Point3> points;
  CaptureScore score;
  for (int f = 0; f < frames; ++f) {
    sim::RandomStream r(sim::stream_key(11, {f}));
    mju_copy(d->qpos, m.qpos0, m.nq);
    const double yaw = 2 * M_PI * r.uniform();
    d->qpos[2] = 1.0;
    d->qpos[3] = std::cos(yaw / 2);
    d->qpos[6] = std::sin(yaw / 2);
    for (int j = 1; j < m.njnt; ++j) {
      if (m.jnt_type[j] == mjJNT_HINGE) d->qpos[m.jnt_qposadr[j]] = 0.6 * r.uniform() - 0.3;
    }
    mj_kinematics(&m, d);
    cameras.film(m, *d, f, &images, &views);
    for (int c = 0; c < rig.size(); ++c) {
      detectors[c].detect(images[c], &blobs[c]);
      score_detection(blobs[c], views[c], &score);
    }
    reconstructor.reconstruct(blobs, &points);
    std::vector<Eigen::Vector3d> truth;
    std::vector<int> seen(sites.size(), 0);
    for (std::size_t k = 0; k < sites.size(); ++k) {
      truth.emplace_back(d->site_xpos + 3 * sites[k]);
      for (int c = 0; c < rig.size(); ++c) seen[k] += views[c][k].visible ? 1 : 0;
    }
    score_points(points, truth, seen, &score);
  }
  mj_deleteData(d);
  return score;
}

}  // namespace

TEST_CASE("Reconstruction: 8 cameras find every marker two of them see, within a millimetre") {
  viewer::HeadlessGl gl;
  SyntheticRigSpec spec;
  spec.jitter_seed = 5;
  const Rig rig = make_synthetic_rig(spec);
  SECTION("without noise") {
    const CaptureScore s = film_and_reconstruct(rig, ImageFormation{}, 20);
    INFO("detected " << s.detection_recall() << ", found " << s.found_points << " of "
                     << s.truth_points << ", RMS " << 1000 * s.rms_m() << " mm, worst "
                     << 1000 * s.worst_m << " mm, ghosts " << s.ghost_points);
    // Measured: 99.9% of visible views detected (98.9% before touching markers' joint blobs
    // were split; the misses left overlap more than they touch), every point found, RMS
    // 0.25 mm, no ghost.
    CHECK(s.detection_recall() >= 0.99);
    CHECK(s.point_recall() >= 0.99);
    CHECK(s.rms_m() <= 0.001);
    CHECK(s.ghost_points == 0);
  }
  SECTION("with 0.5 px of centroid noise") {
    ImageFormation noisy;
    noisy.noise_px = 0.5;
    ReconstructionParams params;
    params.epipolar_gate_px = 3;
    params.support_gate_px = 3;
    params.max_residual_px = 2.5;
    const CaptureScore s = film_and_reconstruct(rig, noisy, 20, params);
    INFO("found " << s.found_points << " of " << s.truth_points << ", RMS " << 1000 * s.rms_m()
                  << " mm, ghosts " << s.ghost_points);
    // Measured: every point found, RMS 2.29 mm (references.md: 2.3 mm on the thesis's bench).
    CHECK(s.point_recall() >= 0.99);
    CHECK(s.rms_m() <= 0.0025);
  }
}

}  // namespace biodyn::capture
