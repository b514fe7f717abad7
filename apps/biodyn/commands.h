#pragma once
/// Subcommand registration: each add_*_command creates its CLI11 subcommand and returns it with
/// the callback that runs it.

#include <CLI/CLI.hpp>
#include <functional>

namespace biodyn::apps {

/// A registered subcommand; `run()` returns the process exit code.
struct Command {
  CLI::App* cli = nullptr;
  std::function<int()> run;
};

/// `biodyn model`: write a character's MJCF (and summary JSON).
Command add_model_command(CLI::App* app);
/// `biodyn drop`: zero-torque drop of a character (the main job until walking lands).
Command add_drop_command(CLI::App* app);
/// `biodyn pose`: stand, squat, reach or one-leg balance under the joint controllers.
Command add_pose_command(CLI::App* app);
/// `biodyn stand-push`: largest standing push survived, per direction and weld mode.
Command add_stand_push_command(CLI::App* app);
/// `biodyn walk`: walk headless under the torque walker.
Command add_walk_command(CLI::App* app);
/// `biodyn push`: one push during steady walking.
Command add_push_command(CLI::App* app);
/// `biodyn push-sweep`: the push protocol during walking, on all cores.
Command add_push_sweep_command(CLI::App* app);
/// `biodyn gait`: a walk's gait beside normative walking and captured walks.
Command add_gait_command(CLI::App* app);
/// `biodyn walk-search`: the torque walker's parameters searched against human gait.
Command add_walk_search_command(CLI::App* app);
Command add_stones_sweep_command(CLI::App* app);
/// `biodyn walk-sweep`: walks from standing on seeded random bodies.
Command add_walk_sweep_command(CLI::App* app);
/// `biodyn bench`: controller cost against the bare physics step.
Command add_bench_command(CLI::App* app);
/// `biodyn mocap info|convert|ik|retarget|id`: capture files in, marker IK, retargeting,
/// inverse dynamics.
Command add_mocap_command(CLI::App* app);
/// `biodyn evaluate`: a motion on a list of bodies (cmd_evaluate.cc).
Command add_evaluate_command(CLI::App* app);

/// `biodyn muscles curves`: the Hill curves, and one muscle's isometric force-angle curve.
Command add_muscles_command(CLI::App* app);

/// `biodyn capture synth|run`: optical marker capture (cmd_capture.cc).
Command add_capture_command(CLI::App* app);

/// `biodyn render`: a scenario filmed headless (MP4, PNG).
Command add_render_command(CLI::App* app);
/// `biodyn view`: the interactive viewer.
Command add_view_command(CLI::App* app);

/// Exit codes shared by every subcommand.
inline constexpr int kExitOk = 0;
inline constexpr int kExitFailure = 1;   ///< the job ran and failed (e.g. MuJoCo warnings)
inline constexpr int kExitBadInput = 2;  ///< bad option, file or value: nothing was written

}  // namespace biodyn::apps
