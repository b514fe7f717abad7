#pragma once
/// The interactive viewer (`biodyn view`, issue 6): a GLFW window with MuJoCo's renderer and Dear
/// ImGui panels. Physics runs on its own thread; the main thread holds the lock only to copy the
/// scene (and the plot samples), then renders without it (style.md).
///
/// A script (a test hook, and a way to replay a session) drives the same code paths as the
/// panels. One command per line, at a simulated time:
///   at <t> set speed|heading_rate <value>
///   at <t> set weld off|honest|glue
///   at <t> set walker.<field> <value>      (a number of the walker JSON, e.g. pelvis_pitch_rad)
///   at <t> set reaction_time <s>           (every joint group)
///   at <t> set tau_scale <group> <factor>  (that group's tau_max times factor)
///   at <t> push <body> <force N> <direction deg, 0 = heading> <duration s>
///   at <t> save-params <walker.json> <controller.json>
///   at <t> screenshot <file.png>
///   at <t> rewind <seconds back>
///   at <t> quit
/// `#` starts a comment. Errors name the file, the line and the rule.
#include <optional>
#include <string>
#include <vector>

#include "biodyn/scenarios/live.h"

namespace biodyn::viewer {

struct ViewerOptions {
  int width = 1600, height = 900;
  std::string script_path;  ///< optional script (above)
  /// Where the screenshot key/button (F2) and recording (F3) write, as <dir>/biodyn_NNN.png|mp4.
  std::string output_dir = ".";
  bool start_paused = false;
  /// Multisampling of the window: 0 by default (software rendering on a 2-core machine draws
  /// 10 frames/s at 1600x900 without it, 6.5 with 4); 4 looks smoother on a GPU.
  int msaa_samples = 0;
};

/// What a session measured, printed at exit.
struct ViewerStats {
  int frames = 0;
  double wall_s = 0;
  double frames_per_s = 0;
  double simulated_s = 0;
  double physics_steps_per_s = 0;
  double realtime_factor = 0;  ///< simulated / wall while running (not paused)
  int screenshots = 0;
  // The state at the end (what a scripted session is checked on).
  double com_x_m = 0, com_y_m = 0;
  bool fallen = false;
  int pushes = 0;
  std::vector<double> stones_plan_m;                  ///< scenario stones: the plan
  std::vector<scenarios::Stone> stones;               ///< and the stones stepped so far
  scenarios::TrackingReport tracking;                 ///< scenario mocap --track
  std::optional<scenarios::MuscleRunReport> muscles;  ///< --muscles on: the shares so far
};

/// Opens the window and runs until it is closed (or a script says quit). Throws
/// sim::InvalidArgument for a bad script, sim::Error if no window can be opened (no display).
ViewerStats run_viewer(scenarios::ScenarioConfig config, const ViewerOptions& options);

}  // namespace biodyn::viewer
