// Capture results against ground truth (evaluation.h).
#include "biodyn/capture/evaluation.h"

#include <algorithm>
#include <cmath>
#include <tuple>

namespace biodyn::capture {

double CaptureScore::rms_m() const {
  return found_points ? std::sqrt(sum2_m2 / static_cast<double>(found_points)) : 0.0;
}

void score_detection(const std::vector<Blob>& blobs, const std::vector<MarkerView>& views,
                     CaptureScore* score) {
  std::vector<char> used(blobs.size(), 0);
  for (const MarkerView& v : views) {
    if (!v.visible) continue;
    ++score->visible_views;
    int best = -1;
    double best_px = kDetectionGate_px;
    for (std::size_t b = 0; b < blobs.size(); ++b) {
      const double e = (blobs[b].uv_px - v.uv_px).norm();
      if (e < best_px) {
        best_px = e;
        best = static_cast<int>(b);
      }
    }
    score->whole_views += v.whole ? 1 : 0;
    if (best >= 0) {
      ++score->detected_views;
      score->detected_whole_views += v.whole ? 1 : 0;
      used[static_cast<std::size_t>(best)] = 1;
    }
  }
  score->extra_blobs += std::count(used.begin(), used.end(), 0);
}

void score_points(const std::vector<Point3>& points, const std::vector<Eigen::Vector3d>& truth_W,
                  const std::vector<int>& seen_by, CaptureScore* score) {
  // Every (distance, marker, point) pair within the gate, nearest first: a greedy one-to-one
  // assignment that does not depend on the order of the markers.
  std::vector<std::tuple<double, int, int>> pairs;
  for (int k = 0; k < static_cast<int>(truth_W.size()); ++k) {
    for (int p = 0; p < static_cast<int>(points.size()); ++p) {
      const double e = (points[p].p_W - truth_W[k]).norm();
      if (e < kPointGate_m) pairs.emplace_back(e, k, p);
    }
  }
  std::sort(pairs.begin(), pairs.end());
  std::vector<char> marker_done(truth_W.size(), 0), point_done(points.size(), 0);
  for (const auto& [e, k, p] : pairs) {
    if (marker_done[k] || point_done[p]) continue;
    marker_done[k] = point_done[p] = 1;
    if (seen_by[k] < 2) continue;  // found, though the truth counts it as not reconstructable
    ++score->found_points;
    score->sum2_m2 += e * e;
    score->worst_m = std::max(score->worst_m, e);
  }
  for (int k = 0; k < static_cast<int>(truth_W.size()); ++k)
    score->truth_points += seen_by[k] >= 2 ? 1 : 0;
  score->ghost_points += std::count(point_done.begin(), point_done.end(), 0);
  ++score->frames;
}

}  // namespace biodyn::capture
