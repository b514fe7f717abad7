#pragma once
/// 2D tracking of one camera's blobs from frame to frame (the thesis's 2D stage: prediction and
/// matching, optical flow where it helps). A track is predicted at constant velocity; a track
/// one frame old has no velocity yet, and a marker's image moves up to ~20 px a frame (a foot in
/// swing 3 m away), so it is carried by pyramidal Lucas–Kanade flow on the images instead. Blobs
/// are matched to predictions at minimum total distance within a gate that grows with the
/// track's step; a track whose blob is missing (hidden, merged) coasts a few frames. The
/// reconstruction prefers the 3D points that continue last frame's along the tracks.

#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <vector>

#include "biodyn/capture/blobs.h"

namespace biodyn::capture {

struct Tracking2dParams {
  double gate_px = 3.0;        ///< px: a blob this close to a track's prediction may continue it
  double gate_per_step = 0.5;  ///< the gate grows by this share of the track's last step
  int max_coast_frames = 3;    ///< frames a track lives on its prediction without a blob
  /// Pyramidal Lucas–Kanade for tracks with no velocity yet (OpenCV's calcOpticalFlowPyrLK);
  /// false: such a track is predicted where it was
  bool optical_flow = true;
  int flow_window_px = 15;  ///< the flow's window side, px (odd)
  int flow_levels = 3;      ///< pyramid levels above the image (each halves it)
  void validate() const;    ///< throws sim::InvalidArgument naming the field
};

struct Track2d {
  int id = 0;                                       ///< unique in the camera, from 0
  Eigen::Vector2d uv_px = Eigen::Vector2d::Zero();  ///< last blob seen (a coasting track keeps it)
  Eigen::Vector2d velocity_px = Eigen::Vector2d::Zero();  ///< px per frame, last step
  int age = 0;                                            ///< frames the track has had a blob
  int missed = 0;                                         ///< frames since its last blob
};

/// One camera's blob tracks. Keeps the last image (for the flow) and its scratch between frames.
class BlobTracker2d {
 public:
  /// Throws sim::InvalidArgument for bad params.
  explicit BlobTracker2d(const Tracking2dParams& params = {});
  /// Continues the tracks with `blobs`, found in `image` (8-bit grey: the camera's next frame).
  /// `track_of_blob` gets each blob's track id, in the blobs' order (a new blob starts a track).
  /// An empty image (the camera had no frame) ages every track by a missed frame.
  void update(const std::vector<Blob>& blobs, const cv::Mat& image,
              std::vector<int>* track_of_blob);
  const std::vector<Track2d>& tracks() const { return tracks_; }

 private:
  void predict(const cv::Mat& image);

  Tracking2dParams params_;
  std::vector<Track2d> tracks_;
  std::vector<Eigen::Vector2d> predicted_;
  cv::Mat previous_;
  std::vector<cv::Point2f> flow_from_, flow_to_;
  std::vector<int> flow_track_;
  std::vector<unsigned char> flow_found_;
  std::vector<float> flow_error_;
  Eigen::MatrixXd cost_;
  int next_id_ = 0;
};

}  // namespace biodyn::capture
