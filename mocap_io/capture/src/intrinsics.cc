// Lens calibration from a checkerboard (intrinsics.h).
#include "biodyn/capture/intrinsics.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>

#include "biodyn/sim/errors.h"
#include "biodyn/sim/random.h"

namespace biodyn::capture {
namespace {

constexpr double kWhite = 220, kBlack = 30, kRoom = 15;  // grey levels
constexpr int kSamples = 2;                              // per pixel and axis

}  // namespace

void Checkerboard::validate() const {
  if (cols < 3 || rows < 3 || cols > 50 || rows > 50)
    throw sim::InvalidArgument("checkerboard: 3 .. 50 inner corners each way, got " +
                               std::to_string(cols) + " x " + std::to_string(rows));
  if (!(square_m > 0.001 && square_m < 1))
    throw sim::InvalidArgument("checkerboard: square side 0.001 .. 1 m, got " +
                               std::to_string(square_m));
}

std::vector<cv::Point3f> Checkerboard::corners_B() const {
  std::vector<cv::Point3f> out;
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c)
      out.emplace_back(static_cast<float>(c * square_m), static_cast<float>(r * square_m), 0.f);
  return out;
}

std::vector<Eigen::Isometry3d> board_poses(const Camera& camera, const Checkerboard& board,
                                           int views, std::uint64_t seed) {
  board.validate();
  std::vector<Eigen::Isometry3d> poses;
  const std::vector<cv::Point3f> corners = board.corners_B();
  const Eigen::Vector3d centre_B(0.5 * (board.cols - 1) * board.square_m,
                                 0.5 * (board.rows - 1) * board.square_m, 0);
  const Eigen::Matrix3d R_WC = camera.R_CW.transpose();
  for (std::uint64_t attempt = 0; static_cast<int>(poses.size()) < views; ++attempt) {
    if (attempt > 1000 * static_cast<std::uint64_t>(views))
      throw sim::InvalidArgument("checkerboard: the board does not fit this camera's image");
    sim::RandomStream r(sim::stream_key(seed, {static_cast<int>(attempt)}));
    // In the camera frame: the board's centre on a random ray through the image, facing the
    // camera (its z towards it), tilted and turned.
    const Eigen::Vector2d uv(camera.K.width_px * r.uniform(), camera.K.height_px * r.uniform());
    const Eigen::Vector2d xy = camera.undistort(uv);
    const double depth = 0.45 + 0.95 * r.uniform();
    const Eigen::Vector3d centre_C = depth * Eigen::Vector3d(xy.x(), xy.y(), 1.0);
    const double tilt = 55.0 * M_PI / 180;
    const Eigen::Matrix3d R_CB =
        (Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()) *  // board z towards the camera
         Eigen::AngleAxisd(tilt * (2 * r.uniform() - 1), Eigen::Vector3d::UnitX()) *
         Eigen::AngleAxisd(tilt * (2 * r.uniform() - 1), Eigen::Vector3d::UnitY()) *
         Eigen::AngleAxisd(0.3 * (2 * r.uniform() - 1), Eigen::Vector3d::UnitZ()))
            .toRotationMatrix();
    Eigen::Isometry3d board_W = Eigen::Isometry3d::Identity();
    board_W.linear() = R_WC * R_CB;
    board_W.translation() = camera.p_WC + R_WC * (centre_C - R_CB * centre_B);
    bool inside = true;
    for (const cv::Point3f& c : corners) {
      bool in_front = false;
      const Eigen::Vector2d p = camera.project(board_W * Eigen::Vector3d(c.x, c.y, c.z), &in_front);
      inside = inside && in_front && p.x() > 10 && p.y() > 10 && p.x() < camera.K.width_px - 11 &&
               p.y() < camera.K.height_px - 11;
    }
    if (inside) poses.push_back(board_W);
  }
  return poses;
}

BoardCamera::BoardCamera(const Camera& camera) : camera_(camera) {
  const int w = camera.K.width_px, h = camera.K.height_px;
  rays_.reserve(static_cast<std::size_t>(w) * static_cast<std::size_t>(h) * kSamples * kSamples);
  for (int v = 0; v < h; ++v)
    for (int u = 0; u < w; ++u)
      for (int sv = 0; sv < kSamples; ++sv)
        for (int su = 0; su < kSamples; ++su)
          rays_.push_back(camera.undistort(
              Eigen::Vector2d(u + (su + 0.5) / kSamples - 0.5, v + (sv + 0.5) / kSamples - 0.5)));
}

cv::Mat BoardCamera::film(const Checkerboard& board, const Eigen::Isometry3d& board_W,
                          double noise_grey, std::uint64_t seed) const {
  const int w = camera_.K.width_px, h = camera_.K.height_px;
  cv::Mat image(h, w, CV_8UC1);
  const Eigen::Isometry3d W_to_B = board_W.inverse();
  const Eigen::Vector3d origin_B = W_to_B * camera_.p_WC;
  const Eigen::Matrix3d R_BC = W_to_B.linear() * camera_.R_CW.transpose();
  // The board's printed area: the squares plus one square of white margin around them.
  const double s = board.square_m;
  const double x0 = -2 * s, x1 = (board.cols + 1) * s, y0 = -2 * s, y1 = (board.rows + 1) * s;
  sim::RandomStream noise(sim::stream_key(seed, {0x600d}));
  std::size_t sample = 0;
  for (int v = 0; v < h; ++v) {
    auto* row = image.ptr<std::uint8_t>(v);
    for (int u = 0; u < w; ++u) {
      double sum = 0;
      for (int k = 0; k < kSamples * kSamples; ++k) {
        const Eigen::Vector2d& xy = rays_[sample++];
        const Eigen::Vector3d ray_B = R_BC * Eigen::Vector3d(xy.x(), xy.y(), 1.0);
        double grey = kRoom;
        if (std::abs(ray_B.z()) > 1e-12) {
          const double t = -origin_B.z() / ray_B.z();
          const Eigen::Vector3d p = origin_B + t * ray_B;
          if (t > 0 && p.x() > x0 && p.x() < x1 && p.y() > y0 && p.y() < y1) {
            // Squares between the corners' rows and columns -1 .. cols; the margin white.
            const int i = static_cast<int>(std::floor(p.x() / s)) + 1;
            const int j = static_cast<int>(std::floor(p.y() / s)) + 1;
            const bool margin = i < 0 || j < 0 || i > board.cols || j > board.rows;
            grey = margin || (i + j) % 2 == 1 ? kWhite : kBlack;
          }
        }
        sum += grey;
      }
      const double value = sum / (kSamples * kSamples) + noise_grey * noise.normal();
      row[u] = static_cast<std::uint8_t>(std::clamp(std::lround(value), 0L, 255L));
    }
  }
  return image;
}

LensFit calibrate_lens(const std::vector<cv::Mat>& images, const Checkerboard& board) {
  board.validate();
  const cv::Size pattern(board.cols, board.rows);
  std::vector<std::vector<cv::Point2f>> found;
  std::vector<std::vector<cv::Point3f>> object;
  cv::Size size;
  for (const cv::Mat& image : images) {
    if (size.empty()) size = image.size();
    if (image.size() != size || image.type() != CV_8UC1)
      throw sim::InvalidArgument("checkerboard: every image must be 8-bit grey of one size");
    std::vector<cv::Point2f> corners;
    if (!cv::findChessboardCorners(image, pattern, corners,
                                   cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE))
      continue;
    cv::cornerSubPix(image, corners, cv::Size(5, 5), cv::Size(-1, -1),
                     cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 100, 1e-4));
    found.push_back(corners);
    object.push_back(board.corners_B());
  }
  if (found.size() < 5)
    throw sim::InvalidArgument("checkerboard: the whole board was found in " +
                               std::to_string(found.size()) + " of " +
                               std::to_string(images.size()) + " images; 5 are needed");
  cv::Mat K, dist;
  std::vector<cv::Mat> rvecs, tvecs;
  LensFit fit;
  fit.rms_px = cv::calibrateCamera(object, found, size, K, dist, rvecs, tvecs, cv::CALIB_FIX_K3);
  fit.views_used = static_cast<int>(found.size());
  fit.lens.width_px = size.width;
  fit.lens.height_px = size.height;
  fit.lens.fx_px = K.at<double>(0, 0);
  fit.lens.fy_px = K.at<double>(1, 1);
  fit.lens.cx_px = K.at<double>(0, 2);
  fit.lens.cy_px = K.at<double>(1, 2);
  fit.lens.k1 = dist.at<double>(0);
  fit.lens.k2 = dist.at<double>(1);
  fit.lens.p1 = dist.at<double>(2);
  fit.lens.p2 = dist.at<double>(3);
  fit.lens.k3 = 0;
  return fit;
}

void film_board_views(const Rig& rig, const Checkerboard& board, int views, double noise_grey,
                      std::uint64_t seed, const std::string& dir) {
  namespace fs = std::filesystem;
  for (int c = 0; c < rig.size(); ++c) {
    const Camera& camera = rig.cameras[static_cast<std::size_t>(c)];
    const fs::path folder = fs::path(dir) / camera.name;
    fs::create_directories(folder);
    const BoardCamera film(camera);
    const auto poses = board_poses(camera, board, views, sim::stream_key(seed, {c}));
    for (int v = 0; v < views; ++v) {
      char name[16];
      std::snprintf(name, sizeof name, "%06d.png", v);
      const cv::Mat image = film.film(board, poses[static_cast<std::size_t>(v)], noise_grey,
                                      sim::stream_key(seed, {c, v}));
      if (!cv::imwrite((folder / name).string(), image))
        throw sim::Error((folder / name).string() + ": cannot write");
    }
  }
}

std::vector<cv::Mat> read_board_views(const std::string& dir, const std::string& camera) {
  namespace fs = std::filesystem;
  const fs::path folder = fs::path(dir) / camera;
  std::vector<fs::path> files;
  if (fs::is_directory(folder))
    for (const auto& e : fs::directory_iterator(folder))
      if (e.path().extension() == ".png") files.push_back(e.path());
  if (files.empty())
    throw sim::InvalidArgument(folder.string() + ": no checkerboard images (.png) for camera " +
                               camera);
  std::sort(files.begin(), files.end());
  std::vector<cv::Mat> images;
  for (const fs::path& f : files) {
    cv::Mat image = cv::imread(f.string(), cv::IMREAD_GRAYSCALE);
    if (image.empty()) throw sim::InvalidArgument(f.string() + ": not an image OpenCV can read");
    images.push_back(image);
  }
  return images;
}

}  // namespace biodyn::capture
