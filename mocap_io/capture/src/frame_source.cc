// Camera image sources and the recorded-capture writer (frame_source.h).
#include "biodyn/capture/frame_source.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>
#include <thread>

#include "biodyn/sim/errors.h"
#include "biodyn/sim/file_io.h"

namespace biodyn::capture {
namespace fs = std::filesystem;
namespace {

// A gap between two timestamps longer than this many frame periods means frames were lost.
constexpr double kDropGapPeriods = 1.5;
const char* const kVideoExtensions[] = {".mp4", ".avi", ".mkv", ".mov"};

std::string image_name(int frame) {
  char name[32];
  std::snprintf(name, sizeof name, "%06d.png", frame);
  return name;
}

int dropped_between(double previous_s, double now_s, double fps) {
  const double gap = (now_s - previous_s) * fps;
  return gap > kDropGapPeriods ? static_cast<int>(std::lround(gap)) - 1 : 0;
}

cv::Mat to_grey(const cv::Mat& image) {
  if (image.empty() || image.type() == CV_8UC1) return image;
  cv::Mat grey;
  cv::cvtColor(image, grey, image.channels() == 4 ? cv::COLOR_BGRA2GRAY : cv::COLOR_BGR2GRAY);
  if (grey.depth() != CV_8U) grey.convertTo(grey, CV_8U);
  return grey;
}

// Timestamps file: "frame,time_s" header, then one line per frame, increasing times.
std::vector<double> read_timestamps(const std::string& path, int frames) {
  const std::string text = sim::read_file(path);
  std::vector<double> times;
  std::size_t start = 0;
  int line = 0;
  while (start < text.size()) {
    std::size_t end = text.find('\n', start);
    if (end == std::string::npos) end = text.size();
    const std::string row = text.substr(start, end - start);
    start = end + 1;
    ++line;
    if (line == 1 || row.empty()) continue;  // the header
    const std::vector<std::string> f = sim::split_fields(row, ',');
    char* stop = nullptr;
    const double t = f.size() == 2 ? std::strtod(f[1].c_str(), &stop) : NAN;
    if (f.size() != 2 || stop == f[1].c_str() || !std::isfinite(t))
      throw sim::InvalidArgument(path + ": line " + std::to_string(line) +
                                 ": expected frame,time_s, got \"" + row + "\"");
    if (!times.empty() && !(t > times.back()))
      throw sim::InvalidArgument(path + ": line " + std::to_string(line) +
                                 ": time_s must increase, got " + f[1] + " after " +
                                 std::to_string(times.back()));
    times.push_back(t);
  }
  if (static_cast<int>(times.size()) != frames)
    throw sim::InvalidArgument(path + ": " + std::to_string(times.size()) + " timestamps for " +
                               std::to_string(frames) + " frames");
  return times;
}

class RecordedSource final : public FrameSource {
 public:
  RecordedSource(const std::string& dir, const std::vector<std::string>& pick) : dir_(dir) {
    const std::string meta_path = (fs::path(dir) / "capture.json").string();
    nlohmann::json meta;
    try {
      meta = nlohmann::json::parse(sim::read_file(meta_path));
    } catch (const nlohmann::json::exception& e) {
      throw sim::InvalidArgument(meta_path + ": malformed JSON: " + e.what());
    }
    const auto need = [&](const char* key, bool ok) {
      if (!meta.contains(key) || !ok)
        throw sim::InvalidArgument(meta_path + ": " + key + ": missing or malformed");
    };
    need("cameras",
         meta.contains("cameras") && meta["cameras"].is_array() && !meta["cameras"].empty());
    need("fps", meta.contains("fps") && meta["fps"].is_number() && meta["fps"].get<double>() > 0);
    need("frames", meta.contains("frames") && meta["frames"].is_number_integer() &&
                       meta["frames"].get<int>() >= 0);
    fps_ = meta["fps"];
    frames_ = meta["frames"];
    std::vector<std::string> all;
    for (const auto& c : meta["cameras"]) all.push_back(c.get<std::string>());
    names_ = pick.empty() ? all : pick;
    for (const std::string& n : names_) {
      if (std::find(all.begin(), all.end(), n) == all.end())
        throw sim::InvalidArgument(meta_path + ": cameras: no camera \"" + n + "\"");
      open_camera(n);
    }
  }
  int camera_count() const override { return static_cast<int>(names_.size()); }
  std::vector<std::string> camera_names() const override { return names_; }
  int frame_count() const override { return frames_; }
  bool next(FrameSet* out) override {
    if (frame_ >= frames_) return false;
    const int n = camera_count();
    out->start(frame_, n);
    for (int c = 0; c < n; ++c) {
      Camera& cam = cameras_[c];
      if (cam.video.isOpened()) {
        cv::Mat frame;
        if (!cam.video.read(frame))
          throw sim::InvalidArgument(cam.path + ": frame " + std::to_string(frame_) +
                                     " cannot be read");
        out->images[c] = to_grey(frame);
      } else {
        const std::string path = (fs::path(cam.path) / image_name(frame_)).string();
        out->images[c] = cv::imread(path, cv::IMREAD_GRAYSCALE);
        if (out->images[c].empty())
          throw sim::InvalidArgument(path + ": missing or not an image (frame " +
                                     std::to_string(frame_) + ")");
      }
      if (frame_ > 0 && out->images[c].size() != cam.size)
        throw sim::InvalidArgument(cam.path + ": frame " + std::to_string(frame_) + " is " +
                                   std::to_string(out->images[c].cols) + " x " +
                                   std::to_string(out->images[c].rows) + ", the first was " +
                                   std::to_string(cam.size.width) + " x " +
                                   std::to_string(cam.size.height));
      cam.size = out->images[c].size();
      out->times_s[c] = cam.times[frame_];
      if (frame_ > 0)
        out->dropped_before[c] = dropped_between(cam.times[frame_ - 1], cam.times[frame_], fps_);
    }
    ++frame_;
    return true;
  }

 private:
  struct Camera {
    std::string path;
    cv::VideoCapture video;
    std::vector<double> times;
    cv::Size size;
  };
  void open_camera(const std::string& name) {
    Camera cam;
    const fs::path folder = fs::path(dir_) / name;
    if (fs::is_directory(folder)) {
      cam.path = folder.string();
      cam.times = read_timestamps((folder / "timestamps.csv").string(), frames_);
    } else {
      for (const char* ext : kVideoExtensions) {
        const fs::path video = fs::path(dir_) / (name + ext);
        if (fs::exists(video)) cam.path = video.string();
      }
      if (cam.path.empty())
        throw sim::InvalidArgument(dir_ + ": camera \"" + name +
                                   "\" has no image folder and no video (.mp4, .avi, .mkv, .mov)");
      if (!cam.video.open(cam.path, cv::CAP_FFMPEG))
        throw sim::InvalidArgument(cam.path + ": OpenCV cannot read this video");
      const fs::path stamps = fs::path(dir_) / (name + "_timestamps.csv");
      if (fs::exists(stamps)) {
        cam.times = read_timestamps(stamps.string(), frames_);
      } else {
        for (int f = 0; f < frames_; ++f) cam.times.push_back(f / fps_);
      }
    }
    cameras_.push_back(std::move(cam));
  }

  std::string dir_;
  std::vector<std::string> names_;
  std::vector<Camera> cameras_;
  double fps_ = 0;
  int frames_ = 0, frame_ = 0;
};

class LiveSource final : public FrameSource {
 public:
  LiveSource(const std::vector<std::string>& devices, double fps, int max_frames)
      : names_(devices), fps_(fps), max_frames_(max_frames) {
    if (devices.empty()) throw sim::InvalidArgument("live capture: no device given");
    if (!(fps > 0))
      throw sim::InvalidArgument("live capture: fps must be positive, got " + std::to_string(fps));
    for (const std::string& d : devices) {
      auto cap = std::make_unique<cv::VideoCapture>();
      const bool index = !d.empty() && d.find_first_not_of("0123456789") == std::string::npos;
      const bool device = index || d.rfind("/dev/", 0) == 0;
      files_.push_back(!device);
      // A file is opened through FFmpeg alone: letting OpenCV probe every backend on a missing
      // or odd file leaks inside some of them (libusb) and prints their errors. A URL
      // (rtsp://, a GStreamer pipeline) goes to whichever backend takes it.
      const bool url = d.find("://") != std::string::npos;
      if (!device && !url && !fs::exists(d))
        throw sim::InvalidArgument("live capture: \"" + d +
                                   "\" is neither a V4L2 device (a number or /dev/...) nor a file");
      const bool ok =
          index ? cap->open(std::stoi(d), cv::CAP_V4L2)
                : cap->open(d, device ? cv::CAP_V4L2 : (url ? cv::CAP_ANY : cv::CAP_FFMPEG));
      if (!ok)
        throw sim::InvalidArgument("live capture: cannot open \"" + d + "\"" +
                                   (device ? " (a V4L2 device)" : ""));
      if (device) cap->set(cv::CAP_PROP_FPS, fps);
      captures_.push_back(std::move(cap));
    }
    last_.assign(devices.size(), -1.0);
    played_.assign(devices.size(), 0);
    started_.assign(devices.size(), std::chrono::steady_clock::time_point{});
    streaming_.assign(devices.size(), false);
  }
  int camera_count() const override { return static_cast<int>(names_.size()); }
  std::vector<std::string> camera_names() const override { return names_; }
  int frame_count() const override { return -1; }
  bool next(FrameSet* out) override {
    if (max_frames_ > 0 && frame_ >= max_frames_) return false;
    const int n = camera_count();
    out->start(frame_, n);
    for (int c = 0; c < n; ++c) {
      cv::VideoCapture& cap = *captures_[c];
      if (files_[c]) pace(c, &out->dropped_before[c]);
      cv::Mat image;
      if (!cap.read(image)) return false;  // the device stopped or the file ended
      const double now = seconds(c);
      out->images[c] = to_grey(image);
      out->times_s[c] = files_[c] ? played_[c] / fps_ : now;
      if (!files_[c] && last_[c] >= 0)
        out->dropped_before[c] = dropped_between(last_[c], now, fps_);
      last_[c] = now;
      if (files_[c]) ++played_[c];
    }
    ++frame_;
    return true;
  }

 private:
  // s since camera c's first read. A camera streams from its first read on (OpenCV's V4L2
  // backend starts streaming at the first grab), so a file played as one does the same: the
  // time the reader spends getting ready before it asks costs no frames. A device's timestamps
  // count from the first camera's first read, one clock for all.
  double seconds(int c) {
    const auto now = std::chrono::steady_clock::now();
    if (!streaming_[c]) {
      started_[c] = files_[c] || c == 0 ? now : started_[0];
      streaming_[c] = true;
    }
    return std::chrono::duration<double>(now - started_[c]).count();
  }
  // A file played as a camera: wait for its next frame's time; a reader that fell behind loses
  // the frames that are overdue, as a camera's full buffer does.
  void pace(int c, int* dropped) {
    const double due = played_[c] / fps_;
    const double now = seconds(c);
    if (due > now) {
      std::this_thread::sleep_for(std::chrono::duration<double>(due - now));
      return;
    }
    const int behind = static_cast<int>(std::floor((now - due) * fps_));
    int skipped = 0;
    while (skipped < behind && captures_[c]->grab()) ++skipped;
    played_[c] += skipped;
    *dropped = skipped;
  }

  std::vector<std::string> names_;
  std::vector<std::unique_ptr<cv::VideoCapture>> captures_;
  std::vector<bool> files_;
  std::vector<double> last_;
  std::vector<int> played_;
  double fps_;
  int max_frames_, frame_ = 0;
  std::vector<std::chrono::steady_clock::time_point> started_;
  std::vector<bool> streaming_;
};

}  // namespace

std::unique_ptr<FrameSource> open_recorded(const std::string& dir,
                                           const std::vector<std::string>& cameras) {
  return std::make_unique<RecordedSource>(dir, cameras);
}

std::unique_ptr<FrameSource> open_live(const std::vector<std::string>& devices, double fps,
                                       int max_frames) {
  return std::make_unique<LiveSource>(devices, fps, max_frames);
}

RecordedWriter::RecordedWriter(std::string dir, std::vector<std::string> cameras, double fps)
    : dir_(std::move(dir)), partial_(dir_ + ".partial"), cameras_(std::move(cameras)), fps_(fps) {
  if (fs::exists(dir_))
    throw sim::InvalidArgument(dir_ + ": already exists (a capture is never overwritten)");
  std::error_code ec;
  fs::remove_all(partial_, ec);
  for (const std::string& c : cameras_) {
    fs::create_directories(fs::path(partial_) / c, ec);
    if (ec) throw sim::Error(partial_ + ": cannot create: " + ec.message());
  }
  timestamps_.assign(cameras_.size(), "frame,time_s\n");
}

RecordedWriter::~RecordedWriter() {
  if (!finished_) {
    std::error_code ec;
    fs::remove_all(partial_, ec);
  }
}

void RecordedWriter::add(const FrameSet& frames) {
  for (std::size_t c = 0; c < cameras_.size(); ++c) {
    const std::string path = (fs::path(partial_) / cameras_[c] / image_name(frames.index)).string();
    if (!cv::imwrite(path, frames.images[c])) throw sim::Error(path + ": cannot write the image");
    char line[64];
    std::snprintf(line, sizeof line, "%d,%.9f\n", frames.index, frames.times_s[c]);
    timestamps_[c] += line;
  }
  ++frames_;
}

void RecordedWriter::finish(const std::string& extra_json) {
  for (std::size_t c = 0; c < cameras_.size(); ++c)
    sim::write_file_atomically((fs::path(partial_) / cameras_[c] / "timestamps.csv").string(),
                               timestamps_[c]);
  nlohmann::json meta = nlohmann::json::parse(extra_json);
  meta["cameras"] = cameras_;
  meta["fps"] = fps_;
  meta["frames"] = frames_;
  sim::write_file_atomically((fs::path(partial_) / "capture.json").string(), meta.dump(2) + "\n");
  std::error_code ec;
  fs::rename(partial_, dir_, ec);
  if (ec) throw sim::Error(dir_ + ": cannot move the finished capture into place: " + ec.message());
  finished_ = true;
}

}  // namespace biodyn::capture
