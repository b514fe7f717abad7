// Frames to 3D points (pipeline.h).
#include "biodyn/capture/pipeline.h"

#include <opencv2/core/utility.hpp>
#include <string>

#include "biodyn/sim/errors.h"

namespace biodyn::capture {

CapturePipeline::CapturePipeline(const Rig& rig, const BlobParams& blobs,
                                 const ReconstructionParams& reconstruction,
                                 const Tracking2dParams* tracking)
    : detectors_(rig.cameras.size(), BlobDetector(blobs)),
      blobs_(rig.cameras.size()),
      trackers_(tracking ? rig.cameras.size() : 0,
                BlobTracker2d(tracking ? *tracking : Tracking2dParams{})),
      tracks_(rig.cameras.size()),
      reconstructor_(rig, reconstruction) {}

void CapturePipeline::process(const FrameSet& frames, std::vector<Point3>* points) {
  const int n = static_cast<int>(detectors_.size());
  if (static_cast<int>(frames.images.size()) != n)
    throw sim::InvalidArgument("capture: a frame of " + std::to_string(frames.images.size()) +
                               " images for a rig of " + std::to_string(n) + " cameras");
  // Each camera's detector and blob list are its own: the result does not depend on threads.
  const bool tracking = !trackers_.empty();
  cv::parallel_for_(cv::Range(0, n), [&](const cv::Range& r) {
    for (int c = r.start; c < r.end; ++c) {
      detectors_[c].detect(frames.images[c], &blobs_[c]);
      if (tracking) trackers_[c].update(blobs_[c], frames.images[c], &tracks_[c]);
    }
  });
  reconstructor_.reconstruct(blobs_, points, tracking ? &tracks_ : nullptr);
}

void set_image_threads(int threads) { cv::setNumThreads(threads > 0 ? threads : -1); }

}  // namespace biodyn::capture
