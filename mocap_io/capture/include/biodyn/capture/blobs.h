#pragma once
/// Marker blobs in one camera image (the thesis's 2D stage: background subtraction, threshold,
/// erosion/dilation, connected components, rejection by size and shape), each located by its
/// intensity-weighted centroid to a fraction of a pixel.

#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <vector>

namespace biodyn::capture {

struct BlobParams {
  /// grey levels (0..255) above the background that make a pixel part of a marker
  int threshold_grey = 50;
  /// grey levels above the background under which a pixel adds nothing to a centroid (the
  /// sensor's noise floor): weights are max(I - background - floor, 0)
  double weight_floor_grey = 6;
  double min_area_px = 2, max_area_px = 2000;  ///< pixels over the threshold (OptiTrack: 4)
  /// Minor over major axis of the blob's second moments; an elongated blob (two markers
  /// touching, a reflection along an edge) is rejected. Blobs under min_area_for_shape_px are
  /// too small to judge and pass.
  double min_roundness = 0.55;
  double min_area_for_shape_px = 8;
  /// px: erosion then dilation (an opening) with this radius before the components are found;
  /// 0: none (markers of a few pixels would vanish).
  int opening_radius_px = 0;
  /// px: a blob within this distance of the image border is refused (part of the marker may be
  /// outside the image: its centroid would be pulled inwards).
  int border_px = 1;
  void validate() const;  ///< throws sim::InvalidArgument naming the field
};

/// One marker candidate in an image.
struct Blob {
  Eigen::Vector2d uv_px = Eigen::Vector2d::Zero();  ///< intensity-weighted centroid
  double area_px = 0;                               ///< pixels over the threshold
  double roundness = 1;                             ///< minor / major axis (second moments)
  double peak_grey = 0;                             ///< brightest pixel above the background
  /// One of two touching markers whose joint blob was split in two (BlobDetector::detect).
  bool split = false;
};

/// Finds the blobs of 8-bit grey images of one camera. Keeps its scratch images between calls
/// (no allocation once warm).
class BlobDetector {
 public:
  explicit BlobDetector(const BlobParams& params = {});
  /// A background image (the median of frames without the subject, or any static scene) to
  /// subtract from every image; none: the background is black.
  void set_background(const cv::Mat& grey);
  /// The blobs of `grey` (8-bit, one channel) into `blobs`, in scan order of their first pixel.
  /// `rejected` (optional) counts those refused by size or shape. Throws sim::InvalidArgument
  /// for an image that is not 8-bit grey or does not match the background's size.
  void detect(const cv::Mat& grey, std::vector<Blob>* blobs, int* rejected = nullptr);

 private:
  /// Splits the component whose weighted pixels are in pixels_ (brightest: `peak_grey`) into
  /// two round blobs if it is two touching markers; false if it is not.
  bool split_pair(double peak_grey, std::vector<Blob>* blobs) const;

  BlobParams params_;
  cv::Mat background_, foreground_, mask_, labels_, stats_, centroids_, kernel_;
  std::vector<Eigen::Vector3d> pixels_;  ///< scratch: (u, v, weight) of one component
};

}  // namespace biodyn::capture
