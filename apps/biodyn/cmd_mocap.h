#pragma once
/// `biodyn mocap`'s subcommands, one add_mocap_*_command each (info in cmd_mocap.cc, the others
/// in cmd_mocap_<name>.cc), which add_mocap_command (commands.h) registers, and what they share.

#include <CLI/CLI.hpp>
#include <string>
#include <vector>

#include "commands.h"

namespace biodyn::apps {

/// Capture and motion file formats, told by the extension.
enum class Format { kC3d, kTrc, kBvh, kCsv };

/// The format of `path` from its extension (case-insensitive). Throws sim::InvalidArgument
/// naming `option` for any other extension.
Format format_of(const std::string& path, const std::string& option);

/// What a reader did to the file's contents that a user should know: names that were not UTF-8
/// (read as Latin-1) and TRC samples stored as 0 0 0 (read as gaps). Empty when nothing.
std::vector<std::string> reader_notes(int transcoded_names, int zero_samples);

/// `mocap info FILE`: what a capture file holds.
Command add_mocap_info_command(CLI::App* mocap);
/// `mocap convert IN OUT`: C3D/TRC markers to TRC or C3D, or a BVH rewritten (scaled).
Command add_mocap_convert_command(CLI::App* mocap);
/// `mocap ik`: marker IK of a capture on a generated character (cmd_mocap_ik.cc).
Command add_mocap_ik_command(CLI::App* mocap);
/// `mocap id`: inverse dynamics of a motion on a generated character (cmd_mocap_id.cc).
Command add_mocap_id_command(CLI::App* mocap);
/// `mocap retarget`: a BVH motion on a generated character (cmd_mocap_retarget.cc).
Command add_mocap_retarget_command(CLI::App* mocap);

}  // namespace biodyn::apps
