#pragma once
/// A calibrated camera: pinhole intrinsics, Brown–Conrady lens distortion (OpenCV's five
/// coefficients k1 k2 p1 p2 k3) and its pose in the lab (world) frame; a rig is a list of them,
/// read and written as JSON in metres.
///
/// Frames: world W is the lab (z up, metres); camera C is OpenCV's (x right, y down, z along the
/// optical axis). Pixels: (u, v) with the centre of the top-left pixel at (0, 0) (OpenCV).

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <string>
#include <vector>

namespace biodyn::capture {

/// Pinhole intrinsics and lens distortion of one camera.
struct Intrinsics {
  int width_px = 656, height_px = 491;  ///< image size (the thesis's cameras: 656 x 491)
  double fx_px = 600, fy_px = 600;      ///< focal lengths, px
  double cx_px = 327.5, cy_px = 245;    ///< principal point, px
  /// Brown–Conrady distortion, OpenCV's order: radial k1, k2, tangential p1, p2, radial k3.
  double k1 = 0, k2 = 0, p1 = 0, p2 = 0, k3 = 0;
  void validate(const std::string& where) const;  ///< throws sim::InvalidArgument naming `where`
  /// fx fy cx cy k1 k2 p1 p2 k3 into `k` (kLensParams values); from_array is its inverse.
  void to_array(double* k) const;
  void from_array(const double* k);
};

/// Number of lens parameters (Intrinsics::to_array): fx fy cx cy k1 k2 p1 p2 k3.
inline constexpr int kLensParams = 9;

/// Applies the lens `k` (kLensParams values, Intrinsics::to_array's order) to the normalised
/// image point (x, y) = (X/Z, Y/Z) and returns pixels. A template so that Ceres can
/// differentiate it (bundle adjustment).
template <typename T>
void distort_to_pixels(const T* k, const T& x, const T& y, T* u, T* v) {
  const T r2 = x * x + y * y;
  const T radial = T(1) + r2 * (k[4] + r2 * (k[5] + r2 * k[8]));
  const T xd = x * radial + T(2) * k[6] * x * y + k[7] * (r2 + T(2) * x * x);
  const T yd = y * radial + k[6] * (r2 + T(2) * y * y) + T(2) * k[7] * x * y;
  *u = k[0] * xd + k[2];
  *v = k[1] * yd + k[3];
}

/// One camera of a rig.
struct Camera {
  std::string name;  ///< e.g. "cam01"; names a folder of images in a capture
  Intrinsics K;
  Eigen::Matrix3d R_CW = Eigen::Matrix3d::Identity();  ///< rotates world vectors into C
  Eigen::Vector3d p_WC = Eigen::Vector3d::Zero();      ///< m, the optical centre in W
  double fps = 100;  ///< frames per second the camera records (> 0)

  /// m, the point `p_W` in the camera frame.
  Eigen::Vector3d to_camera(const Eigen::Vector3d& p_W) const { return R_CW * (p_W - p_WC); }
  /// Pixels of world point `p_W` through the lens (distortion applied). The point must be in
  /// front of the camera (z > 0 in C); `in_front` says whether it is.
  Eigen::Vector2d project(const Eigen::Vector3d& p_W, bool* in_front = nullptr) const;
  /// Pixels of `p_W` through an ideal lens (no distortion).
  Eigen::Vector2d project_pinhole(const Eigen::Vector3d& p_W) const;
  /// The normalised image point (X/Z, Y/Z) a distorted pixel comes from: the inverse of the
  /// lens model by fixed-point iteration (as OpenCV's undistortPoints), to 1e-9 of a pixel.
  Eigen::Vector2d undistort(const Eigen::Vector2d& uv_px) const;
  /// Unit direction, in W, of the ray through distorted pixel `uv_px`.
  Eigen::Vector3d ray_W(const Eigen::Vector2d& uv_px) const;
  /// 3 x 4 projection matrix K [R | t] of the ideal pinhole (pixels from homogeneous world
  /// points): for triangulation and epipolar geometry on undistorted points.
  Eigen::Matrix<double, 3, 4> projection_matrix() const;
  /// Whether pixel (u, v) lies inside the image (pixel centres 0 .. size - 1, half a pixel
  /// margin to each edge).
  bool in_image(const Eigen::Vector2d& uv_px) const;
};

/// Cameras looking at one capture volume, with what their calibration achieved.
struct Rig {
  std::vector<Camera> cameras;
  /// px, RMS reprojection error of the calibration per camera (empty: not calibrated by us,
  /// e.g. a synthetic rig's true values).
  std::vector<double> reprojection_rms_px;
  std::string source;  ///< how it was made ("synthetic truth", "wand calibration", ...)

  int size() const { return static_cast<int>(cameras.size()); }
  /// Index of camera `name`, or -1.
  int find(const std::string& name) const;
};

/// The rig as JSON text (metres, pixels; R_CW row by row).
std::string format_rig_json(const Rig& rig);
/// Parses a rig; `source` names the file in errors. Throws sim::InvalidArgument naming the file,
/// the field (cameras[2].fx_px, ...), the rule and the value: malformed JSON, a missing field,
/// a non-positive size, focal length or fps, a rotation that is not orthonormal (1e-6), a
/// duplicate camera name.
Rig parse_rig_json(const std::string& text, const std::string& source);
Rig read_rig(const std::string& path);                    ///< parse_rig_json of the file
void write_rig(const std::string& path, const Rig& rig);  ///< whole or not at all

/// The rotation R_CW of a camera at `p_WC` looking at `target_W`, the image's up as close to
/// world +z as the view allows (OpenCV's y down: image up is -y). Throws sim::InvalidArgument if
/// the camera looks straight up or down (up is then undefined) or target == centre.
Eigen::Matrix3d look_at(const Eigen::Vector3d& p_WC, const Eigen::Vector3d& target_W);

}  // namespace biodyn::capture
