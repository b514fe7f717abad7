#pragma once
/// Options shared by `biodyn view` and `biodyn render`: the scenario and its character and
/// parameters (the same files `biodyn walk --params` and `biodyn pose --params` read).
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "biodyn/scenarios/live.h"
#include "biodyn/scenarios/registry.h"
#include "cli_common.h"

namespace biodyn::apps {

struct ViewOptions {
  std::string scenario = "walk";
  CharacterOptions character;
  double speed_m_s = 1.0;
  double heading_rate_deg_s = 0;
  std::string weld = "honest";
  std::string controller = "torque";   ///< walking: the walker's actuation, torque | velocity
  std::string params_path;             ///< walker parameters (biodyn walk --params)
  std::string controller_params_path;  ///< controller parameters (biodyn pose --params)
  std::string motion_path;             ///< scenario mocap: qpos CSV or BVH
  double motion_from_s = 0, motion_to_s = -1;  ///< scenario mocap: the part played
  bool track = false;                          ///< scenario mocap: tracked by the controllers
  double track_lookahead_s = 0.1;
  bool track_open_loop = false;
  std::string steps;         ///< scenario stones: lengths, m, comma-separated
  std::string step_offsets;  ///< scenario stones: lateral offsets, m, one per length (2D)
  double steps_start_s = 5.0;
  MuscleOptions muscles;                ///< --muscles on|off, --tendons, --muscle-params
  TerrainOptions terrain;               ///< --terrain and its shape (walking scenarios)
  CLI::Option* speed_option = nullptr;  ///< to tell a given --speed from the default
  std::vector<CLI::Option*> only_with_stones, only_with_track,
      only_with_mocap;  ///< refused outside their scenario

  /// Adds --scenario, the character options, --speed, --heading-rate, --weld, --params,
  /// --controller-params, --motion, --motion-from, --motion-to, --track (and its options), --steps,
  /// --step-offsets, --steps-start, --muscles, --tendons, --muscle-params.
  void add_to(CLI::App* cmd);
  /// Reads the files; throws sim::InvalidArgument naming the option or file.
  /// `notes` (optional) receives what the user should know about the body chosen (a motion
  /// CSV is played on the body of its header).
  scenarios::ScenarioConfig to_config(std::vector<std::string>* notes = nullptr) const;
  /// What the results depend on, said in every output: the foot-contact mode, or for the mocap
  /// scenario that it is a kinematic playback; and the legs' muscles when they are on.
  std::string assumption() const;
};

/// scenario mocap --track: the tracking error over the run and the fall (JSON), and one line.
nlohmann::json tracking_json(const scenarios::TrackingReport& r);
std::string tracking_line(const scenarios::TrackingReport& r);  ///< "" when not tracked

/// scenario stones: the plan, the lengths walked so far, their errors and RMS (JSON), and one
/// line for the terminal ("" without a plan). With lateral offsets (2D stones) the JSON has
/// them and the widths planned and walked, and each error is the 2D distance to the stone.
nlohmann::json stones_json(const std::vector<double>& plan_m,
                           const std::vector<scenarios::Stone>& stones,
                           const std::vector<double>& lateral_m = {});
std::string stones_line(const std::vector<double>& plan_m,
                        const std::vector<scenarios::Stone>& stones);

}  // namespace biodyn::apps
