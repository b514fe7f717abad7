#pragma once
/// Synthetic optical capture: a character playing a motion, its marker sites filmed as
/// retro-reflective spheres on black by N calibrated virtual cameras (MuJoCo's renderer through
/// sim::SceneRenderer, headless), then what a real camera adds applied by us: Brown–Conrady
/// lens distortion, exposure, per-marker centroid noise and sensor noise. Every image comes with
/// its ground truth: each marker's 3D position and, per camera, its distorted pixel and whether
/// the camera sees it (in the image, in front, not hidden by the body).
///
/// The body is not drawn (a real IR camera sees it dark); it hides a marker from a camera when
/// the line of sight to the marker's centre enters a body geom more than one marker radius
/// before the centre (markers sit on the skin surface: models/markers_26.csv), so a marker is
/// either wholly seen or hidden.

#include <mujoco/mujoco.h>

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "biodyn/capture/calibration.h"
#include "biodyn/capture/camera.h"

namespace biodyn::capture {

/// A ring of cameras around a capture volume, as labs mount them.
struct SyntheticRigSpec {
  int cameras = 8;          ///< 2 .. 64 (the issue's rigs: 4 .. 12)
  double distance_m = 3.0;  ///< horizontal distance of each camera from the volume's axis
  /// Camera heights alternate low, high around the ring (a low camera sees under the arms).
  double height_low_m = 1.4, height_high_m = 2.6;
  Eigen::Vector3d target_W = Eigen::Vector3d(0, 0, 0.95);  ///< m, where every camera looks
  /// The volume every camera must see whole: a vertical cylinder about the target's axis.
  double volume_radius_m = 0.5, volume_top_m = 2.05;
  int width_px = 656, height_px = 491;  ///< the thesis's cameras
  /// Cameras rolled 90° so the image's long side is vertical: a standing or walking subject
  /// fills more of the sensor (focal length ~1.6 x the landscape one at 656 x 491).
  bool portrait = true;
  double fps = 100;
  /// Lens distortion of every camera (OpenCV's order); moderate barrel by default.
  double k1 = -0.08, k2 = 0.02, p1 = 0.0005, p2 = -0.0003, k3 = 0;
  /// 0: cameras evenly spaced at the stated heights; otherwise each camera's azimuth (±10°),
  /// distance (±0.3 m) and height (±0.2 m) are drawn from this seed, and its aim (±0.2 m).
  std::uint64_t jitter_seed = 0;
  void validate() const;  ///< throws sim::InvalidArgument naming the field
};

/// The cameras of `spec`: each with the focal length that fits the volume in its image with 8 px
/// to spare (a lab sets each camera's zoom), the principal point at the image centre. Throws
/// sim::InvalidArgument from validate().
Rig make_synthetic_rig(const SyntheticRigSpec& spec);

/// A calibration wand waved through the volume of `spec` for `frames` frames at `fps`: its
/// markers A, B, C per frame (m). The wand's middle follows a smooth seeded path filling the
/// volume (heights 0.2 m to the volume's top less 0.2 m) and turns through every direction.
std::vector<std::array<Eigen::Vector3d, 3>> wand_wave(const Wand& wand,
                                                      const SyntheticRigSpec& spec, int frames,
                                                      double fps, std::uint64_t seed);

/// The lens a lab would start a calibration from: each camera's focal length off by a seeded
/// error of `focal_error` (standard deviation, a fraction: a lens's spec), the principal point
/// at the image centre, no distortion; poses unknown (identity at the origin).
Rig nominal_rig(const Rig& truth, double focal_error, std::uint64_t seed);

/// What the virtual cameras do to the light (applied after rendering).
struct ImageFormation {
  double marker_diameter_m = 0.025;  ///< m; labs use 14-25 mm markers
  double noise_px = 0;               ///< px: standard deviation of each marker's image position,
                                     ///< per camera and frame (the `--noise-px` of the bench)
  double sensor_noise_grey = 1.0;    ///< grey levels (0..255): per-pixel Gaussian noise
  double exposure = 1.0;             ///< gain on brightness (markers render at 255 x exposure)
  std::uint64_t seed = 1;            ///< the noises' random stream
  void validate() const;             ///< throws sim::InvalidArgument naming the field
};

/// One marker seen (or not) by one camera at one frame: the ground truth.
struct MarkerView {
  Eigen::Vector2d uv_px = Eigen::Vector2d::Zero();  ///< distorted pixel of the true centre
  bool visible = false;  ///< in the image, in front of the camera, not hidden by the body
  /// visible, and its whole image (the sphere's disc) inside the frame, clear of the one-pixel
  /// border a blob detector refuses: what a camera can measure a centroid of
  bool whole = false;
};

/// Renders the cameras of a rig. Needs a current OpenGL context for its whole life (the app
/// makes it: viewer::HeadlessGl) and the model whose marker sites it films.
class SyntheticCameras {
 public:
  /// `marker_sites`: site ids of the markers in `model`. Throws sim::InvalidArgument for bad
  /// formation settings or a site id out of range, sim::Error if the GL context is missing.
  SyntheticCameras(mjModel& model, Rig rig, std::vector<int> marker_sites,
                   const ImageFormation& formation);
  ~SyntheticCameras();
  SyntheticCameras(const SyntheticCameras&) = delete;
  SyntheticCameras& operator=(const SyntheticCameras&) = delete;

  const Rig& rig() const { return rig_; }
  /// Films frame `frame` of the pose in `data` (its kinematics computed): one 8-bit grey image
  /// per camera into `images` and the truth per camera and marker into `views`
  /// ([camera][marker]). The noises are keyed by (seed, frame, camera, marker): the same frame
  /// gives the same images whatever was filmed before.
  void film(const mjModel& model, mjData& data, int frame, std::vector<cv::Mat>* images,
            std::vector<std::vector<MarkerView>>* views);
  /// As film(), for markers at `points_W` (m) instead of the model's sites: props such as a
  /// calibration wand. The model's geoms still hide them (an empty model hides nothing).
  void film_points(const mjModel& model, mjData& data, const std::vector<Eigen::Vector3d>& points_W,
                   int frame, std::vector<cv::Mat>* images,
                   std::vector<std::vector<MarkerView>>* views);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::vector<Eigen::Vector3d> site_points_;
  Rig rig_;
};

}  // namespace biodyn::capture
