#pragma once
/// The overlay video `capture run --overlay` writes: every camera's image in a grid, its
/// detected blobs circled (green; split ones yellow), the labelled markers' 3D positions
/// projected back through the lens (red cross, label). What a lab looks at to trust a capture.

#include <Eigen/Core>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "biodyn/capture/blobs.h"
#include "biodyn/capture/camera.h"
#include "biodyn/capture/frame_source.h"

namespace biodyn::capture {

class OverlayWriter {
 public:
  /// Writes to `path` (.mp4 or .avi, MJPEG/MPEG-4 through OpenCV's FFmpeg backend) at `fps`,
  /// each camera's tile `scale` times its image size. Nothing is at `path` until finish().
  /// Throws sim::InvalidArgument for another extension or a scale outside 0.1 .. 2.
  OverlayWriter(const std::string& path, const Rig& rig, double fps, double scale = 0.5);
  ~OverlayWriter();
  /// One frame: the images, each camera's blobs, the labelled markers (label, m in W).
  void add(const FrameSet& frames, const std::vector<std::vector<Blob>>& blobs,
           const std::vector<std::pair<std::string, Eigen::Vector3d>>& labelled);
  /// Closes the video and moves it to `path`. Throws sim::Error if it could not be written.
  void finish();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace biodyn::capture
