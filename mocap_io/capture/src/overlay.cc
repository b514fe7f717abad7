// The overlay video (overlay.h).
#include "biodyn/capture/overlay.h"

#include <cmath>
#include <filesystem>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "biodyn/sim/errors.h"

namespace biodyn::capture {

struct OverlayWriter::Impl {
  std::string path, partial;
  Rig rig;
  double scale = 0.5;
  int columns = 1, rows = 1;
  cv::Size tile;
  cv::VideoWriter video;
  cv::Mat canvas, colour, small;
  bool finished = false;
};

OverlayWriter::OverlayWriter(const std::string& path, const Rig& rig, double fps, double scale)
    : impl_(std::make_unique<Impl>()) {
  namespace fs = std::filesystem;
  std::string ext = fs::path(path).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (ext != ".mp4" && ext != ".avi")
    throw sim::InvalidArgument("--overlay: a .mp4 or .avi video, got \"" + path + "\"");
  if (!(scale >= 0.1 && scale <= 2))
    throw sim::InvalidArgument("overlay: scale 0.1 .. 2, got " + std::to_string(scale));
  if (rig.size() < 1) throw sim::InvalidArgument("overlay: a rig without cameras");
  Impl& im = *impl_;
  im.path = path;
  // The extension stays last (OpenCV picks the container from it).
  im.partial =
      (fs::path(path).parent_path() / ("." + fs::path(path).stem().string() + ".partial" + ext))
          .string();
  im.rig = rig;
  im.scale = scale;
  im.columns = static_cast<int>(std::ceil(std::sqrt(static_cast<double>(rig.size()))));
  im.rows = (rig.size() + im.columns - 1) / im.columns;
  const Intrinsics& k = rig.cameras.front().K;
  im.tile = cv::Size(static_cast<int>(std::lround(k.width_px * scale)) / 2 * 2,
                     static_cast<int>(std::lround(k.height_px * scale)) / 2 * 2);
  im.canvas =
      cv::Mat(im.tile.height * im.rows, im.tile.width * im.columns, CV_8UC3, cv::Scalar(0, 0, 0));
  const int fourcc = ext == ".mp4" ? cv::VideoWriter::fourcc('m', 'p', '4', 'v')
                                   : cv::VideoWriter::fourcc('M', 'J', 'P', 'G');
  if (!im.video.open(im.partial, cv::CAP_FFMPEG, fourcc, fps, im.canvas.size(), true))
    throw sim::Error(path + ": OpenCV cannot write this video (FFmpeg backend)");
}

OverlayWriter::~OverlayWriter() {
  if (impl_ && !impl_->finished) {
    impl_->video.release();
    std::error_code ignored;
    std::filesystem::remove(impl_->partial, ignored);  // whole or not at all
  }
}

void OverlayWriter::add(const FrameSet& frames, const std::vector<std::vector<Blob>>& blobs,
                        const std::vector<std::pair<std::string, Eigen::Vector3d>>& labelled) {
  Impl& im = *impl_;
  im.canvas.setTo(cv::Scalar(0, 0, 0));
  const double s = im.scale;
  for (int c = 0; c < im.rig.size(); ++c) {
    const cv::Rect where((c % im.columns) * im.tile.width, (c / im.columns) * im.tile.height,
                         im.tile.width, im.tile.height);
    cv::Mat tile = im.canvas(where);
    if (static_cast<std::size_t>(c) < frames.images.size() && !frames.images[c].empty()) {
      cv::resize(frames.images[c], im.small, im.tile, 0, 0, cv::INTER_AREA);
      cv::cvtColor(im.small, tile, cv::COLOR_GRAY2BGR);
    }
    const auto at = [&](const Eigen::Vector2d& uv) {
      return cv::Point(static_cast<int>(std::lround(uv.x() * s)),
                       static_cast<int>(std::lround(uv.y() * s)));
    };
    if (static_cast<std::size_t>(c) < blobs.size()) {
      for (const Blob& b : blobs[c])
        cv::circle(tile, at(b.uv_px), 6, b.split ? cv::Scalar(0, 220, 255) : cv::Scalar(0, 200, 0),
                   1, cv::LINE_AA);
    }
    const Camera& cam = im.rig.cameras[c];
    for (const auto& [label, p_W] : labelled) {
      bool in_front = false;
      const Eigen::Vector2d uv = cam.project(p_W, &in_front);
      if (!in_front || !cam.in_image(uv)) continue;
      const cv::Point p = at(uv);
      cv::drawMarker(tile, p, cv::Scalar(40, 40, 255), cv::MARKER_CROSS, 8, 1, cv::LINE_AA);
      cv::putText(tile, label, p + cv::Point(5, -4), cv::FONT_HERSHEY_PLAIN, 0.7,
                  cv::Scalar(80, 80, 255), 1, cv::LINE_AA);
    }
    cv::putText(tile, cam.name, cv::Point(4, 14), cv::FONT_HERSHEY_PLAIN, 1.0,
                cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
  }
  cv::putText(im.canvas, "frame " + std::to_string(frames.index), cv::Point(4, im.canvas.rows - 6),
              cv::FONT_HERSHEY_PLAIN, 1.0, cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
  im.video.write(im.canvas);
}

void OverlayWriter::finish() {
  Impl& im = *impl_;
  im.video.release();
  std::error_code error;
  std::filesystem::rename(im.partial, im.path, error);
  if (error)
    throw sim::Error(im.path + ": cannot move the overlay video into place: " + error.message());
  im.finished = true;
}

}  // namespace biodyn::capture
