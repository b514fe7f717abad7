// biodyn mocap: capture files in (C3D, TRC, BVH): info, convert, marker IK, retargeting and
// inverse dynamics (issue 5). This file holds `mocap info` and registers every subcommand; the
// others live in cmd_mocap_<name>.cc (cmd_mocap.h).
#include "cmd_mocap.h"

#include <algorithm>
#include <cctype>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <vector>

#include "biodyn/mocap_io/bvh.h"
#include "biodyn/mocap_io/c3d.h"
#include "biodyn/mocap_io/trc.h"
#include "biodyn/sim/errors.h"
#include "cli_common.h"

namespace biodyn::apps {
namespace {

using nlohmann::json;

/// The markers' part of `mocap info`: frames, rate, labels and each label's gaps.
json marker_info(const mocap_io::MarkerData& m) {
  json gaps = json::object();
  for (int i = 0; i < m.marker_count(); ++i)
    gaps[m.labels[static_cast<size_t>(i)]] = m.gap_count(i);
  return {{"frames", m.frame_count()},
          {"rate", m.rate_hz},
          {"first_frame", m.first_frame},
          {"markers", m.labels},
          {"gaps", gaps}};
}

/// info of a C3D file: markers, analog channels, force plates.
json c3d_info(const std::string& path) {
  const mocap_io::C3dFile f = mocap_io::read_c3d(path);
  json j = marker_info(f.markers);
  j["format"] = "c3d";
  j["transcoded_names"] = f.transcoded_names;
  j["notes"] = reader_notes(f.transcoded_names, 0);
  j["processor"] = mocap_io::to_string(f.processor);
  j["storage"] = mocap_io::to_string(f.storage);
  j["point_units"] = f.point_units;
  json analog = json::array();
  for (int c = 0; c < f.analog.channel_count(); ++c) {
    analog.push_back({{"label", f.analog.labels[static_cast<size_t>(c)]},
                      {"unit", c < static_cast<int>(f.analog.units.size())
                                   ? f.analog.units[static_cast<size_t>(c)]
                                   : ""}});
  }
  j["analog_channels"] = analog;
  j["analog_rate"] = f.analog.rate_hz;
  json plates = json::array();
  for (const mocap_io::ForcePlate& p : f.force_plates) {
    std::vector<std::vector<double>> corners;
    for (int k = 0; k < 4; ++k)
      corners.push_back({p.corners_m(0, k), p.corners_m(1, k), p.corners_m(2, k)});
    plates.push_back({{"type", p.type},
                      {"corners_m", corners},
                      {"channels", p.channels},
                      {"samples", p.sample_count()}});
  }
  j["force_plates"] = plates;
  j["inconsistencies"] = f.inconsistencies;
  return j;
}

/// info of a TRC file: markers only.
json trc_info(const std::string& path) {
  const mocap_io::TrcFile f = mocap_io::read_trc(path);
  json j = marker_info(f.markers);
  j["format"] = "trc";
  j["units"] = f.units;
  j["point_units"] = f.units;  // the key C3D info uses for the same thing
  j["zero_samples_read_as_gaps"] = f.zero_samples;
  j["transcoded_names"] = f.transcoded_names;
  j["notes"] = reader_notes(f.transcoded_names, f.zero_samples);
  j["analog_channels"] = json::array();
  j["force_plates"] = json::array();
  j["inconsistencies"] = f.inconsistencies;
  return j;
}

/// info of a BVH file: its joints and channels (no markers).
json bvh_info(const std::string& path) {
  const mocap_io::BvhMotion b = mocap_io::read_bvh(path);
  json j;
  j["format"] = "bvh";
  j["transcoded_names"] = b.transcoded_names;
  j["notes"] = reader_notes(b.transcoded_names, 0);
  j["frames"] = b.frame_count();
  j["rate"] = 1.0 / b.frame_time_s;
  j["frame_time"] = b.frame_time_s;
  j["first_frame"] = 0;
  json joints = json::array();
  for (const mocap_io::BvhJoint& jt : b.joints) {
    std::vector<std::string> channels;
    for (mocap_io::BvhChannel c : jt.channels) channels.push_back(mocap_io::to_string(c));
    joints.push_back(
        {{"name", jt.name},
         {"parent", jt.parent < 0 ? "" : b.joints[static_cast<size_t>(jt.parent)].name},
         {"end_site", jt.end_site},
         {"channels", channels}});
  }
  j["joints"] = joints;
  j["channels"] = b.channel_count();
  j["analog_channels"] = json::array();
  j["force_plates"] = json::array();
  j["inconsistencies"] = json::array();
  return j;
}

/// What `path` holds, as `mocap info --json` prints it.
json info_json(const std::string& path) {
  switch (format_of(path, "FILE")) {
    case Format::kC3d:
      return c3d_info(path);
    case Format::kTrc:
      return trc_info(path);
    case Format::kBvh:
      return bvh_info(path);
    default:
      throw sim::InvalidArgument("FILE: expected a .c3d, .trc or .bvh file, got '" + path + "'");
  }
}

void print_info(const std::string& path, const json& j) {
  std::cout << path << ": " << j["format"].get<std::string>() << ", " << j["frames"]
            << " frames at " << j["rate"] << " Hz, first frame " << j["first_frame"] << "\n";
  if (j.contains("markers")) {
    std::cout << "  " << j["markers"].size() << " markers:";
    for (const auto& [label, gaps] : j["gaps"].items()) {
      std::cout << " " << label;
      if (gaps.get<int>() > 0) std::cout << "(" << gaps << " gaps)";
    }
    std::cout << "\n";
  }
  if (j.contains("joints")) {
    std::cout << "  " << j["joints"].size() << " joints (incl. end sites), " << j["channels"]
              << " channels\n";
  }
  std::cout << "  " << j["analog_channels"].size() << " analog channels, "
            << j["force_plates"].size() << " force plates\n";
  for (const auto& s : j["inconsistencies"]) {
    std::cout << "  header and contents disagree: " << s.get<std::string>() << "\n";
  }
  for (const auto& s : j["notes"]) std::cout << "  note: " << s.get<std::string>() << "\n";
}

}  // namespace

std::vector<std::string> reader_notes(int transcoded_names, int zero_samples) {
  std::vector<std::string> notes;
  if (transcoded_names > 0) {
    notes.push_back(std::to_string(transcoded_names) +
                    (transcoded_names == 1 ? " name was" : " names were") +
                    " not UTF-8: read as Latin-1 and transcoded to UTF-8");
  }
  if (zero_samples > 0) {
    notes.push_back(std::to_string(zero_samples) + (zero_samples == 1 ? " sample" : " samples") +
                    " stored as 0 0 0 read as gaps (how OpenSim writes a missing marker)");
  }
  return notes;
}

Format format_of(const std::string& path, const std::string& option) {
  const size_t dot = path.find_last_of('.');
  std::string ext = dot == std::string::npos ? "" : path.substr(dot + 1);
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return std::tolower(c); });
  if (ext == "c3d") return Format::kC3d;
  if (ext == "trc") return Format::kTrc;
  if (ext == "bvh") return Format::kBvh;
  if (ext == "csv") return Format::kCsv;
  throw sim::InvalidArgument(option + ": expected a .c3d, .trc or .bvh file, got '" + path + "'");
}

Command add_mocap_info_command(CLI::App* mocap) {
  struct InfoOptions {
    std::string file;
    bool json_out = false;
  };
  auto info = std::make_shared<InfoOptions>();
  CLI::App* info_cmd =
      mocap->add_subcommand("info", "What a capture file holds (JSON with --json)");
  info_cmd->add_option("FILE", info->file, "a .c3d, .trc or .bvh file")->required();
  info_cmd->add_flag("--json", info->json_out, "print JSON instead of a summary");
  return {info_cmd, [info]() {
            const json j = info_json(info->file);
            if (info->json_out) {
              std::cout << json_text(j, 1) << "\n";
            } else {
              print_info(info->file, j);
            }
            return kExitOk;
          }};
}

Command add_mocap_command(CLI::App* app) {
  CLI::App* mocap = app->add_subcommand(
      "mocap",
      "Motion capture in: C3D, TRC and BVH files, marker IK, retargeting, inverse dynamics, "
      "static optimisation");
  mocap->require_subcommand(1);
  // Registered in the order --help lists them.
  const std::vector<Command> subcommands = {
      add_mocap_info_command(mocap), add_mocap_convert_command(mocap),
      add_mocap_ik_command(mocap),   add_mocap_id_command(mocap),
      add_mocap_so_command(mocap),   add_mocap_retarget_command(mocap),
      add_mocap_track_command(mocap)};
  return {mocap, [subcommands]() {
            for (const Command& c : subcommands) {
              if (c.cli->parsed()) return c.run();
            }
            return kExitBadInput;  // not reached: CLI11 requires one subcommand
          }};
}

}  // namespace biodyn::apps
