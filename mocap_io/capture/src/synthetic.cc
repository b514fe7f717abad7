// Synthetic optical capture (synthetic.h).
#include "biodyn/capture/synthetic.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>

#include "biodyn/sim/errors.h"
#include "biodyn/sim/queries.h"
#include "biodyn/sim/random.h"
#include "biodyn/sim/renderer.h"

namespace biodyn::capture {
namespace {

// px kept free between the volume's image and the image border (make_synthetic_rig).
constexpr double kVolumeMargin_px = 8;
// The undistorted canvas may be at most this many times the image in each direction (a lens
// whose distortion needs more is refused: its corners would fold over).
constexpr double kMaxCanvasScale = 2.0;
// Sampled points on the volume's cylinder (per ring) when fitting the focal length.
constexpr int kVolumeSamples = 72;

[[noreturn]] void bad(const std::string& field, const std::string& why, double value) {
  throw sim::InvalidArgument("synthetic capture: " + field + ": " + why + ", got " +
                             std::to_string(value));
}

}  // namespace

void SyntheticRigSpec::validate() const {
  if (cameras < 2 || cameras > 64) bad("cameras", "must be 2 .. 64", cameras);
  if (!(distance_m > volume_radius_m + 0.3) || distance_m > 50)
    bad("distance_m", "must exceed the volume's radius by 0.3 m and be at most 50 m", distance_m);
  if (!(height_low_m > 0) || !(height_high_m > 0) || height_low_m > 20 || height_high_m > 20)
    bad("height_low_m/height_high_m", "must be in (0, 20] m",
        std::min(height_low_m, height_high_m));
  if (!(volume_radius_m > 0) || !(volume_top_m > 0))
    bad("volume_radius_m/volume_top_m", "must be positive",
        std::min(volume_radius_m, volume_top_m));
  if (width_px < 16 || height_px < 16 || width_px > 8192 || height_px > 8192)
    bad("width_px/height_px", "must be 16 .. 8192", std::min(width_px, height_px));
  if (!(fps > 0) || fps > 10000) bad("fps", "must be in (0, 10000]", fps);
  for (double k : {k1, k2, p1, p2, k3}) {
    if (!std::isfinite(k) || std::abs(k) > 1) bad("distortion", "must be within +-1", k);
  }
}

Rig make_synthetic_rig(const SyntheticRigSpec& spec) {
  spec.validate();
  Rig rig;
  rig.source = "synthetic truth";
  for (int i = 0; i < spec.cameras; ++i) {
    sim::RandomStream r(sim::stream_key(spec.jitter_seed, {i}));
    const auto jitter = [&](double half) {
      return spec.jitter_seed == 0 ? 0.0 : (2 * r.uniform() - 1) * half;
    };
    const double azimuth = 2 * M_PI * i / spec.cameras + jitter(10 * M_PI / 180);
    const double distance = spec.distance_m + jitter(0.3);
    const double height = (i % 2 == 0 ? spec.height_low_m : spec.height_high_m) + jitter(0.2);
    Camera c;
    char name[16];
    std::snprintf(name, sizeof name, "cam%02d", i + 1);
    c.name = name;
    c.p_WC = spec.target_W +
             Eigen::Vector3d(distance * std::cos(azimuth), distance * std::sin(azimuth), 0);
    c.p_WC.z() = height;
    const Eigen::Vector3d aim =
        spec.target_W + Eigen::Vector3d(jitter(0.2), jitter(0.2), jitter(0.2));
    c.R_CW = look_at(c.p_WC, aim);
    if (spec.portrait) {  // rolled about the optical axis: image right is world up
      const Eigen::Vector3d right = c.R_CW.row(0), down = c.R_CW.row(1);
      c.R_CW.row(0) = -down.transpose();
      c.R_CW.row(1) = right.transpose();
    }
    c.K.width_px = spec.width_px;
    c.K.height_px = spec.height_px;
    c.K.cx_px = 0.5 * spec.width_px - 0.5;
    c.K.cy_px = 0.5 * spec.height_px - 0.5;
    c.K.k1 = spec.k1;
    c.K.k2 = spec.k2;
    c.K.p1 = spec.p1;
    c.K.p2 = spec.p2;
    c.K.k3 = spec.k3;
    c.fps = spec.fps;
    rig.cameras.push_back(c);
  }
  // Each camera's focal length: the largest with which its pinhole image of the volume keeps
  // the margin (a lab picks each camera's zoom to frame the volume; distortion is small at the
  // margin for the default lens: tests check the distorted image).
  const double half_w = 0.5 * spec.width_px - kVolumeMargin_px;
  const double half_h = 0.5 * spec.height_px - kVolumeMargin_px;
  for (Camera& c : rig.cameras) {
    double f = std::numeric_limits<double>::infinity();
    for (int k = 0; k < kVolumeSamples; ++k) {
      const double a = 2 * M_PI * k / kVolumeSamples;
      for (double z : {0.0, spec.volume_top_m}) {
        const Eigen::Vector3d p(spec.target_W.x() + spec.volume_radius_m * std::cos(a),
                                spec.target_W.y() + spec.volume_radius_m * std::sin(a), z);
        const Eigen::Vector3d p_C = c.to_camera(p);
        if (p_C.z() <= 0) bad("distance_m", "puts the volume behind a camera", spec.distance_m);
        const double x = std::abs(p_C.x() / p_C.z()), y = std::abs(p_C.y() / p_C.z());
        if (x > 0) f = std::min(f, half_w / x);
        if (y > 0) f = std::min(f, half_h / y);
      }
    }
    c.K.fx_px = c.K.fy_px = f;
  }
  return rig;
}

std::vector<std::array<Eigen::Vector3d, 3>> wand_wave(const Wand& wand,
                                                      const SyntheticRigSpec& spec, int frames,
                                                      double fps, std::uint64_t seed) {
  wand.validate();
  spec.validate();
  sim::RandomStream r(sim::stream_key(seed, {-7}));
  // Incommensurate frequencies (rad/s) and random phases: the path does not repeat.
  double w[5], phase[5];
  for (int k = 0; k < 5; ++k) {
    w[k] = 0.9 + 1.4 * r.uniform();
    phase[k] = 2 * M_PI * r.uniform();
  }
  const double reach = spec.volume_radius_m;
  const double low = 0.2, high = spec.volume_top_m - 0.2;
  const std::array<double, 3> offsets = wand.offsets_m();
  std::vector<std::array<Eigen::Vector3d, 3>> out(static_cast<std::size_t>(frames));
  for (int f = 0; f < frames; ++f) {
    const double t = f / fps;
    const Eigen::Vector3d mid(
        spec.target_W.x() + reach * std::sin(w[0] * t + phase[0]),
        spec.target_W.y() + reach * std::sin(w[1] * t + phase[1]),
        0.5 * (low + high) + 0.5 * (high - low) * std::sin(w[2] * t + phase[2]));
    const double azimuth = w[3] * t + phase[3], elevation = 1.2 * std::sin(w[4] * t + phase[4]);
    const Eigen::Vector3d d(std::cos(elevation) * std::cos(azimuth),
                            std::cos(elevation) * std::sin(azimuth), std::sin(elevation));
    const Eigen::Vector3d a = mid - 0.5 * wand.ac_m * d;
    for (int m = 0; m < 3; ++m) out[f][m] = a + offsets[m] * d;
  }
  return out;
}

Rig nominal_rig(const Rig& truth, double focal_error, std::uint64_t seed) {
  Rig rig = truth;
  rig.source = "nominal lenses";
  rig.reprojection_rms_px.clear();
  for (int i = 0; i < rig.size(); ++i) {
    Camera& c = rig.cameras[i];
    sim::RandomStream r(sim::stream_key(seed, {-11, i}));
    const double f = c.K.fx_px * (1 + focal_error * r.normal());
    const int w = c.K.width_px, h = c.K.height_px;
    c.K = Intrinsics{};
    c.K.width_px = w;
    c.K.height_px = h;
    c.K.fx_px = c.K.fy_px = f;
    c.K.cx_px = 0.5 * w - 0.5;
    c.K.cy_px = 0.5 * h - 0.5;
    c.R_CW = Eigen::Matrix3d::Identity();
    c.p_WC = Eigen::Vector3d::Zero();
  }
  return rig;
}

void ImageFormation::validate() const {
  if (!(marker_diameter_m > 0) || marker_diameter_m > 0.2)
    bad("marker_diameter_m", "must be in (0, 0.2] m", marker_diameter_m);
  if (!(noise_px >= 0) || noise_px > 20) bad("noise_px", "must be in [0, 20] px", noise_px);
  if (!(sensor_noise_grey >= 0) || sensor_noise_grey > 100)
    bad("sensor_noise_grey", "must be in [0, 100]", sensor_noise_grey);
  if (!(exposure > 0) || exposure > 100) bad("exposure", "must be in (0, 100]", exposure);
}

/// One camera's rendering set-up: the undistorted canvas that covers its distorted image and
/// the map from each distorted pixel to the canvas.
struct CanvasMap {
  int width = 0, height = 0;  ///< px, canvas size
  double cx = 0, cy = 0;      ///< px, the canvas's principal point
  cv::Mat map_x, map_y;       ///< CV_32F, image size: canvas coordinates of each image pixel
};

struct SyntheticCameras::Impl {
  std::vector<int> sites;
  ImageFormation formation;
  std::vector<CanvasMap> canvases;
  std::unique_ptr<sim::SceneRenderer> renderer;
  std::vector<std::uint8_t> rgb;
  std::vector<sim::OverlayGeom> overlays;
  cv::Mat canvas, warped, noise, sensor;
};

namespace {

CanvasMap canvas_for(const Camera& c) {
  const int W = c.K.width_px, H = c.K.height_px;
  CanvasMap m;
  m.map_x.create(H, W, CV_32F);
  m.map_y.create(H, W, CV_32F);
  double lo_u = 0, lo_v = 0, hi_u = W - 1, hi_v = H - 1;
  for (int v = 0; v < H; ++v) {
    for (int u = 0; u < W; ++u) {
      const Eigen::Vector2d x = c.undistort(Eigen::Vector2d(u, v));
      const double pu = c.K.fx_px * x.x() + c.K.cx_px, pv = c.K.fy_px * x.y() + c.K.cy_px;
      m.map_x.at<float>(v, u) = static_cast<float>(pu);
      m.map_y.at<float>(v, u) = static_cast<float>(pv);
      lo_u = std::min(lo_u, pu);
      hi_u = std::max(hi_u, pu);
      lo_v = std::min(lo_v, pv);
      hi_v = std::max(hi_v, pv);
    }
  }
  const double left = std::floor(lo_u) - 2, top = std::floor(lo_v) - 2;
  m.width = static_cast<int>(std::ceil(hi_u) + 3 - left);
  m.height = static_cast<int>(std::ceil(hi_v) + 3 - top);
  if (m.width > kMaxCanvasScale * W || m.height > kMaxCanvasScale * H) {
    throw sim::InvalidArgument("synthetic capture: camera " + c.name +
                               ": its lens distortion folds the image (undistorted canvas " +
                               std::to_string(m.width) + " x " + std::to_string(m.height) + ")");
  }
  m.cx = c.K.cx_px - left;
  m.cy = c.K.cy_px - top;
  m.map_x -= left;
  m.map_y -= top;
  return m;
}

}  // namespace

SyntheticCameras::SyntheticCameras(mjModel& model, Rig rig, std::vector<int> marker_sites,
                                   const ImageFormation& formation)
    : impl_(std::make_unique<Impl>()), rig_(std::move(rig)) {
  formation.validate();
  for (int s : marker_sites) {
    if (s < 0 || s >= model.nsite) bad("marker_sites", "a site id out of the model's range", s);
  }
  for (const Camera& c : rig_.cameras) {
    c.K.validate("synthetic capture: camera " + c.name);
    if (std::abs(c.K.fx_px - c.K.fy_px) > 1e-9 * c.K.fx_px)
      bad("camera " + c.name + " fx_px/fy_px", "the renderer draws square pixels: fx must equal fy",
          c.K.fx_px - c.K.fy_px);
  }
  impl_->sites = std::move(marker_sites);
  impl_->formation = formation;
  int max_w = 1, max_h = 1;
  for (const Camera& c : rig_.cameras) {
    impl_->canvases.push_back(canvas_for(c));
    max_w = std::max(max_w, impl_->canvases.back().width);
    max_h = std::max(max_h, impl_->canvases.back().height);
  }
  impl_->renderer = std::make_unique<sim::SceneRenderer>(
      model, max_w, max_h, static_cast<int>(impl_->sites.size()) + 1000);
  impl_->renderer->set_look(sim::SceneLook::kOverlaysOnly);
}

SyntheticCameras::~SyntheticCameras() = default;

void SyntheticCameras::film(const mjModel& model, mjData& data, int frame,
                            std::vector<cv::Mat>* images,
                            std::vector<std::vector<MarkerView>>* views) {
  site_points_.resize(impl_->sites.size());
  for (std::size_t k = 0; k < impl_->sites.size(); ++k)
    site_points_[k] = Eigen::Vector3d(data.site_xpos + 3 * impl_->sites[k]);
  film_points(model, data, site_points_, frame, images, views);
}

void SyntheticCameras::film_points(const mjModel& model, mjData& data,
                                   const std::vector<Eigen::Vector3d>& points_W, int frame,
                                   std::vector<cv::Mat>* images,
                                   std::vector<std::vector<MarkerView>>* views) {
  Impl& im = *impl_;
  const ImageFormation& fm = im.formation;
  const double radius = 0.5 * fm.marker_diameter_m;
  const int n = static_cast<int>(points_W.size());
  images->resize(rig_.cameras.size());
  views->assign(rig_.cameras.size(), std::vector<MarkerView>(n));
  for (int ci = 0; ci < rig_.size(); ++ci) {
    const Camera& cam = rig_.cameras[ci];
    const CanvasMap& cm = im.canvases[ci];
    im.overlays.clear();
    for (int k = 0; k < n; ++k) {
      const Eigen::Vector3d& p_W = points_W[k];
      bool in_front = false;
      MarkerView& view = (*views)[ci][k];
      view.uv_px = cam.project(p_W, &in_front);
      const double dist = (p_W - cam.p_WC).norm();
      view.visible = in_front && cam.in_image(view.uv_px) &&
                     sim::first_hit_m(model, data, cam.p_WC, p_W) >= dist - radius;
      if (!view.visible) continue;
      // The disc's radius in pixels (the sphere at its depth) plus the detector's border pixel.
      const double r_px = cam.K.fx_px * radius / cam.to_camera(p_W).z() + 1.0;
      view.whole = view.uv_px.x() - r_px >= 0 && view.uv_px.y() - r_px >= 0 &&
                   view.uv_px.x() + r_px <= cam.K.width_px - 1 &&
                   view.uv_px.y() + r_px <= cam.K.height_px - 1;
      // Centroid noise: the sphere moved across the line of sight by noise_px at its depth.
      sim::RandomStream r(sim::stream_key(fm.seed, {frame, ci, k}));
      const double depth = cam.to_camera(p_W).z(), scale = depth / cam.K.fx_px;
      const double du = fm.noise_px * r.normal(), dv = fm.noise_px * r.normal();
      sim::OverlayGeom g;
      g.kind = sim::OverlayGeom::Kind::kSphere;
      g.from_W =
          p_W + scale * (du * cam.R_CW.row(0).transpose() + dv * cam.R_CW.row(1).transpose());
      g.width_m = radius;
      g.emission = 1.0f;
      im.overlays.push_back(g);
    }
    im.renderer->update_scene(model, data, im.overlays);
    sim::PinholeView pin;
    pin.p_WC = cam.p_WC;
    pin.R_CW = cam.R_CW;
    pin.f_px = cam.K.fx_px;
    pin.cx_px = cm.cx;
    pin.cy_px = cm.cy;
    im.renderer->use_pinhole(pin, cm.width, cm.height);
    im.renderer->render_offscreen(cm.width, cm.height, &im.rgb);
    // Grey = the green channel (the markers are white); then the lens, exposure and sensor.
    const cv::Mat rgb(cm.height, cm.width, CV_8UC3, im.rgb.data());
    cv::extractChannel(rgb, im.canvas, 1);
    cv::remap(im.canvas, im.warped, cm.map_x, cm.map_y, cv::INTER_LINEAR, cv::BORDER_CONSTANT, 0);
    im.warped.convertTo(im.noise, CV_32F, fm.exposure);
    if (fm.sensor_noise_grey > 0) {
      im.sensor.create(im.noise.size(), CV_32F);  // reused: no allocation once warm
      cv::RNG rng(sim::stream_key(fm.seed, {frame, ci, -1}));
      rng.fill(im.sensor, cv::RNG::NORMAL, 0.0, fm.sensor_noise_grey);
      im.noise += im.sensor;
    }
    im.noise.convertTo((*images)[ci], CV_8U);  // rounds and saturates to 0..255
  }
}

}  // namespace biodyn::capture
