#pragma once
/// Capture results scored against ground truth (a synthetic capture's): 2D detection recall per
/// camera, and the 3D points' recall, error and ghosts per frame.

#include <Eigen/Core>
#include <vector>

#include "biodyn/capture/blobs.h"
#include "biodyn/capture/reconstruct.h"
#include "biodyn/capture/synthetic.h"

namespace biodyn::capture {

struct CaptureScore {
  long visible_views = 0;         ///< (camera, marker) pairs the truth says are visible
  long detected_views = 0;        ///< of those, with a blob within the detection gate
  long whole_views = 0;           ///< visible views whose whole image is inside the frame
  long detected_whole_views = 0;  ///< of those, detected
  long extra_blobs = 0;           ///< blobs near no visible marker
  long truth_points = 0;          ///< markers seen by at least 2 cameras (reconstructable)
  long found_points = 0;          ///< of those, with a point within the 3D gate
  long ghost_points = 0;          ///< points near no marker
  double sum2_m2 = 0;             ///< m^2, squared errors of the found points
  double worst_m = 0;             ///< m
  long frames = 0;

  double detection_recall() const {
    return visible_views ? static_cast<double>(detected_views) / static_cast<double>(visible_views)
                         : 1;
  }
  /// Recall over the views whose whole marker image is in the frame (MarkerView::whole).
  double whole_detection_recall() const {
    return whole_views
               ? static_cast<double>(detected_whole_views) / static_cast<double>(whole_views)
               : 1;
  }
  double point_recall() const {
    return truth_points ? static_cast<double>(found_points) / static_cast<double>(truth_points) : 1;
  }
  double rms_m() const;  ///< m, RMS error of the found points (0 when none)
};

/// px: a blob this close to a visible marker's true pixel detects it.
inline constexpr double kDetectionGate_px = 1.5;
/// m: a point this close to a marker's true position finds it (one point per marker, nearest
/// first).
inline constexpr double kPointGate_m = 0.01;

/// Adds camera `views`' detection (blobs against the truth's visible markers) to `score`.
void score_detection(const std::vector<Blob>& blobs, const std::vector<MarkerView>& views,
                     CaptureScore* score);
/// Adds one frame's points against the markers' true positions (`truth_W`, one per marker) and
/// how many cameras see each (`seen_by`) to `score`.
void score_points(const std::vector<Point3>& points, const std::vector<Eigen::Vector3d>& truth_W,
                  const std::vector<int>& seen_by, CaptureScore* score);

}  // namespace biodyn::capture
