#pragma once
/// One frame of every camera to 3D points: each image's blobs and their 2D tracks (the cameras
/// in parallel), then the multi-view reconstruction. What `biodyn capture run` drives, frame by
/// frame.

#include <vector>

#include "biodyn/capture/blobs.h"
#include "biodyn/capture/frame_source.h"
#include "biodyn/capture/reconstruct.h"
#include "biodyn/capture/tracking2d.h"

namespace biodyn::capture {

class CapturePipeline {
 public:
  /// Throws sim::InvalidArgument for bad params (blobs.h, reconstruct.h, tracking2d.h).
  /// `tracking` null: no 2D tracks (each frame reconstructed on its own).
  CapturePipeline(const Rig& rig, const BlobParams& blobs,
                  const ReconstructionParams& reconstruction,
                  const Tracking2dParams* tracking = nullptr);
  /// The points of `frames` (one image per camera, in the rig's order) into `points`; each
  /// camera's blobs stay readable through blobs(). Throws sim::InvalidArgument if the frame set
  /// has another number of images than the rig has cameras.
  void process(const FrameSet& frames, std::vector<Point3>* points);
  const std::vector<std::vector<Blob>>& blobs() const { return blobs_; }
  /// Each camera's blobs' 2D track ids (empty lists without tracking).
  const std::vector<std::vector<int>>& tracks() const { return tracks_; }
  /// The last frame's points rebuilt along the 2D tracks (Reconstructor::continued_points).
  int continued_points() const { return reconstructor_.continued_points(); }

 private:
  std::vector<BlobDetector> detectors_;
  std::vector<std::vector<Blob>> blobs_;
  std::vector<BlobTracker2d> trackers_;  ///< one per camera; none without tracking
  std::vector<std::vector<int>> tracks_;
  Reconstructor reconstructor_;
};

/// Threads OpenCV may use for the cameras' images (0: its default, every core).
void set_image_threads(int threads);

}  // namespace biodyn::capture
