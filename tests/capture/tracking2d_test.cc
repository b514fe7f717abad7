// 2D blob tracks (tracking2d.h) on drawn marker images, and the reconstruction that rebuilds
// last frame's points along them (reconstruct.h) on the character filmed by 4 cameras.
#include "biodyn/capture/tracking2d.h"

#include <catch2/catch.hpp>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <set>

#include "biodyn/capture/evaluation.h"
#include "biodyn/capture/reconstruct.h"
#include "biodyn/capture/synthetic.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/model.h"
#include "biodyn/viewer/headless_gl.h"
#include "filmed_character.h"

namespace biodyn::capture {
namespace {

// A 656 x 491 black image with a bright 4 px disc at each of `centres` (anti-aliased).
cv::Mat draw(const std::vector<Eigen::Vector2d>& centres) {
  cv::Mat image(491, 656, CV_8UC1, cv::Scalar(0));
  for (const Eigen::Vector2d& c : centres)
    cv::circle(image,
               cv::Point(static_cast<int>(std::lround(c.x() * 16)),
                         static_cast<int>(std::lround(c.y() * 16))),
               4 * 16, cv::Scalar(230), cv::FILLED, cv::LINE_AA, 4);
  return image;
}

// The track id of the blob nearest `uv` (within 2 px), or -1.
int track_at(const std::vector<Blob>& blobs, const std::vector<int>& ids,
             const Eigen::Vector2d& uv) {
  for (std::size_t b = 0; b < blobs.size(); ++b)
    if ((blobs[b].uv_px - uv).norm() < 2) return ids[b];
  return -1;
}

// The ids one marker's blob had over `path` (frames where `hidden` says so draw nothing).
std::vector<int> ids_along(const std::vector<Eigen::Vector2d>& path, const Tracking2dParams& p,
                           const std::set<int>& hidden = {}) {
  BlobTracker2d tracker(p);
  BlobDetector detector;
  std::vector<Blob> blobs;
  std::vector<int> ids, seen;
  for (int f = 0; f < static_cast<int>(path.size()); ++f) {
    const bool shown = hidden.count(f) == 0;
    const cv::Mat image =
        draw(shown ? std::vector<Eigen::Vector2d>{path[static_cast<std::size_t>(f)]}
                   : std::vector<Eigen::Vector2d>{});
    detector.detect(image, &blobs);
    tracker.update(blobs, image, &ids);
    if (shown) seen.push_back(track_at(blobs, ids, path[static_cast<std::size_t>(f)]));
  }
  return seen;
}

}  // namespace

TEST_CASE("2D tracks: a fast marker is followed from its second frame, a hidden one coasts") {
  // 18 px a frame (a foot in swing 3 m away), bending: constant velocity alone cannot start
  // the track (its first step is unknown); the optical flow can.
  std::vector<Eigen::Vector2d> fast;
  for (int f = 0; f < 20; ++f) fast.emplace_back(100 + 18.0 * f, 240 + 60 * std::sin(0.15 * f));
  const std::vector<int> with_flow = ids_along(fast, Tracking2dParams{});
  CHECK(std::set<int>(with_flow.begin(), with_flow.end()) == std::set<int>{0});
  Tracking2dParams no_flow;
  no_flow.optical_flow = false;
  const std::vector<int> without = ids_along(fast, no_flow);
  CHECK(std::set<int>(without.begin(), without.end()).size() == without.size());  // one each
  // Hidden for 2 frames, it coasts at its velocity and is found again; for 5, it starts anew.
  std::vector<Eigen::Vector2d> slow;
  for (int f = 0; f < 20; ++f) slow.emplace_back(200 + 3.0 * f, 150 + 2.0 * f);
  const std::vector<int> short_gap = ids_along(slow, Tracking2dParams{}, {8, 9});
  CHECK(std::set<int>(short_gap.begin(), short_gap.end()) == std::set<int>{0});
  const std::vector<int> long_gap = ids_along(slow, Tracking2dParams{}, {8, 9, 10, 11, 12});
  CHECK(std::set<int>(long_gap.begin(), long_gap.end()) == std::set<int>{0, 1});
}

TEST_CASE("2D tracks: two markers passing each other keep their own tracks") {
  BlobTracker2d tracker;
  BlobDetector detector;
  std::vector<Blob> blobs;
  std::vector<int> ids;
  std::set<int> a_ids, b_ids;
  for (int f = 0; f < 30; ++f) {
    const Eigen::Vector2d a(200 + 6.0 * f, 240), b(374 - 6.0 * f, 252);  // pass 12 px apart
    const cv::Mat image = draw({a, b});
    detector.detect(image, &blobs);
    tracker.update(blobs, image, &ids);
    a_ids.insert(track_at(blobs, ids, a));
    b_ids.insert(track_at(blobs, ids, b));
  }
  CHECK(a_ids == std::set<int>{0});
  CHECK(b_ids == std::set<int>{1});
  Tracking2dParams bad;
  bad.flow_window_px = 4;
  CHECK_THROWS_AS(BlobTracker2d(bad), sim::InvalidArgument);
  bad = Tracking2dParams{};
  bad.gate_px = 0;
  CHECK_THROWS_AS(BlobTracker2d(bad), sim::InvalidArgument);
}

TEST_CASE("Reconstruction along 2D tracks: 4 cameras, fewer ghosts, the same points", "[slow]") {
  // A 2 s arm-and-leg swing of the character filmed by 4 cameras (rig seed 8), reconstructed
  // frame by frame on its own and along the 2D tracks.
  viewer::HeadlessGl gl;
  SyntheticRigSpec spec;
  spec.cameras = 4;
  spec.jitter_seed = 8;
  const Rig rig = make_synthetic_rig(spec);
  testing::FilmedCharacter filmed;
  mjModel& m = *filmed.model.get();
  mjData* d = mj_makeData(&m);
  const std::vector<int>& sites = filmed.sites;
  SyntheticCameras cameras(m, rig, sites, ImageFormation{});
  Reconstructor plain(rig), tracked(rig);
  std::vector<BlobDetector> detectors(rig.size());
  std::vector<BlobTracker2d> trackers(rig.size());
  std::vector<cv::Mat> images;
  std::vector<std::vector<MarkerView>> views;
  std::vector<std::vector<Blob>> blobs(rig.size());
  std::vector<std::vector<int>> tracks(rig.size());
  std::vector<Point3> points;
  CaptureScore plain_score, tracked_score;
  long continued = 0, total = 0;
  for (int f = 0; f < 200; ++f) {
    const double t = f / spec.fps;
    mju_copy(d->qpos, m.qpos0, m.nq);
    d->qpos[2] = 1.0;
    d->qpos[3] = std::cos(0.3 * t);  // turning slowly about z
    d->qpos[6] = std::sin(0.3 * t);
    for (int j = 1; j < m.njnt; ++j) {
      if (m.jnt_type[j] == mjJNT_HINGE)
        d->qpos[m.jnt_qposadr[j]] = 0.4 * std::sin(2 * M_PI * 0.9 * t + 0.7 * j);
    }
    mj_kinematics(&m, d);
    cameras.film(m, *d, f, &images, &views);
    for (int c = 0; c < rig.size(); ++c) {
      detectors[c].detect(images[c], &blobs[c]);
      trackers[c].update(blobs[c], images[c], &tracks[c]);
    }
    std::vector<Eigen::Vector3d> truth;
    std::vector<int> seen(sites.size(), 0);
    for (std::size_t k = 0; k < sites.size(); ++k) {
      truth.emplace_back(d->site_xpos + 3 * sites[k]);
      for (int c = 0; c < rig.size(); ++c) seen[k] += views[c][k].visible ? 1 : 0;
    }
    plain.reconstruct(blobs, &points);
    score_points(points, truth, seen, &plain_score);
    tracked.reconstruct(blobs, &points, &tracks);
    score_points(points, truth, seen, &tracked_score);
    continued += tracked.continued_points();
    total += static_cast<long>(points.size());
  }
  mj_deleteData(d);
  INFO("found " << plain_score.point_recall() << " / " << tracked_score.point_recall()
                << ", ghosts " << plain_score.ghost_points << " / " << tracked_score.ghost_points
                << ", RMS " << 1000 * plain_score.rms_m() << " / " << 1000 * tracked_score.rms_m()
                << " mm, continued " << continued << " of " << total);
  CHECK(static_cast<double>(continued) >= 0.95 * static_cast<double>(total));
  CHECK(tracked_score.ghost_points <= plain_score.ghost_points);
  CHECK(tracked_score.point_recall() >= plain_score.point_recall() - 0.002);
  CHECK(tracked_score.rms_m() <= 0.001);
  // Track ids that do not match the blob lists are refused.
  tracks.front().push_back(99);
  CHECK_THROWS_AS(tracked.reconstruct(blobs, &points, &tracks), sim::InvalidArgument);
}

}  // namespace biodyn::capture
