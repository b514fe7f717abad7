#pragma once
/// `biodyn render`: a live scenario run for a while and filmed offscreen (issue 6, headless
/// use): MP4 through ffmpeg and/or one PNG frame, the camera following the pelvis.
#include <functional>
#include <string>

#include "biodyn/scenarios/live.h"
#include "biodyn/viewer/overlays.h"

namespace biodyn::viewer {

struct RenderOptions {
  double duration_s = 10;  ///< s of simulated time
  double fps = 30;         ///< video frames per simulated second
  int width = 1280, height = 720;
  std::string video_path;  ///< MP4 to write (empty: none)
  std::string png_path;    ///< PNG to write (empty: none)
  double png_time_s = -1;  ///< s, simulated time of the PNG frame (< 0: the last frame)
  /// Camera: a side view from the character's left-front (it walks along +x), following the
  /// pelvis.
  double azimuth_deg = 110, elevation_deg = -10, distance_m = 4.0;
  OverlayOptions overlays;
  void validate() const;  ///< throws sim::InvalidArgument naming the field
};

struct RenderStats {
  int frames = 0;  ///< frames drawn (the video's, or the PNG's one)
  double simulated_s = 0;
  double wall_s = 0;
  double physics_s = 0;  ///< wall time stepping
  double render_s = 0;   ///< wall time rendering and reading back
  double encode_s = 0;   ///< wall time handing frames to ffmpeg
  bool fallen = false;
};

/// Runs `scenario` from its current state for options.duration_s, rendering a frame every
/// 1/fps simulated seconds (a headless GL context is made here). `progress` gets the fraction.
RenderStats render_scenario(scenarios::LiveScenario* scenario, const RenderOptions& options,
                            const std::function<void(double)>& progress = {});

}  // namespace biodyn::viewer
