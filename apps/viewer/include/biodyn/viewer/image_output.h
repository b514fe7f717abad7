#pragma once
/// Screenshots (PNG through stb_image_write) and videos (MP4 through an ffmpeg process), both
/// written whole or not at all: into a temporary file beside the target, renamed at the end.
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

namespace biodyn::viewer {

/// Writes width x height RGB (rows top to bottom) as a PNG. Throws sim::Error naming the path.
void write_png(const std::string& path, int width, int height,
               const std::vector<std::uint8_t>& rgb);

/// An MP4 (H.264, yuv420p) fed frame by frame to `ffmpeg`.
class VideoWriter {
 public:
  /// Starts ffmpeg writing `<path>.partial.mp4`. Throws sim::Error if ffmpeg cannot start
  /// (naming the package to install) or the size is odd (H.264 4:2:0 needs even sizes).
  VideoWriter(std::string path, int width, int height, double fps);
  /// Abandons an unfinished video (the partial file is removed).
  ~VideoWriter();
  VideoWriter(const VideoWriter&) = delete;
  VideoWriter& operator=(const VideoWriter&) = delete;

  /// One frame, width x height RGB, rows top to bottom. Throws sim::Error if ffmpeg died.
  void add_frame(const std::vector<std::uint8_t>& rgb);
  /// Closes ffmpeg and renames the file into place. Throws sim::Error with ffmpeg's log if it
  /// failed.
  void finish();

 private:
  std::string path_, partial_, log_;
  int width_, height_;
  std::FILE* pipe_ = nullptr;
};

}  // namespace biodyn::viewer
