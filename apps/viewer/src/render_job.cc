// Headless filming of a live scenario (render_job.h).
#include "biodyn/viewer/render_job.h"

#include <chrono>
#include <cmath>
#include <optional>

#include "biodyn/sim/errors.h"
#include "biodyn/sim/renderer.h"
#include "biodyn/viewer/headless_gl.h"
#include "biodyn/viewer/image_output.h"

namespace biodyn::viewer {
namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

}  // namespace

void RenderOptions::validate() const {
  if (!(duration_s > 0) || !std::isfinite(duration_s) || duration_s > 3600) {
    throw sim::InvalidArgument("--duration: must be within (0, 3600] s, got " +
                               std::to_string(duration_s));
  }
  if (!(fps > 0) || fps > 240) {
    throw sim::InvalidArgument("--fps: must be within (0, 240], got " + std::to_string(fps));
  }
  if (width < 16 || height < 16 || width > 4096 || height > 4096 || width % 2 || height % 2) {
    throw sim::InvalidArgument("--size: width and height must be even and within [16, 4096], got " +
                               std::to_string(width) + "x" + std::to_string(height));
  }
  if (video_path.empty() && png_path.empty()) {
    throw sim::InvalidArgument("render: give -o VIDEO.mp4 and/or --png FRAME.png");
  }
}

RenderStats render_scenario(scenarios::LiveScenario* s, const RenderOptions& o,
                            const std::function<void(double)>& progress) {
  o.validate();
  RenderStats st;
  const auto start = Clock::now();
  HeadlessGl gl;
  sim::Simulation& simulation = s->simulation();
  sim::SceneRenderer renderer(simulation.mutable_model(), o.width, o.height);
  renderer.follow(s->rig().pelvis());
  renderer.view().azimuth_deg = o.azimuth_deg;
  renderer.view().elevation_deg = o.elevation_deg;
  renderer.view().distance_m = o.distance_m;
  renderer.view().lookat_W.z() = 0.9;
  muscle_scene_options(*s, o.overlays, &renderer.options());
  std::optional<VideoWriter> video;
  if (!o.video_path.empty()) video.emplace(o.video_path, o.width, o.height, o.fps);

  OverlayBuffers buffers;
  std::vector<sim::OverlayGeom> overlays;
  std::vector<std::uint8_t> rgb, png_rgb;
  std::vector<float> activation, tendon_rgba;
  const double t0 = s->time_s();
  const int frames = static_cast<int>(std::floor(o.duration_s * o.fps + 1e-9)) + 1;
  const double png_at = o.png_time_s < 0 ? t0 + o.duration_s : o.png_time_s;
  bool png_taken = false;
  for (int f = 0; f < frames; ++f) {
    const double t = t0 + f / o.fps;
    auto phase = Clock::now();
    s->run_until(t);
    st.physics_s += seconds_since(phase);
    // Drawn only when filmed or when it is the PNG's frame (a PNG alone costs one frame).
    const bool png_frame =
        !o.png_path.empty() && !png_taken && (t >= png_at - 0.5 / o.fps || f + 1 == frames);
    if (progress) progress(static_cast<double>(f + 1) / frames);
    if (!video && !png_frame) continue;
    phase = Clock::now();
    build_overlays(*s, o.overlays, &buffers, &overlays);
    renderer.update_scene(simulation.model(), simulation.data(), overlays);
    muscle_activations(*s, &activation);
    tendon_colors(*s, activation, &tendon_rgba);
    color_muscles(tendon_rgba, &renderer);
    renderer.render_offscreen(o.width, o.height, &rgb);
    st.render_s += seconds_since(phase);
    if (png_frame) {
      png_rgb = rgb;
      png_taken = true;
    }
    if (video) {
      phase = Clock::now();
      video->add_frame(rgb);
      st.encode_s += seconds_since(phase);
    }
    ++st.frames;
  }
  if (video) {
    const auto phase = Clock::now();
    video->finish();
    st.encode_s += seconds_since(phase);
  }
  if (!o.png_path.empty()) write_png(o.png_path, o.width, o.height, png_rgb);
  st.simulated_s = s->time_s() - t0;
  st.wall_s = seconds_since(start);
  st.fallen = s->fallen();
  return st;
}

}  // namespace biodyn::viewer
