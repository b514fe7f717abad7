// 2D blob tracks (tracking2d.h).
#include "biodyn/capture/tracking2d.h"

#include <algorithm>
#include <opencv2/video/tracking.hpp>
#include <string>

#include "biodyn/capture/labelling.h"
#include "biodyn/sim/errors.h"

namespace biodyn::capture {

void Tracking2dParams::validate() const {
  const auto bad = [](const char* field, const std::string& why) {
    throw sim::InvalidArgument(std::string("2D tracking: ") + field + ": " + why);
  };
  if (!(gate_px > 0)) bad("gate_px", "must be > 0, got " + std::to_string(gate_px));
  if (!(gate_per_step >= 0))
    bad("gate_per_step", "must be >= 0, got " + std::to_string(gate_per_step));
  if (max_coast_frames < 0)
    bad("max_coast_frames", "must be >= 0, got " + std::to_string(max_coast_frames));
  if (flow_window_px < 3 || flow_window_px % 2 == 0)
    bad("flow_window_px", "must be odd and >= 3, got " + std::to_string(flow_window_px));
  if (flow_levels < 0 || flow_levels > 6)
    bad("flow_levels", "must be 0 .. 6, got " + std::to_string(flow_levels));
}

BlobTracker2d::BlobTracker2d(const Tracking2dParams& params) : params_(params) {
  params_.validate();
}

void BlobTracker2d::predict(const cv::Mat& image) {
  predicted_.resize(tracks_.size());
  flow_from_.clear();
  flow_track_.clear();
  for (std::size_t t = 0; t < tracks_.size(); ++t) {
    const Track2d& k = tracks_[t];
    predicted_[t] = k.uv_px + static_cast<double>(k.missed + 1) * k.velocity_px;
    if (k.age == 1 && k.missed == 0 && params_.optical_flow && !previous_.empty()) {
      flow_from_.emplace_back(static_cast<float>(k.uv_px.x()), static_cast<float>(k.uv_px.y()));
      flow_track_.push_back(static_cast<int>(t));
    }
  }
  if (flow_from_.empty() || image.empty() || image.size() != previous_.size()) return;
  flow_to_ = flow_from_;
  cv::calcOpticalFlowPyrLK(
      previous_, image, flow_from_, flow_to_, flow_found_, flow_error_,
      cv::Size(params_.flow_window_px, params_.flow_window_px), params_.flow_levels,
      cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 20, 0.01));
  for (std::size_t i = 0; i < flow_track_.size(); ++i)
    if (flow_found_[i])
      predicted_[static_cast<std::size_t>(flow_track_[i])] =
          Eigen::Vector2d(flow_to_[i].x, flow_to_[i].y);
}

void BlobTracker2d::update(const std::vector<Blob>& blobs, const cv::Mat& image,
                           std::vector<int>* track_of_blob) {
  predict(image);
  const Eigen::Index nt = static_cast<Eigen::Index>(tracks_.size());
  const Eigen::Index nb = static_cast<Eigen::Index>(blobs.size());
  cost_.resize(nt, nb);
  for (Eigen::Index t = 0; t < nt; ++t) {
    const Track2d& k = tracks_[static_cast<std::size_t>(t)];
    const double gate = params_.gate_px + params_.gate_per_step * k.velocity_px.norm();
    for (Eigen::Index b = 0; b < nb; ++b)
      cost_(t, b) =
          (blobs[static_cast<std::size_t>(b)].uv_px - predicted_[static_cast<std::size_t>(t)])
              .norm() /
          gate;
  }
  std::vector<int> blob_of_track = min_cost_assignment(cost_, 1.0);
  // A track with a second, unclaimed blob within its gate ends here: two markers parting after
  // their images merged (a hand passing the thigh), the track cannot tell which is its own.
  // Both blobs start new tracks; the reconstruction matches them afresh.
  std::vector<char> claimed(blobs.size(), 0);
  for (int b : blob_of_track)
    if (b >= 0) claimed[static_cast<std::size_t>(b)] = 1;
  for (Eigen::Index t = 0; t < nt; ++t) {
    if (blob_of_track[static_cast<std::size_t>(t)] < 0) continue;
    for (Eigen::Index b = 0; b < nb; ++b)
      if (!claimed[static_cast<std::size_t>(b)] && cost_(t, b) < 1.0) {
        blob_of_track[static_cast<std::size_t>(t)] = -1;
        tracks_[static_cast<std::size_t>(t)].missed = params_.max_coast_frames;  // ends it
        break;
      }
  }
  track_of_blob->assign(blobs.size(), -1);
  std::vector<Track2d> kept;
  kept.reserve(tracks_.size() + blobs.size());
  for (std::size_t t = 0; t < tracks_.size(); ++t) {
    Track2d k = tracks_[t];
    const int b = blob_of_track[t];
    if (b >= 0) {
      const Eigen::Vector2d uv = blobs[static_cast<std::size_t>(b)].uv_px;
      // After coasting, the step is spread over the frames the blob was missing.
      k.velocity_px = (uv - k.uv_px) / static_cast<double>(k.missed + 1);
      k.uv_px = uv;
      ++k.age;
      k.missed = 0;
      (*track_of_blob)[static_cast<std::size_t>(b)] = k.id;
    } else {
      if (++k.missed > params_.max_coast_frames) continue;
    }
    kept.push_back(k);
  }
  for (std::size_t b = 0; b < blobs.size(); ++b) {
    if ((*track_of_blob)[b] >= 0) continue;
    Track2d k;
    k.id = next_id_++;
    k.uv_px = blobs[b].uv_px;
    k.age = 1;
    (*track_of_blob)[b] = k.id;
    kept.push_back(k);
  }
  tracks_.swap(kept);
  if (!image.empty()) image.copyTo(previous_);
}

}  // namespace biodyn::capture
