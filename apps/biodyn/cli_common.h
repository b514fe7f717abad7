#pragma once
/// Pieces shared by the biodyn subcommands: character options, whole-or-nothing output files,
/// the console log sink.

#include <CLI/CLI.hpp>
#include <cstddef>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

#include "biodyn/sim/file_io.h"
#include "biodyn/sim/simulation.h"

#include "biodyn/models/character.h"
#include "biodyn/models/mjcf.h"
#include "biodyn/scenarios/scenario.h"

namespace biodyn::apps {

/// Raw character options as typed on the command line (validated by to_spec()).
struct CharacterOptions {
  double height_m = 1.80;
  double mass_kg = 80.0;
  std::string sex = "male";
  std::string detail = "full";
  std::string overrides_path;  ///< JSON file, optional
  std::string body_path;       ///< body file (models/body_file.h), optional

  /// Adds --height --mass --sex --detail (and --overrides --body-file) to `cmd`.
  void add_to(CLI::App* cmd, bool with_overrides = true);
  /// Builds the spec (reading and name-checking the overrides or body file); generate_character
  /// validates the values. Throws sim::InvalidArgument naming the field and value, or when
  /// --body-file is given with --height, --sex, --detail or --overrides (it fixes those).
  models::CharacterSpec to_spec() const;
  /// The body to use for the motion CSV `motion_path`: the one its header names (the body
  /// `mocap ik` scaled or `mocap retarget` generated) unless the command line gives one; a
  /// given body whose geometry differs from the header's is refused (sim::InvalidArgument
  /// naming both). --mass may differ (joint angles hold on any mass): `notes` says so, and
  /// says when the motion has no header.
  models::CharacterSpec spec_for_motion(const std::string& motion_path,
                                        std::vector<std::string>* notes) const;
  bool geometry_given() const;  ///< --height, --sex, --detail, --overrides or --body-file given

 private:
  std::vector<CLI::Option*> geometry_options_;
  CLI::Option* mass_option_ = nullptr;
};

/// --muscles on|off, --tendons, --muscle-params: the legs' Hill muscles under a scenario's
/// controllers (scenarios::MuscleConfig).
struct MuscleOptions {
  std::string muscles = "off";
  std::string tendons = "default";
  std::string params_path;

  void add_to(CLI::App* cmd);
  /// Throws sim::InvalidArgument naming the option and the value (or the parameter file's
  /// muscle, field and value: the file is checked against the muscles here).
  scenarios::MuscleConfig to_config() const;
};

/// The ground ahead (models::Terrain): --terrain flat|hill|steps, --terrain-slope,
/// --terrain-step, --terrain-start.
struct TerrainOptions {
  std::string kind = "flat";
  models::Terrain shape;
  void add_to(CLI::App* cmd);
  /// Throws sim::InvalidArgument naming the option and the value.
  models::Terrain to_terrain() const;
  /// ", terrain: ..." for a summary's first line ("" on flat ground).
  std::string text() const;
  /// The options as command-line arguments ("" on flat ground).
  std::string args() const;
  nlohmann::json json() const;  ///< null on flat ground
};

/// A run's muscle report (scenario.h) for the JSON summaries: tendons, and per joint the shares
/// of the torque the muscles and the backups gave; null without muscles.
nlohmann::json muscles_json(const std::optional<scenarios::MuscleRunReport>& report);
/// The same in a few lines a person reads (nothing without muscles).
void print_muscles(const std::optional<scenarios::MuscleRunReport>& report, std::ostream& out);

/// What the joints' range stops carried beside the motors (scenario.h) for the JSON summaries.
nlohmann::json joint_load_json(const scenarios::JointLoadReport& r);
/// The same as one line a person reads ("  joint stops: ...\n").
void print_joint_load(const scenarios::JointLoadReport& r, std::ostream& out);

/// The body an output was computed for, as every JSON summary reports it: height_m, mass_kg,
/// sex, detail (add a command's own inputs to it).
nlohmann::json character_json(const models::CharacterSpec& spec);

/// Numbers separated by commas, e.g. "150,0.2,0"; throws sim::InvalidArgument
/// "<option>: expected <expected>, got '<text>'" on anything else (an empty item too, as a
/// trailing comma gives).
std::vector<double> parse_number_list(const std::string& text, const std::string& option,
                                      const std::string& expected);

/// "WIDTHxHEIGHT" (e.g. 1280x720) as two integers; throws sim::InvalidArgument
/// "<option>: expected WIDTHxHEIGHT, e.g. 1280x720, got '<text>'" on anything else.
std::pair<int, int> parse_size(const std::string& text, const std::string& option);

/// `j` as text (nlohmann's dump with `indent`) that never throws on a string that is not UTF-8
/// (a file name or label of any bytes): such bytes become U+FFFD, the rest is dump's text.
inline std::string json_text(const nlohmann::json& j, int indent) {
  return j.dump(indent, ' ', false, nlohmann::json::error_handler_t::replace);
}

/// Whole-file reads (sim/file_io.h), for every subcommand.
using sim::read_file;

/// Refuses (sim::InvalidArgument: exit 2, nothing written) outputs that cannot all be written,
/// before any work: a file output that is a directory or lies under a file, a directory output
/// that is a file, two outputs on one path, an output on an input. `what` names each path's
/// option for the message, e.g. {"-o", path}.
struct OutputPath {
  std::string option, path;
  bool directory = false;  ///< an output directory (else a file)
};
void check_outputs(const std::vector<OutputPath>& outputs, const std::vector<std::string>& inputs);

/// sim::write_file_atomically, creating missing parent directories: a subcommand's outputs go
/// where the user says.
inline void write_file_atomically(const std::string& path, const std::string& text) {
  sim::write_file_atomically(path, text, sim::MissingDirectories::kCreate);
}

/// Runs gnuplot on `script_path` (a script that writes `png_tmp`), then renames `png_tmp` to
/// `png`: the plot is written whole or not at all. Throws sim::Error starting with `command`
/// if gnuplot cannot start or fails (with its output).
void plot_with_gnuplot(const std::string& command, const std::string& script_path,
                       const std::string& png_tmp, const std::string& png);

/// A batch of independent runs: job(sim, i) for every i in [0, count) on `threads` workers,
/// each with its own simulation of `mjcf` (results do not depend on the thread count when
/// every run resets its simulation); a progress bar labelled `label`. The first error stops
/// the workers and is thrown as sim::Error("<label>: <what>").
void run_batch(std::size_t count, int threads, const std::string& mjcf, const std::string& label,
               const std::function<void(sim::Simulation*, std::size_t)>& job);
/// The same without a shared model: job(i) builds what it runs (e.g. one body per run).
void run_jobs(std::size_t count, int threads, const std::string& label,
              const std::function<void(std::size_t)>& job);
/// A batch's worker count: `requested` (--threads; 0: every core), at most one per job.
int batch_threads(int requested, std::size_t jobs);

/// Installs a log sink printing warnings and errors to stderr (debug/info only if verbose).
void install_console_log(bool verbose);

}  // namespace biodyn::apps

namespace biodyn::apps {

/// A one-line progress bar on stderr, redrawn in place on a terminal; elsewhere (CI logs,
/// pipes) it prints only the finished line so logs stay short.
class ProgressBar {
 public:
  explicit ProgressBar(std::string label);
  /// fraction in [0, 1].
  void update(double fraction);
  /// Prints the final state and a newline (idempotent).
  void finish();
  /// Finishes, unless an exception is unwinding: then the bar only ends its line, so the
  /// error message stays the one line the user reads.
  ~ProgressBar();

 private:
  std::string label_;
  bool tty_ = false;
  bool done_ = false;
  int last_percent_ = -1;
};

}  // namespace biodyn::apps
