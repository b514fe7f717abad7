// MuJoCo's scene and GPU context (renderer.h).
#include "biodyn/sim/renderer.h"

#include <cmath>

#include <algorithm>
#include <cstring>

#include "biodyn/sim/errors.h"

namespace biodyn::sim {

void recolor_objects(mjtObj objtype, const std::vector<float>& rgba, mjvScene* scene,
                     float width_scale) {
  const int objects = static_cast<int>(rgba.size() / 4);
  for (int i = 0; i < scene->ngeom; ++i) {
    mjvGeom& g = scene->geoms[i];
    if (g.objtype != objtype || g.category == mjCAT_DECOR || g.objid < 0 || g.objid >= objects)
      continue;
    const float* c = rgba.data() + 4 * static_cast<std::size_t>(g.objid);
    if (c[3] < 0) continue;
    std::copy(c, c + 4, g.rgba);
    g.size[0] *= width_scale;
    g.size[1] *= width_scale;
  }
}

SceneRenderer::SceneRenderer(mjModel& model, int offscreen_width, int offscreen_height,
                             int max_geoms) {
  if (offscreen_width < 1 || offscreen_height < 1) {
    throw InvalidArgument("renderer: offscreen size must be positive, got " +
                          std::to_string(offscreen_width) + " x " +
                          std::to_string(offscreen_height));
  }
  // mjr_makeContext sizes the offscreen buffer from the model's visual settings (2.2.2).
  model.vis.global.offwidth = std::max(model.vis.global.offwidth, offscreen_width);
  model.vis.global.offheight = std::max(model.vis.global.offheight, offscreen_height);
  mjv_defaultScene(&scene_);
  mjv_defaultOption(&options_);
  mjv_defaultCamera(&camera_);
  mjr_defaultContext(&context_);
  mjv_makeScene(&model, &scene_, max_geoms);
  mjr_makeContext(&model, &context_, mjFONTSCALE_100);
  if (context_.offWidth < offscreen_width || context_.offHeight < offscreen_height) {
    mjr_freeContext(&context_);
    mjv_freeScene(&scene_);
    throw Error("renderer: the GL context gave an offscreen buffer of " +
                std::to_string(context_.offWidth) + " x " + std::to_string(context_.offHeight) +
                ", not the " + std::to_string(offscreen_width) + " x " +
                std::to_string(offscreen_height) + " asked for");
  }
  camera_.type = mjCAMERA_FREE;
}

SceneRenderer::~SceneRenderer() {
  mjr_freeContext(&context_);
  mjv_freeScene(&scene_);
}

void SceneRenderer::update_scene(const mjModel& model, mjData& data,
                                 const std::vector<OverlayGeom>& overlays) {
  if (follow_body_ >= 0 && follow_body_ < model.nbody) {
    // The followed body's subtree CoM, at a steady height: the view does not bob with the gait.
    view_.lookat_W.x() = data.subtree_com[3 * follow_body_];
    view_.lookat_W.y() = data.subtree_com[3 * follow_body_ + 1];
  }
  camera_.azimuth = view_.azimuth_deg;
  camera_.elevation = view_.elevation_deg;
  camera_.distance = view_.distance_m;
  for (int k = 0; k < 3; ++k) camera_.lookat[k] = view_.lookat_W[k];
  mjv_updateScene(&model, &data, &options_, nullptr, &camera_, mjCAT_ALL, &scene_);
  if (look_ == SceneLook::kOverlaysOnly) scene_.ngeom = 0;
  add_overlays(overlays);
}

void SceneRenderer::set_look(SceneLook look) {
  look_ = look;
  const mjtByte normal = look == SceneLook::kNormal ? 1 : 0;
  scene_.flags[mjRND_SHADOW] = normal;
  scene_.flags[mjRND_REFLECTION] = normal;
  scene_.flags[mjRND_SKYBOX] = normal;
  for (int g = 0; g < mjNGROUP; ++g) options_.sitegroup[g] = normal && g < 3 ? 1 : 0;
}

void SceneRenderer::use_pinhole(const PinholeView& v, int width, int height) {
  if (!(v.f_px > 0) || width < 1 || height < 1 || !(v.near_m > 0) || !(v.far_m > v.near_m)) {
    throw InvalidArgument(
        "renderer: a pinhole needs f > 0, a positive size and 0 < near < far;"
        " got f " +
        std::to_string(v.f_px) + " px, " + std::to_string(width) + " x " + std::to_string(height) +
        ", near " + std::to_string(v.near_m) + " m");
  }
  // glFrustum at the near plane n (mjr_render, 2.2.2): rows span [bottom, top], columns
  // [center - hw, center + hw] with hw = (top - bottom) W / (2 H). Matching u = f x/z + cx with
  // pixel centres at integers: top - bottom = H n / f, center = (W/2 - 1/2 - cx) n / f,
  // top + bottom = (cy - H/2 + 1/2) 2 n / f (OpenCV's y is down, GL's up).
  const double n = v.near_m, span = height * n / v.f_px;
  const double center = (0.5 * width - 0.5 - v.cx_px) * n / v.f_px;
  const double sum = (v.cy_px - 0.5 * height + 0.5) * 2 * n / v.f_px;
  for (mjvGLCamera& c : scene_.camera) {
    for (int k = 0; k < 3; ++k) {
      c.pos[k] = static_cast<float>(v.p_WC[k]);
      c.forward[k] = static_cast<float>(v.R_CW(2, k));
      c.up[k] = static_cast<float>(-v.R_CW(1, k));
    }
    c.frustum_center = static_cast<float>(center);
    c.frustum_top = static_cast<float>(0.5 * (sum + span));
    c.frustum_bottom = static_cast<float>(0.5 * (sum - span));
    c.frustum_near = static_cast<float>(n);
    c.frustum_far = static_cast<float>(v.far_m);
  }
}

void SceneRenderer::add_overlays(const std::vector<OverlayGeom>& overlays) {
  for (const OverlayGeom& o : overlays) {
    if (scene_.ngeom >= scene_.maxgeom) return;  // a full scene drops overlays, never writes past
    mjvGeom* g = scene_.geoms + scene_.ngeom;
    const mjtNum zero3[3] = {0, 0, 0};
    const mjtNum from[3] = {o.from_W.x(), o.from_W.y(), o.from_W.z()};
    const mjtNum to[3] = {o.to_W.x(), o.to_W.y(), o.to_W.z()};
    switch (o.kind) {
      case OverlayGeom::Kind::kSphere: {
        const mjtNum size[3] = {o.width_m, o.width_m, o.width_m};
        mjv_initGeom(g, mjGEOM_SPHERE, size, from, nullptr, o.rgba);
        break;
      }
      case OverlayGeom::Kind::kBox: {
        const mjtNum size[3] = {o.half_size_m.x(), o.half_size_m.y(), o.half_size_m.z()};
        const mjtNum c = std::cos(o.yaw_rad), s = std::sin(o.yaw_rad);
        const mjtNum mat[9] = {c, -s, 0, s, c, 0, 0, 0, 1};
        mjv_initGeom(g, mjGEOM_BOX, size, from, mat, o.rgba);
        break;
      }
      case OverlayGeom::Kind::kArrow:
        mjv_initGeom(g, mjGEOM_ARROW, zero3, zero3, nullptr, o.rgba);
        mjv_makeConnector(g, mjGEOM_ARROW, o.width_m, from[0], from[1], from[2], to[0], to[1],
                          to[2]);
        break;
      case OverlayGeom::Kind::kLine:
        mjv_initGeom(g, mjGEOM_CAPSULE, zero3, zero3, nullptr, o.rgba);
        mjv_makeConnector(g, mjGEOM_CAPSULE, o.width_m, from[0], from[1], from[2], to[0], to[1],
                          to[2]);
        break;
    }
    g->category = mjCAT_DECOR;
    g->emission = o.emission;
    ++scene_.ngeom;
  }
}

void SceneRenderer::render_to_window(int width, int height) {
  mjr_setBuffer(mjFB_WINDOW, &context_);
  const mjrRect viewport = {0, 0, width, height};
  mjr_render(viewport, &scene_, &context_);
}

void SceneRenderer::render_offscreen(int width, int height, std::vector<std::uint8_t>* rgb) {
  if (width > context_.offWidth || height > context_.offHeight) {
    throw InvalidArgument("renderer: " + std::to_string(width) + " x " + std::to_string(height) +
                          " exceeds the offscreen buffer " + std::to_string(context_.offWidth) +
                          " x " + std::to_string(context_.offHeight));
  }
  mjr_setBuffer(mjFB_OFFSCREEN, &context_);
  const mjrRect viewport = {0, 0, width, height};
  mjr_render(viewport, &scene_, &context_);
  read_pixels(width, height, rgb);
}

void SceneRenderer::read_window(int width, int height, std::vector<std::uint8_t>* rgb) {
  mjr_setBuffer(mjFB_WINDOW, &context_);
  read_pixels(width, height, rgb);
}

void SceneRenderer::read_pixels(int width, int height, std::vector<std::uint8_t>* rgb) {
  const mjrRect viewport = {0, 0, width, height};
  const std::size_t row = 3 * static_cast<std::size_t>(width);
  rgb->resize(row * static_cast<std::size_t>(height));
  mjr_readPixels(rgb->data(), nullptr, viewport, &context_);
  // MuJoCo reads bottom-up (mujoco-2.2.2.md); images are top-down.
  flip_.resize(row);
  for (int y = 0; y < height / 2; ++y) {
    std::uint8_t* a = rgb->data() + row * static_cast<std::size_t>(y);
    std::uint8_t* b = rgb->data() + row * static_cast<std::size_t>(height - 1 - y);
    std::memcpy(flip_.data(), a, row);
    std::memcpy(a, b, row);
    std::memcpy(b, flip_.data(), row);
  }
}

}  // namespace biodyn::sim
