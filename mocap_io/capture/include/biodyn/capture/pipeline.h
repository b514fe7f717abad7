#pragma once
/// One frame of every camera to 3D points: each image's blobs (the cameras in parallel), then
/// the multi-view reconstruction. What `biodyn capture run` drives, frame by frame.

#include <vector>

#include "biodyn/capture/blobs.h"
#include "biodyn/capture/frame_source.h"
#include "biodyn/capture/reconstruct.h"

namespace biodyn::capture {

class CapturePipeline {
 public:
  /// Throws sim::InvalidArgument for bad params (blobs.h, reconstruct.h).
  CapturePipeline(const Rig& rig, const BlobParams& blobs,
                  const ReconstructionParams& reconstruction);
  /// The points of `frames` (one image per camera, in the rig's order) into `points`; each
  /// camera's blobs stay readable through blobs(). Throws sim::InvalidArgument if the frame set
  /// has another number of images than the rig has cameras.
  void process(const FrameSet& frames, std::vector<Point3>* points);
  const std::vector<std::vector<Blob>>& blobs() const { return blobs_; }

 private:
  std::vector<BlobDetector> detectors_;
  std::vector<std::vector<Blob>> blobs_;
  Reconstructor reconstructor_;
};

/// Threads OpenCV may use for the cameras' images (0: its default, every core).
void set_image_threads(int threads);

}  // namespace biodyn::capture
