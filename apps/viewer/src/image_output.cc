// PNG and MP4 output (image_output.h).
#include "biodyn/viewer/image_output.h"

#include <stb/stb_image_write.h>

#include <sys/wait.h>
#include <cmath>

#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "biodyn/sim/errors.h"
#include "biodyn/sim/file_io.h"

namespace biodyn::viewer {
namespace {

std::string shell_quoted(const std::string& s) {
  std::string out = "'";
  for (char c : s) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

std::string slurp(const std::string& path) {
  std::ifstream in(path);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

}  // namespace

void write_png(const std::string& path, int width, int height,
               const std::vector<std::uint8_t>& rgb) {
  if (rgb.size() != 3 * static_cast<std::size_t>(width) * static_cast<std::size_t>(height)) {
    throw sim::InvalidArgument(path + ": image data does not match " + std::to_string(width) +
                               " x " + std::to_string(height) + " RGB");
  }
  // Encoded in memory, then written whole (sim/file_io.h).
  std::string png;
  const auto append = [](void* context, void* data, int size) {
    static_cast<std::string*>(context)->append(static_cast<const char*>(data),
                                               static_cast<std::size_t>(size));
  };
  if (!stbi_write_png_to_func(append, &png, width, height, 3, rgb.data(), 3 * width)) {
    throw sim::Error(path + ": cannot encode the PNG");
  }
  sim::write_file_atomically(path, png, sim::MissingDirectories::kCreate);
}

VideoWriter::VideoWriter(std::string path, int width, int height, double fps)
    : path_(std::move(path)), width_(width), height_(height) {
  if (width % 2 != 0 || height % 2 != 0 || width < 2 || height < 2) {
    throw sim::InvalidArgument(path_ + ": video size must be even and positive, got " +
                               std::to_string(width) + " x " + std::to_string(height));
  }
  if (!(fps > 0) || !std::isfinite(fps)) {
    throw sim::InvalidArgument(path_ + ": frame rate must be > 0, got " + std::to_string(fps));
  }
  const std::filesystem::path target(path_);
  if (target.has_parent_path()) std::filesystem::create_directories(target.parent_path());
  partial_ = path_ + ".partial.mp4";
  log_ = path_ + ".ffmpeg.log";
  std::ostringstream cmd;
  cmd << "ffmpeg -nostdin -y -loglevel error -f rawvideo -pix_fmt rgb24 -s " << width << "x"
      << height << " -framerate " << fps
      << " -i - -c:v libx264 -preset veryfast -crf 20 -pix_fmt yuv420p -movflags +faststart "
      << shell_quoted(partial_) << " 2> " << shell_quoted(log_);
  // A broken pipe must become an error here, not a signal that kills the process.
  std::signal(SIGPIPE, SIG_IGN);
  pipe_ = popen(cmd.str().c_str(), "w");
  if (pipe_ == nullptr) {
    throw sim::Error(path_ + ": cannot start ffmpeg (install the Debian package ffmpeg)");
  }
}

VideoWriter::~VideoWriter() {
  if (pipe_ != nullptr) {
    pclose(pipe_);
    std::remove(partial_.c_str());
    std::remove(log_.c_str());
  }
}

void VideoWriter::add_frame(const std::vector<std::uint8_t>& rgb) {
  const std::size_t size = 3 * static_cast<std::size_t>(width_) * static_cast<std::size_t>(height_);
  if (rgb.size() != size) throw sim::InvalidArgument(path_ + ": frame has the wrong size");
  if (std::fwrite(rgb.data(), 1, size, pipe_) != size) {
    throw sim::Error(path_ + ": ffmpeg stopped taking frames: " + slurp(log_));
  }
}

void VideoWriter::finish() {
  const int status = pclose(pipe_);
  pipe_ = nullptr;
  const std::string log = slurp(log_);
  std::remove(log_.c_str());
  if (status != 0) {
    std::remove(partial_.c_str());
    const bool missing = WIFEXITED(status) && WEXITSTATUS(status) == 127;
    throw sim::Error(path_ + (missing ? ": ffmpeg not found (install the Debian package ffmpeg)"
                                      : ": ffmpeg failed: " + log));
  }
  std::error_code ec;
  std::filesystem::rename(partial_, path_, ec);
  if (ec) {
    std::remove(partial_.c_str());
    throw sim::Error(path_ + ": cannot write the video (" + ec.message() + ")");
  }
}

}  // namespace biodyn::viewer
