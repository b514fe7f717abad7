#pragma once
/// `biodyn mocap retarget`: a BVH motion on a generated character (retarget.h), its options and
/// its run, kept apart from cmd_mocap.cc's other mocap subcommands.

#include <CLI/CLI.hpp>
#include <optional>
#include <string>

#include "cli_common.h"
#include "commands.h"

namespace biodyn::apps {

struct RetargetCliOptions {
  std::string bvh, motion, map, up, output;
  std::optional<double> metres_per_unit;  ///< unset: the map's units
  bool align_start = false;
  CharacterOptions character;

  /// The input: the BVH, else the qpos motion.
  const std::string& input() const { return bvh.empty() ? motion : bvh; }
  /// Adds --bvh / --motion, the character options, --map, --metres-per-unit, --up, --align-start,
  /// -o.
  void add_to(CLI::App* cmd);
};

/// Retargets and writes DIR/{motion.csv, character.bvh, stats.json, feet.png}; returns the
/// exit code. Throws sim::InvalidArgument for bad options or files.
int run_retarget(const RetargetCliOptions& options);

}  // namespace biodyn::apps
