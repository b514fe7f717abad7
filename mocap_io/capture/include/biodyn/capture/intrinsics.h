#pragma once
/// Lens calibration from a checkerboard (OpenCV's calib3d: findChessboardCorners, cornerSubPix,
/// calibrateCamera; Zhang 2000): each camera's focal lengths, principal point and Brown–Conrady
/// distortion from views of a flat board held in front of it, before the wand finds where the
/// cameras are (calibration.h). And the board filmed by a synthetic camera, for testing.

#include <Eigen/Geometry>
#include <cstdint>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "biodyn/capture/camera.h"

namespace biodyn::capture {

struct Checkerboard {
  int cols = 9, rows = 6;  ///< inner corners along and across the board
  double square_m = 0.04;  ///< m, side of a square
  void validate() const;   ///< throws sim::InvalidArgument naming the field and value
  /// m, the inner corners in the board's frame (z = 0), row by row as OpenCV finds them.
  std::vector<cv::Point3f> corners_B() const;
};

/// `views` poses (board frame to world) of the board in front of `camera`: 0.45-1.4 m away,
/// tilted up to 40 degrees, centred anywhere in the image (its corners too: the lens's
/// distortion is largest there), each with every corner inside the image; seeded.
std::vector<Eigen::Isometry3d> board_poses(const Camera& camera, const Checkerboard& board,
                                           int views, std::uint64_t seed);

/// A synthetic camera filming the board (black and white squares with a white margin of one
/// square) against a dark room, through its lens, 2 x 2 samples per pixel. Keeps the rays of
/// its samples (the lens inverted once).
class BoardCamera {
 public:
  explicit BoardCamera(const Camera& camera);
  /// The board at `board_W`, with Gaussian sensor noise of `noise_grey` keyed by `seed`.
  cv::Mat film(const Checkerboard& board, const Eigen::Isometry3d& board_W, double noise_grey,
               std::uint64_t seed) const;

 private:
  Camera camera_;
  std::vector<Eigen::Vector2d> rays_;  ///< normalised image point of each sample, row by row
};

struct LensFit {
  Intrinsics lens;     ///< the fitted lens (k3 held at 0)
  double rms_px = 0;   ///< RMS reprojection error of the found corners
  int views_used = 0;  ///< images where the whole board was found
};

/// The lens of one camera from its board images (8-bit grey, all `size`). Throws
/// sim::InvalidArgument if fewer than 5 images show the whole board.
LensFit calibrate_lens(const std::vector<cv::Mat>& images, const Checkerboard& board);

/// Films `views` board views for every camera of `rig` (board_poses, BoardCamera; sensor noise
/// `noise_grey`) into `dir`/<camera>/000000.png ... (a lab's checkerboard session: each camera
/// its own views).
void film_board_views(const Rig& rig, const Checkerboard& board, int views, double noise_grey,
                      std::uint64_t seed, const std::string& dir);
/// The images of `dir`/<camera>/*.png in name order, as 8-bit grey. Throws sim::InvalidArgument
/// naming the folder if it has none or one cannot be read.
std::vector<cv::Mat> read_board_views(const std::string& dir, const std::string& camera);

}  // namespace biodyn::capture
