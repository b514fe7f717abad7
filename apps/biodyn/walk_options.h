#pragma once
/// Options shared by `biodyn walk`, `push` and `push-sweep`, and the walk JSON.

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <ostream>
#include <string>

#include "biodyn/models/mjcf.h"
#include "biodyn/scenarios/motion_recorder.h"
#include "biodyn/scenarios/walk.h"
#include "cli_common.h"

namespace biodyn::apps {

struct WalkOptions {
  CharacterOptions character;
  double speed_m_s = 1.0;
  double heading_rate_deg_s = 0;
  std::string weld = "honest";
  std::string controller = "torque";  ///< the walker's actuation: torque | velocity
  double reaction_time_s = 0;
  std::string params_path;
  std::string controller_params_path;
  /// s, physics timestep. 2 ms is the default of every biodyn model; 3 ms walks the same
  /// (controllers/README.md, "Timestep and speed") at 1.5x the speed.
  double timestep_s = 0.002;
  TerrainOptions terrain;
  MuscleOptions muscles;

  /// Adds the character options and --speed --heading-rate --weld --controller --reaction-time
  /// --params
  /// --controller-params --timestep --muscles --tendons --muscle-params.
  void add_to(CLI::App* cmd);
  /// The model's physics options for --timestep.
  /// Throws sim::InvalidArgument.
  models::PhysicsOptions physics() const;
  /// The run parameters (reads the params file). Throws sim::InvalidArgument.
  scenarios::WalkRunParams to_params() const;
  nlohmann::json inputs_json(const models::CharacterSpec& spec) const;
  /// These options as `biodyn walk` arguments (without --speed): to replay one run of a batch
  /// alone.
  std::string replay_args() const;
};

/// Builds the character's simulation and runs the walk with a progress bar labelled `label`; the
/// trace (if `with_trace`) comes back in `trace`, the motion (if `recording`, at `record_hz`)
/// in `recording`.
scenarios::WalkRunResult run_walk_on(const models::CharacterSpec& spec,
                                     const models::PhysicsOptions& physics,
                                     scenarios::WalkRunParams p, bool with_trace,
                                     const std::string& label, std::string* trace,
                                     scenarios::RecordedMotion* recording = nullptr,
                                     double record_hz = 100);

/// `biodyn walk --motion-out`'s ground-force file beside the motion: <stem>.grf.csv.
std::string ground_force_path(const std::string& motion_path);

/// What a result depends on in each foot-contact mode, said in every output.
std::string weld_assumption(const std::string& weld);
/// The walk JSON (field names of the issue: fallen, distance, mean_speed, ...).
nlohmann::json walk_json(const scenarios::WalkRunResult& r);
/// A few lines a person reads.
void print_walk_summary(const scenarios::WalkRunResult& r, std::ostream& out);

}  // namespace biodyn::apps
