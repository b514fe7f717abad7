// Marker blobs in camera images (blobs.h).
#include "biodyn/capture/blobs.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <string>

#include "biodyn/sim/errors.h"

namespace biodyn::capture {
namespace {
// A joint blob of two touching markers: 2-means iterations, the halves' least roundness (a
// disc cut by its neighbour's half-plane is ~0.6-0.8 round) and their largest weight ratio.
constexpr int kSplitIterations = 8;
constexpr double kSplitRoundness = 0.55;
constexpr double kSplitWeightRatio = 3.0;

struct Moments {
  Eigen::Vector2d centroid = Eigen::Vector2d::Zero();    ///< px, intensity-weighted
  Eigen::Matrix2d covariance = Eigen::Matrix2d::Zero();  ///< px^2
  double roundness = 1;                                  ///< minor / major axis
  double weight = 0;                                     ///< summed weights
  int count = 0;                                         ///< pixels
};

/// Weighted moments of the pixels (u, v, weight) that `in` selects.
template <class In>
Moments moments_of(const std::vector<Eigen::Vector3d>& px, In in) {
  double w = 0, su = 0, sv = 0, suu = 0, svv = 0, suv = 0;
  Moments m;
  for (std::size_t i = 0; i < px.size(); ++i) {
    if (!in(i)) continue;
    const Eigen::Vector3d& p = px[i];
    w += p.z();
    su += p.z() * p.x();
    sv += p.z() * p.y();
    suu += p.z() * p.x() * p.x();
    svv += p.z() * p.y() * p.y();
    suv += p.z() * p.x() * p.y();
    ++m.count;
  }
  m.weight = w;
  if (w <= 0) return m;
  m.centroid = Eigen::Vector2d(su / w, sv / w);
  const double cuu = suu / w - m.centroid.x() * m.centroid.x();
  const double cvv = svv / w - m.centroid.y() * m.centroid.y();
  const double cuv = suv / w - m.centroid.x() * m.centroid.y();
  m.covariance << cuu, cuv, cuv, cvv;
  const double mean = 0.5 * (cuu + cvv);
  const double spread = std::sqrt(std::max(0.0, 0.25 * (cuu - cvv) * (cuu - cvv) + cuv * cuv));
  const double major = mean + spread, minor = std::max(0.0, mean - spread);
  m.roundness = major > 0 ? std::sqrt(minor / major) : 1.0;
  return m;
}

}  // namespace

void BlobParams::validate() const {
  const auto bad = [](const char* field, const std::string& why) {
    throw sim::InvalidArgument(std::string("blob detection: ") + field + ": " + why);
  };
  if (threshold_grey < 1 || threshold_grey > 254)
    bad("threshold_grey", "must be 1 .. 254, got " + std::to_string(threshold_grey));
  if (!(weight_floor_grey >= 0) || weight_floor_grey >= threshold_grey)
    bad("weight_floor_grey",
        "must be in [0, threshold_grey), got " + std::to_string(weight_floor_grey));
  if (!(min_area_px >= 1) || !(max_area_px >= min_area_px))
    bad("min_area_px/max_area_px", "need 1 <= min <= max, got " + std::to_string(min_area_px) +
                                       ", " + std::to_string(max_area_px));
  if (!(min_roundness >= 0) || min_roundness > 1)
    bad("min_roundness", "must be in [0, 1], got " + std::to_string(min_roundness));
  if (border_px < 0 || border_px > 100)
    bad("border_px", "must be 0 .. 100, got " + std::to_string(border_px));
  if (opening_radius_px < 0 || opening_radius_px > 10)
    bad("opening_radius_px", "must be 0 .. 10, got " + std::to_string(opening_radius_px));
}

BlobDetector::BlobDetector(const BlobParams& params) : params_(params) {
  params_.validate();
  if (params_.opening_radius_px > 0) {
    const int d = 2 * params_.opening_radius_px + 1;
    kernel_ = cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(d, d));
  }
}

void BlobDetector::set_background(const cv::Mat& grey) {
  if (grey.type() != CV_8UC1)
    throw sim::InvalidArgument("blob detection: the background must be an 8-bit grey image");
  grey.copyTo(background_);
}

void BlobDetector::detect(const cv::Mat& grey, std::vector<Blob>* blobs, int* rejected) {
  if (grey.type() != CV_8UC1)
    throw sim::InvalidArgument("blob detection: an image must be 8-bit grey (one channel)");
  if (!background_.empty() && background_.size() != grey.size())
    throw sim::InvalidArgument("blob detection: the image is " + std::to_string(grey.cols) + " x " +
                               std::to_string(grey.rows) + ", its background " +
                               std::to_string(background_.cols) + " x " +
                               std::to_string(background_.rows));
  if (background_.empty())
    grey.copyTo(foreground_);
  else
    cv::subtract(grey, background_, foreground_);  // saturates at 0
  cv::threshold(foreground_, mask_, params_.threshold_grey, 255, cv::THRESH_BINARY);
  if (!kernel_.empty()) cv::morphologyEx(mask_, mask_, cv::MORPH_OPEN, kernel_);
  const int n = cv::connectedComponentsWithStats(mask_, labels_, stats_, centroids_, 8, CV_32S);
  blobs->clear();
  int refused = 0;
  for (int label = 1; label < n; ++label) {
    const double area = stats_.at<int>(label, cv::CC_STAT_AREA);
    const int left = stats_.at<int>(label, cv::CC_STAT_LEFT),
              top = stats_.at<int>(label, cv::CC_STAT_TOP);
    const int right = left + stats_.at<int>(label, cv::CC_STAT_WIDTH) - 1;
    const int bottom = top + stats_.at<int>(label, cv::CC_STAT_HEIGHT) - 1;
    const int margin = params_.border_px;
    const bool at_border = left < margin || top < margin || right > grey.cols - 1 - margin ||
                           bottom > grey.rows - 1 - margin;
    if (area < params_.min_area_px || area > params_.max_area_px || at_border) {
      ++refused;
      continue;
    }
    // Weighted moments over the component's box grown by one pixel: the anti-aliased rim under
    // the threshold carries weight too; pixels of another component do not.
    const int x0 = std::max(0, stats_.at<int>(label, cv::CC_STAT_LEFT) - 1);
    const int y0 = std::max(0, stats_.at<int>(label, cv::CC_STAT_TOP) - 1);
    const int x1 = std::min(grey.cols, stats_.at<int>(label, cv::CC_STAT_LEFT) +
                                           stats_.at<int>(label, cv::CC_STAT_WIDTH) + 1);
    const int y1 = std::min(grey.rows, stats_.at<int>(label, cv::CC_STAT_TOP) +
                                           stats_.at<int>(label, cv::CC_STAT_HEIGHT) + 1);
    double peak = 0;
    pixels_.clear();
    for (int y = y0; y < y1; ++y) {
      const std::uint8_t* row = foreground_.ptr<std::uint8_t>(y);
      const int* lab = labels_.ptr<int>(y);
      for (int x = x0; x < x1; ++x) {
        if (lab[x] != 0 && lab[x] != label) continue;
        const double wi = std::max(0.0, row[x] - params_.weight_floor_grey);
        peak = std::max(peak, static_cast<double>(row[x]));
        if (wi > 0) pixels_.emplace_back(x, y, wi);
      }
    }
    const Moments mo = moments_of(pixels_, [](std::size_t) { return true; });
    if (mo.weight <= 0) {
      ++refused;
      continue;
    }
    Blob b;
    b.uv_px = mo.centroid;
    b.roundness = mo.roundness;
    b.area_px = area;
    b.peak_grey = peak;
    if (area >= params_.min_area_for_shape_px && b.roundness < params_.min_roundness) {
      if (!split_pair(peak, blobs)) ++refused;
      continue;
    }
    blobs->push_back(b);
  }
  if (rejected != nullptr) *rejected = refused;
}

bool BlobDetector::split_pair(double peak_grey, std::vector<Blob>* blobs) const {
  // Two touching discs: weighted 2-means on the blob's pixels, started a standard deviation
  // either side of the centroid along the major axis. Accepted when both halves are round and
  // of comparable brightness (two markers of one size at similar depths); a smear or a
  // reflection is not.
  const Moments whole = moments_of(pixels_, [](std::size_t) { return true; });
  if (whole.weight <= 0) return false;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(whole.covariance);
  const Eigen::Vector2d axis =
      eig.eigenvectors().col(1) * std::sqrt(std::max(0.0, eig.eigenvalues()(1)));
  Eigen::Vector2d a = whole.centroid + axis, b = whole.centroid - axis;
  const auto nearer_a = [&](std::size_t i) {
    return (pixels_[i].head<2>() - a).squaredNorm() <= (pixels_[i].head<2>() - b).squaredNorm();
  };
  Moments first, second;
  for (int iteration = 0; iteration < kSplitIterations; ++iteration) {
    first = moments_of(pixels_, nearer_a);
    second = moments_of(pixels_, [&](std::size_t i) { return !nearer_a(i); });
    a = first.centroid;
    b = second.centroid;
  }
  const double heavier = std::max(first.weight, second.weight);
  const double lighter = std::min(first.weight, second.weight);
  if (first.roundness < kSplitRoundness || second.roundness < kSplitRoundness ||
      lighter * kSplitWeightRatio < heavier)
    return false;
  for (const Moments* half : {&first, &second}) {
    Blob blob;
    blob.uv_px = half->centroid;
    blob.roundness = half->roundness;
    blob.area_px = half->count;
    blob.split = true;
    blob.peak_grey = peak_grey;
    blobs->push_back(blob);
  }
  return true;
}

}  // namespace biodyn::capture
