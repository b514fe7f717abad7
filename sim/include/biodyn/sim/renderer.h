#pragma once
/// MuJoCo's renderer for biodyn (system.md: sim/ holds offscreen rendering): a scene, its
/// visual options, a camera and the GPU context, with what the viewer and `biodyn render`
/// share: a camera that follows a body, extra geoms drawn into the scene (arrows, polygons),
/// offscreen rendering read back as top-down RGB.
///
/// An OpenGL context must be current on the calling thread for the lifetime of a
/// SceneRenderer (mjr_makeContext and every render need it); the app creates it (GLFW window,
/// or EGL without a display). update_scene() reads mjData and is the only part that must run
/// under the physics lock; render() then works on the copied scene alone.
#include <mujoco/mujoco.h>

#include <Eigen/Core>
#include <cstdint>
#include <vector>

namespace biodyn::sim {

/// An extra geom drawn with the scene (mjvGeom kinds biodyn uses).
struct OverlayGeom {
  enum class Kind { kArrow, kLine, kSphere, kBox };
  Kind kind = Kind::kLine;
  Eigen::Vector3d from_W = Eigen::Vector3d::Zero();       ///< m; the sphere's or box's centre
  Eigen::Vector3d to_W = Eigen::Vector3d::Zero();         ///< m; unused for spheres and boxes
  double width_m = 0.01;                                  ///< arrow shaft / line width / radius
  Eigen::Vector3d half_size_m = Eigen::Vector3d::Zero();  ///< box: half extents (its frame)
  double yaw_rad = 0;                                     ///< box: turned about z
  float rgba[4] = {1, 1, 1, 1};
  float emission = 0;  ///< 0..1: light of its own (a retro-reflective marker under a ring light)
};

/// Recolours the geoms mjv_updateScene made in `scene` for objects of type `objtype` (e.g.
/// mjOBJ_TENDON: each segment of a spatial tendon's path): the geoms of object i get
/// rgba[4i .. 4i+3] and their radius (size[0], size[1]) times `width_scale`; an object beyond
/// rgba.size() / 4, or given a negative alpha, is left as it is. Extra geoms (OverlayGeom) are
/// left alone. Reads and writes the scene only (no GL).
void recolor_objects(mjtObj objtype, const std::vector<float>& rgba, mjvScene* scene,
                     float width_scale = 1.0f);

/// How the camera frames the scene.
struct CameraView {
  double azimuth_deg = 135;  ///< MuJoCo's free camera angles
  double elevation_deg = -15;
  double distance_m = 3.5;
  Eigen::Vector3d lookat_W = Eigen::Vector3d(0, 0, 1);
};

/// An ideal pinhole camera (square pixels) for pixel-exact offscreen images: a calibrated
/// camera's view. Frame C is OpenCV's (x right, y down, z along the optical axis); pixel
/// (u, v) = (f x/z + cx, f y/z + cy), the top-left pixel's centre at (0, 0).
struct PinholeView {
  Eigen::Vector3d p_WC = Eigen::Vector3d::Zero();      ///< m, optical centre in the world
  Eigen::Matrix3d R_CW = Eigen::Matrix3d::Identity();  ///< rotates world vectors into C
  double f_px = 600, cx_px = 319.5, cy_px = 239.5;     ///< focal length and principal point
  double near_m = 0.05, far_m = 50;                    ///< clipping planes
};

/// How model geoms are drawn.
enum class SceneLook {
  kNormal,  ///< the model's colours, lights, shadows and reflections (viewer, render)
  /// An optical motion-capture camera's view: only the overlays (bright emissive marker
  /// spheres) on black; no model geom, site, shadow, reflection or skybox. What the body hides
  /// is decided by the caller (first_hit_m) before it adds the overlays.
  kOverlaysOnly,
};

class SceneRenderer {
 public:
  /// Makes the scene (room for `max_geoms`) and the GPU context for `model` with an offscreen
  /// buffer of at least width x height (the model's offwidth/offheight are raised to it: MuJoCo
  /// sizes the buffer from them). Needs a current GL context; throws sim::Error otherwise.
  SceneRenderer(mjModel& model, int offscreen_width, int offscreen_height, int max_geoms = 2000);
  ~SceneRenderer();
  SceneRenderer(const SceneRenderer&) = delete;
  SceneRenderer& operator=(const SceneRenderer&) = delete;

  CameraView& view() { return view_; }
  /// The camera's look-at point follows body `body` (its CoM subtree position) when >= 0.
  void follow(int body) { follow_body_ = body; }
  mjvOption& options() { return options_; }

  /// Copies the drawable state of `data` into the scene (mjv_updateScene) and adds the
  /// overlays. Reads `data` only; call it under the physics lock, then render without it.
  void update_scene(const mjModel& model, mjData& data, const std::vector<OverlayGeom>& overlays);
  /// Draws the scene as `look` says from the next update_scene on.
  void set_look(SceneLook look);
  /// Replaces the camera of the scene update_scene made by `view` (its image `width` x
  /// `height` px): render_offscreen at that size then gives the pinhole's exact pixels.
  /// Throws sim::InvalidArgument for a non-positive focal length, size or near plane.
  void use_pinhole(const PinholeView& view, int width, int height);
  /// recolor_objects on the scene update_scene made (before rendering it).
  void recolor(mjtObj objtype, const std::vector<float>& rgba, float width_scale = 1.0f) {
    recolor_objects(objtype, rgba, &scene_, width_scale);
  }

  /// Renders the scene into the window's back buffer (viewport width x height).
  void render_to_window(int width, int height);
  /// Renders offscreen and reads back width x height RGB, rows top to bottom (MuJoCo reads
  /// bottom-up; flipped here). `rgb` is resized to 3 w h.
  void render_offscreen(int width, int height, std::vector<std::uint8_t>* rgb);

  /// Reads back what render_to_window drew (width x height RGB, top-down): screenshots and
  /// recordings of the viewer, without its panels.
  void read_window(int width, int height, std::vector<std::uint8_t>* rgb);

  const mjvScene& scene() const { return scene_; }

 private:
  void add_overlays(const std::vector<OverlayGeom>& overlays);
  void read_pixels(int width, int height, std::vector<std::uint8_t>* rgb);

  mjvScene scene_;
  mjvOption options_;
  mjvCamera camera_;
  mjrContext context_;
  CameraView view_;
  int follow_body_ = -1;
  SceneLook look_ = SceneLook::kNormal;
  std::vector<std::uint8_t> flip_;  // one row, reused
};

}  // namespace biodyn::sim
