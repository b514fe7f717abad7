// biodyn mocap: capture files in (C3D, TRC, BVH): info, convert, marker IK, inverse dynamics
// (issue 5); retarget lives in cmd_mocap_retarget.cc.
#include <algorithm>
#include <cmath>
#include <iostream>
#include <memory>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <sstream>

#include "biodyn/mocap_io/bvh.h"
#include "biodyn/mocap_io/c3d.h"
#include "biodyn/mocap_io/inverse_dynamics.h"
#include "biodyn/mocap_io/marker_ik.h"
#include "biodyn/mocap_io/motion_csv.h"
#include "biodyn/mocap_io/scaling.h"
#include "biodyn/mocap_io/trc.h"
#include "biodyn/models/marker_set.h"
#include "biodyn/models/mjcf.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/model.h"
#include "cli_common.h"
#include "cmd_mocap_retarget.h"
#include "commands.h"

namespace biodyn::apps {
namespace {

using nlohmann::json;

enum class Format { kC3d, kTrc, kBvh, kCsv };

/// The format of `path` from its extension (case-insensitive).
Format format_of(const std::string& path, const std::string& option) {
  const size_t dot = path.find_last_of('.');
  std::string ext = dot == std::string::npos ? "" : path.substr(dot + 1);
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  if (ext == "c3d") return Format::kC3d;
  if (ext == "trc") return Format::kTrc;
  if (ext == "bvh") return Format::kBvh;
  if (ext == "csv") return Format::kCsv;
  throw sim::InvalidArgument(option + ": expected a .c3d, .trc or .bvh file, got '" + path + "'");
}

/// Marker trajectories (and what else the file had) from a C3D or TRC file.
struct MarkerFile {
  mocap_io::MarkerData markers;
  std::vector<std::string> inconsistencies;
};

MarkerFile read_markers(const std::string& path, const std::string& option) {
  switch (format_of(path, option)) {
    case Format::kC3d: {
      mocap_io::C3dFile f = mocap_io::read_c3d(path);
      return {std::move(f.markers), std::move(f.inconsistencies)};
    }
    case Format::kTrc: {
      mocap_io::TrcFile f = mocap_io::read_trc(path);
      return {std::move(f.markers), std::move(f.inconsistencies)};
    }
    default:
      throw sim::InvalidArgument(option + ": expected a .c3d or .trc marker file, got '" + path +
                                 "'");
  }
}

/// Rotates lab-frame markers into biodyn's world (z up) when the lab's vertical is y.
void to_z_up(mocap_io::MarkerData* m, const std::string& lab_up) {
  if (lab_up == "z") return;
  const Eigen::Matrix3d r = mocap_io::file_to_world(mocap_io::UpAxis::kY);
  for (int f = 0; f < m->frame_count(); ++f) {
    for (int i = 0; i < m->marker_count(); ++i) {
      const Eigen::Vector3d p = r * m->position(f, i);
      m->positions_m.row(f).segment<3>(3 * i) = p.transpose();
    }
  }
}

/// Rotates force plates into biodyn's world (z up) when the lab's vertical is y.
void to_z_up(std::vector<mocap_io::ForcePlate>* plates, const std::string& lab_up) {
  if (lab_up == "z") return;
  const Eigen::Matrix3d r = mocap_io::file_to_world(mocap_io::UpAxis::kY);
  for (mocap_io::ForcePlate& p : *plates) {
    p.corners_m = r * p.corners_m;
    for (Eigen::MatrixXd* m : {&p.force_N, &p.moment_origin_Nm, &p.cop_m, &p.free_moment_Nm}) {
      *m = *m * r.transpose();  // rows are vectors: v' R'
    }
  }
}

json marker_info(const mocap_io::MarkerData& m) {
  json gaps = json::object();
  for (int i = 0; i < m.marker_count(); ++i) gaps[m.labels[static_cast<size_t>(i)]] = m.gap_count(i);
  return {{"frames", m.frame_count()}, {"rate", m.rate_hz},       {"first_frame", m.first_frame},
          {"markers", m.labels},       {"gaps", gaps}};
}

json info_json(const std::string& path) {
  json j;
  switch (format_of(path, "FILE")) {
    case Format::kC3d: {
      const mocap_io::C3dFile f = mocap_io::read_c3d(path);
      j = marker_info(f.markers);
      j["format"] = "c3d";
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
        for (int k = 0; k < 4; ++k) corners.push_back({p.corners_m(0, k), p.corners_m(1, k), p.corners_m(2, k)});
        plates.push_back({{"type", p.type}, {"corners_m", corners}, {"channels", p.channels},
                          {"samples", p.sample_count()}});
      }
      j["force_plates"] = plates;
      j["inconsistencies"] = f.inconsistencies;
      break;
    }
    case Format::kTrc: {
      const mocap_io::TrcFile f = mocap_io::read_trc(path);
      j = marker_info(f.markers);
      j["format"] = "trc";
      j["units"] = f.units;
      j["analog_channels"] = json::array();
      j["force_plates"] = json::array();
      j["inconsistencies"] = f.inconsistencies;
      break;
    }
    case Format::kBvh: {
      const mocap_io::BvhMotion b = mocap_io::read_bvh(path);
      j["format"] = "bvh";
      j["frames"] = b.frame_count();
      j["rate"] = 1.0 / b.frame_time_s;
      j["frame_time"] = b.frame_time_s;
      j["first_frame"] = 0;
      json joints = json::array();
      for (const mocap_io::BvhJoint& jt : b.joints) {
        std::vector<std::string> channels;
        for (mocap_io::BvhChannel c : jt.channels) channels.push_back(mocap_io::to_string(c));
        joints.push_back({{"name", jt.name},
                          {"parent", jt.parent < 0 ? "" : b.joints[static_cast<size_t>(jt.parent)].name},
                          {"end_site", jt.end_site},
                          {"channels", channels}});
      }
      j["joints"] = joints;
      j["channels"] = b.channel_count();
      j["analog_channels"] = json::array();
      j["force_plates"] = json::array();
      j["inconsistencies"] = json::array();
      break;
    }
    default:
      throw sim::InvalidArgument("FILE: expected a .c3d, .trc or .bvh file, got '" + path + "'");
  }
  return j;
}

void print_info(const std::string& path, const json& j) {
  std::cout << path << ": " << j["format"].get<std::string>() << ", " << j["frames"] << " frames at "
            << j["rate"] << " Hz, first frame " << j["first_frame"] << "\n";
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
}


/// The longest run of frames with a pose (IK leaves unsolved frames as NaN rows).
mocap_io::Motion longest_solved_span(const mocap_io::Motion& motion, int* first) {
  int best_start = 0, best_len = 0, start = 0;
  for (int f = 0; f <= motion.frame_count(); ++f) {
    const bool ok = f < motion.frame_count() && motion.qpos.row(f).allFinite();
    if (ok) continue;
    if (f - start > best_len) {
      best_len = f - start;
      best_start = start;
    }
    start = f + 1;
  }
  mocap_io::Motion out = motion;
  out.qpos = motion.qpos.middleRows(best_start, best_len);
  out.times_s.assign(motion.times_s.begin() + best_start,
                     motion.times_s.begin() + best_start + best_len);
  *first = best_start;
  return out;
}

/// Heel strikes of one foot: times its body origin comes down to within kStrikeHeight_m of its
/// lowest height in the motion after being higher than kLiftHeight_m above it.
std::vector<double> foot_strikes(const mjModel& m, const mocap_io::Motion& motion,
                                 const char* foot) {
  constexpr double kStrikeHeight_m = 0.02;  // a planted foot is within 2 cm of its lowest
  constexpr double kLiftHeight_m = 0.05;    // swing lifts the ankle by more than 5 cm
  const int body = mj_name2id(&m, mjOBJ_BODY, foot);
  if (body < 0) return {};
  sim::Data d(m);
  std::vector<double> z(static_cast<size_t>(motion.frame_count()));
  for (int f = 0; f < motion.frame_count(); ++f) {
    for (int k = 0; k < m.nq; ++k) d->qpos[k] = motion.qpos(f, k);
    mj_kinematics(&m, d.get());
    z[static_cast<size_t>(f)] = d->xpos[3 * body + 2];
  }
  const double lowest = *std::min_element(z.begin(), z.end());
  std::vector<double> strikes;
  bool lifted = false;
  for (size_t f = 0; f < z.size(); ++f) {
    if (z[f] > lowest + kLiftHeight_m) lifted = true;
    if (lifted && z[f] < lowest + kStrikeHeight_m) {
      strikes.push_back(motion.times_s[f]);
      lifted = false;
    }
  }
  return strikes;
}

/// gnuplot script and data plotting the sagittal torques of hip, knee and ankle over the gait
/// cycle (left heel strike to left heel strike; over time when there is no full cycle).
void plot_torques(const std::string& dir, const mocap_io::InverseDynamicsResult& id,
                  const std::vector<double>& strikes, double mass_kg) {
  const std::vector<std::pair<std::string, std::string>> panels = {
      {"hip_l_y", "hip flexion-extension (left, about y)"},
      {"knee_flexion_l", "knee flexion (left)"},
      {"ankle_dorsiflexion_l", "ankle dorsiflexion (left)"},
      {"hip_r_y", "hip flexion-extension (right, about y)"},
      {"knee_flexion_r", "knee flexion (right)"},
      {"ankle_dorsiflexion_r", "ankle dorsiflexion (right)"}};
  const bool cycles = strikes.size() >= 2;
  std::ostringstream data;
  data.precision(6);
  for (const auto& [dof, title] : panels) {
    const auto it = std::find(id.dof_names.begin(), id.dof_names.end(), dof);
    data << "# " << dof << "\n";
    if (it != id.dof_names.end()) {
      const Eigen::Index col = it - id.dof_names.begin();
      for (size_t i = 0; i < id.times_s.size(); ++i) {
        const double t = id.times_s[i];
        double x = t;
        if (cycles) {
          const auto next = std::upper_bound(strikes.begin(), strikes.end(), t);
          if (next == strikes.begin() || next == strikes.end()) continue;
          const double t0 = *(next - 1), t1 = *next;
          x = 100.0 * (t - t0) / (t1 - t0);
          if (i > 0 && id.times_s[i - 1] < t0) data << "\n";  // a new cycle: a new line
        }
        data << x << " " << id.generalized_force(static_cast<Eigen::Index>(i), col) / mass_kg
             << "\n";
      }
    }
    data << "\n\n";
  }
  write_file_atomically(dir + "/torques_plot.dat", data.str());
  std::ostringstream gp;
  gp << "set terminal pngcairo size 1400,800 font 'sans,10'\n"
     << "set output '" << dir << "/torques.png.tmp'\n"
     << "set multiplot layout 2,3 title 'Joint torques per kg of body mass (" << mass_kg
     << " kg)'\n"
     << "set grid\nset xlabel '" << (cycles ? "% of the gait cycle (left heel strike to left heel strike)" : "time (s)")
     << "'\nset ylabel 'N m / kg'\n";
  for (size_t p = 0; p < panels.size(); ++p) {
    gp << "set title '" << panels[p].second << "'\n"
       << "plot '" << dir << "/torques_plot.dat' index " << p << " with lines lw 1.5 notitle\n";
  }
  gp << "unset multiplot\n";
  write_file_atomically(dir + "/torques.gp", gp.str());
  plot_with_gnuplot("mocap id", dir + "/torques.gp", dir + "/torques.png.tmp", dir + "/torques.png");
}

}  // namespace

Command add_mocap_command(CLI::App* app) {
  CLI::App* mocap = app->add_subcommand("mocap", "Motion capture in: C3D, TRC and BVH files, marker IK, retargeting, inverse dynamics");
  mocap->require_subcommand(1);

  // --- info ---
  struct InfoOptions {
    std::string file;
    bool json_out = false;
  };
  auto info = std::make_shared<InfoOptions>();
  CLI::App* info_cmd = mocap->add_subcommand("info", "What a capture file holds (JSON with --json)");
  info_cmd->add_option("FILE", info->file, "a .c3d, .trc or .bvh file")->required();
  info_cmd->add_flag("--json", info->json_out, "print JSON instead of a summary");

  // --- convert ---
  struct ConvertOptions {
    std::string in, out, units = "mm", processor = "intel", storage = "float";
    double scale = 1.0;
    int precision = 10;
  };
  auto conv = std::make_shared<ConvertOptions>();
  CLI::App* conv_cmd = mocap->add_subcommand(
      "convert", "Convert C3D/TRC markers to TRC or C3D, or rewrite a BVH (scaled lengths)");
  conv_cmd->add_option("IN", conv->in, "input file (.c3d, .trc, .bvh)")->required();
  conv_cmd->add_option("OUT", conv->out, "output file (.trc, .c3d, .bvh)")->required();
  conv_cmd->add_option("--units", conv->units, "TRC output units: mm or m")->capture_default_str();
  conv_cmd->add_option("--processor", conv->processor, "C3D output: intel, dec or mips")
      ->capture_default_str();
  conv_cmd->add_option("--storage", conv->storage, "C3D output: float or integer")
      ->capture_default_str();
  conv_cmd->add_option("--scale", conv->scale, "BVH: multiply every length (offsets, positions)")
      ->capture_default_str();
  conv_cmd->add_option("--precision", conv->precision, "significant digits of text outputs")
      ->capture_default_str();

  // --- ik ---
  struct IkOptions {
    std::string c3d, trc, markerset, static_trial, output, json_path, lab_up = "z";
    CharacterOptions character;
    int max_iterations = 15;
  };
  auto ik = std::make_shared<IkOptions>();
  CLI::App* ik_cmd = mocap->add_subcommand(
      "ik", "Marker IK of a capture on a generated character: joint trajectories (qpos CSV)");
  auto* c3d_opt = ik_cmd->add_option("--c3d", ik->c3d, "C3D capture");
  auto* trc_opt = ik_cmd->add_option("--trc", ik->trc, "TRC capture");
  c3d_opt->excludes(trc_opt);
  ik_cmd->add_option("--markerset", ik->markerset,
                     "built-in set (thesis26, full40, opensim_walking5) or a JSON file; default: "
                     "the built-in set sharing the most labels with the capture");
  ik_cmd->add_option("--static", ik->static_trial,
                     "static trial (.c3d/.trc) to scale the character and place markers from "
                     "(OpenSim's ScaleTool); without it the character is scaled by height");
  ik_cmd->add_option("--lab-up", ik->lab_up, "vertical axis of the capture lab: z or y")
      ->capture_default_str();
  ik->character.add_to(ik_cmd);
  ik_cmd->add_option("--max-iterations", ik->max_iterations, "LM iterations per frame")
      ->capture_default_str();
  ik_cmd->add_option("-o,--output", ik->output, "motion CSV to write (qpos per frame)")->required();
  ik_cmd->add_option("--json", ik->json_path, "statistics JSON to write");

  // --- id ---
  struct IdOptions {
    std::string motion, grf = "none", c3d, output, lab_up = "z";
    CharacterOptions character;
    double cutoff_hz = 6.0;
  };
  auto idopt = std::make_shared<IdOptions>();
  CLI::App* id_cmd = mocap->add_subcommand(
      "id", "Inverse dynamics of a motion (qpos CSV) on a body: joint torques and residuals");
  id_cmd->add_option("--motion", idopt->motion, "motion CSV (from mocap ik or retarget)")->required();
  idopt->character.add_to(id_cmd);
  id_cmd->add_option("--grf", idopt->grf,
                     "ground reaction: none (all in the root residual), from-c3d (the "
                     "capture's force plates; needs --c3d), contact (MuJoCo's floor contact)")
      ->capture_default_str();
  id_cmd->add_option("--c3d", idopt->c3d, "the C3D the motion came from (force plates)");
  id_cmd->add_option("--lab-up", idopt->lab_up,
                     "vertical axis of the capture lab (as given to mocap ik): z or y")
      ->capture_default_str();
  id_cmd->add_option("--cutoff", idopt->cutoff_hz, "low-pass cut-off, Hz (0: no filter)")
      ->capture_default_str();
  id_cmd->add_option("-o,--output", idopt->output, "output directory")->required();

  // --- retarget ---
  auto rt = std::make_shared<RetargetCliOptions>();
  CLI::App* rt_cmd = mocap->add_subcommand(
      "retarget", "A BVH motion on a generated character: qpos CSV, the character's BVH, "
                  "foot-slide and penetration stats");
  rt->add_to(rt_cmd);

  return {mocap, [=]() {
            if (rt_cmd->parsed()) return run_retarget(*rt);
            if (info_cmd->parsed()) {
              const json j = info_json(info->file);
              if (info->json_out) {
                std::cout << j.dump(1) << "\n";
              } else {
                print_info(info->file, j);
              }
              return kExitOk;
            }
            if (conv_cmd->parsed()) {
              const Format in = format_of(conv->in, "IN"), out = format_of(conv->out, "OUT");
              if (conv->precision < 3 || conv->precision > 17) {
                throw sim::InvalidArgument("--precision: must be within [3, 17], got " +
                                           std::to_string(conv->precision));
              }
              if (in == Format::kBvh || out == Format::kBvh) {
                if (in != out) {
                  throw sim::InvalidArgument("convert: BVH converts only to BVH (got " + conv->in +
                                             " -> " + conv->out + ")");
                }
                if (!(conv->scale > 0 && std::isfinite(conv->scale))) {
                  throw sim::InvalidArgument("--scale: must be > 0, got " + std::to_string(conv->scale));
                }
                mocap_io::BvhMotion b = mocap_io::read_bvh(conv->in);
                for (mocap_io::BvhJoint& jt : b.joints) {
                  jt.offset *= conv->scale;
                  for (size_t c = 0; c < jt.channels.size(); ++c) {
                    const mocap_io::BvhChannel ch = jt.channels[c];
                    if (ch == mocap_io::BvhChannel::kXposition || ch == mocap_io::BvhChannel::kYposition ||
                        ch == mocap_io::BvhChannel::kZposition) {
                      b.values.col(jt.first_channel + static_cast<int>(c)) *= conv->scale;
                    }
                  }
                }
                mocap_io::write_bvh(conv->out, b, conv->precision);
                std::cout << "wrote " << conv->out << ": " << b.frame_count() << " frames, "
                          << b.joints.size() << " joints\n";
                return kExitOk;
              }
              if (in == Format::kCsv || out == Format::kCsv) {
                throw sim::InvalidArgument("convert: CSV is not a capture format (use mocap ik)");
              }
              mocap_io::C3dFile data;
              if (in == Format::kC3d) {
                data = mocap_io::read_c3d(conv->in);
              } else {
                data.markers = mocap_io::read_trc(conv->in).markers;
              }
              if (out == Format::kTrc) {
                mocap_io::write_trc(conv->out, data.markers, conv->units, conv->precision);
              } else {
                mocap_io::C3dWriteOptions w;
                if (conv->processor == "intel") {
                  w.processor = mocap_io::C3dProcessor::kIntel;
                } else if (conv->processor == "dec") {
                  w.processor = mocap_io::C3dProcessor::kDec;
                } else if (conv->processor == "mips") {
                  w.processor = mocap_io::C3dProcessor::kMips;
                } else {
                  throw sim::InvalidArgument("--processor: expected intel, dec or mips, got '" +
                                             conv->processor + "'");
                }
                if (conv->storage == "float") {
                  w.storage = mocap_io::C3dStorage::kFloat;
                } else if (conv->storage == "integer") {
                  w.storage = mocap_io::C3dStorage::kInteger;
                } else {
                  throw sim::InvalidArgument("--storage: expected float or integer, got '" +
                                             conv->storage + "'");
                }
                if (w.storage == mocap_io::C3dStorage::kInteger) {
                  // The finest resolution (at least 0.1 mm) whose 16-bit range holds the data.
                  constexpr double kFinestScale_mm = 0.1;
                  constexpr double kUsableRange = 32000.0;  // of the int16's 32767
                  double max_abs_mm = 0.0;
                  for (Eigen::Index k = 0; k < data.markers.positions_m.size(); ++k) {
                    const double v = data.markers.positions_m.data()[k];
                    if (std::isfinite(v)) max_abs_mm = std::max(max_abs_mm, 1000.0 * std::abs(v));
                  }
                  w.integer_scale_mm =
                      std::max(kFinestScale_mm, std::ceil(1000.0 * max_abs_mm / kUsableRange) / 1000.0);
                  std::cout << "integer storage at " << w.integer_scale_mm << " mm per unit\n";
                }
                mocap_io::write_c3d(conv->out, data, w);
              }
              std::cout << "wrote " << conv->out << ": " << data.markers.frame_count()
                        << " frames, " << data.markers.marker_count() << " markers\n";
              return kExitOk;
            }
            if (id_cmd->parsed()) {
              mocap_io::InverseDynamicsOptions options;
              options.filter.cutoff_hz = idopt->cutoff_hz;
              std::vector<mocap_io::ForcePlate> plates;
              double plate_rate = 0.0;
              if (idopt->grf == "none") {
                options.ground = mocap_io::GroundForces::kNone;
              } else if (idopt->grf == "contact") {
                options.ground = mocap_io::GroundForces::kContact;
              } else if (idopt->grf == "from-c3d") {
                options.ground = mocap_io::GroundForces::kForcePlates;
                if (idopt->c3d.empty()) {
                  throw sim::InvalidArgument("--grf from-c3d: give the capture with --c3d FILE");
                }
                const mocap_io::C3dFile c3d = mocap_io::read_c3d(idopt->c3d);
                if (c3d.force_plates.empty()) {
                  throw sim::InvalidArgument("--c3d " + idopt->c3d + ": has no force plates");
                }
                if (idopt->lab_up != "z" && idopt->lab_up != "y") {
                  throw sim::InvalidArgument("--lab-up: expected z or y, got '" + idopt->lab_up + "'");
                }
                plates = c3d.force_plates;
                to_z_up(&plates, idopt->lab_up);
                plate_rate = c3d.analog.rate_hz;
              } else {
                throw sim::InvalidArgument("--grf: expected none, from-c3d or contact, got '" +
                                           idopt->grf + "'");
              }
              const mocap_io::Motion all = mocap_io::read_motion_csv(idopt->motion);
              models::CharacterSpec spec = idopt->character.to_spec();
              const models::Character character = models::generate_character(spec);
              const sim::Model model = sim::Model::from_string(models::to_mjcf(character), "character");
              mocap_io::check_motion_matches(all, *model, idopt->motion);
              int first = 0;
              const mocap_io::Motion motion = longest_solved_span(all, &first);
              ProgressBar bar("mocap id: " + std::to_string(motion.frame_count()) + " frames");
              const mocap_io::InverseDynamicsResult id =
                  mocap_io::inverse_dynamics(*model, motion, options, plates, plate_rate);
              bar.finish();
              std::filesystem::create_directories(idopt->output);
              std::ostringstream torques, residuals;
              torques.precision(9);
              residuals.precision(9);
              torques << "time";
              for (const std::string& n : id.dof_names) torques << "," << n;
              torques << "\n";
              residuals << "time,residual_fx,residual_fy,residual_fz,residual_mx,residual_my,"
                           "residual_mz,ground_fx,ground_fy,ground_fz\n";
              for (size_t i = 0; i < id.times_s.size(); ++i) {
                const Eigen::Index r = static_cast<Eigen::Index>(i);
                torques << id.times_s[i];
                for (Eigen::Index c = 0; c < id.generalized_force.cols(); ++c) {
                  torques << "," << id.generalized_force(r, c);
                }
                torques << "\n";
                residuals << id.times_s[i];
                for (int k = 0; k < 3; ++k) residuals << "," << id.residual_force_N(r, k);
                for (int k = 0; k < 3; ++k) residuals << "," << id.residual_moment_Nm(r, k);
                for (int k = 0; k < 3; ++k) residuals << "," << id.ground_force_N(r, k);
                residuals << "\n";
              }
              const auto norms = [](const Eigen::MatrixXd& x) {
                return x.rowwise().norm();
              };
              const Eigen::VectorXd fn = norms(id.residual_force_N), mn = norms(id.residual_moment_Nm);
              json peaks = json::object();
              for (size_t c = 0; c < id.dof_names.size(); ++c) {
                peaks[id.dof_names[c]] = id.generalized_force.col(static_cast<Eigen::Index>(c)).cwiseAbs().maxCoeff();
              }
              const std::vector<double> strikes = foot_strikes(*model, motion, "foot_l");
              json summary = {
                  {"motion", idopt->motion},
                  {"frames_used", id.times_s.size()},
                  {"first_frame_used", first + options.trim_frames},
                  {"time_span_s", {id.times_s.front(), id.times_s.back()}},
                  {"character", {{"height_m", spec.height_m}, {"mass_kg", spec.mass_kg},
                                 {"sex", models::to_string(spec.sex)},
                                 {"detail", models::to_string(spec.detail)}}},
                  {"ground", idopt->grf},
                  {"ground_caveat",
                   idopt->grf == "contact"
                       ? "MuJoCo's soft contact inverted on kinematic data: forces swing strongly "
                         "with sub-millimetre penetration; an estimate only"
                       : idopt->grf == "none" ? "no ground force: the root residual is the whole "
                                                "ground reaction"
                                              : "measured force plates"},
                  {"filter", {{"type", "Butterworth 2nd order, forward-backward (zero lag)"},
                              {"cutoff_hz", idopt->cutoff_hz}}},
                  {"armature_and_damping", "left out (simulation stabilisers, not body properties)"},
                  {"residual_force_peak_N", fn.maxCoeff()},
                  {"residual_force_rms_N", std::sqrt(fn.squaredNorm() / static_cast<double>(fn.size()))},
                  {"residual_moment_peak_Nm", mn.maxCoeff()},
                  {"residual_moment_rms_Nm", std::sqrt(mn.squaredNorm() / static_cast<double>(mn.size()))},
                  {"body_weight_N", character.total_mass_kg() * 9.81},
                  {"left_heel_strikes_s", strikes},
                  {"peak_torques", peaks}};
              write_file_atomically(idopt->output + "/torques.csv", torques.str());
              write_file_atomically(idopt->output + "/residuals.csv", residuals.str());
              write_file_atomically(idopt->output + "/summary.json", summary.dump(1) + "\n");
              plot_torques(idopt->output, id, strikes, spec.mass_kg);
              std::cout << "mocap id: " << id.times_s.size() << " frames on " << spec.height_m
                        << " m / " << spec.mass_kg << " kg, ground " << idopt->grf
                        << ": residual force peak " << fn.maxCoeff() << " N (body weight "
                        << character.total_mass_kg() * 9.81 << " N), moment peak " << mn.maxCoeff()
                        << " N m\n";
              if (options.ground == mocap_io::GroundForces::kNone) {
                std::cout << "  --grf none: the residual is the whole ground reaction the motion "
                             "needs, not a modelling error\n";
              }
              if (options.ground == mocap_io::GroundForces::kContact) {
                // Measured on the CMU walk retargeted to 2 m: peaks of 10^4-10^5 N where a
                // kinematic foot or knee sits a fraction of a millimetre in the floor.
                Eigen::Index peak = 0;
                fn.maxCoeff(&peak);
                std::cout << "  --grf contact: MuJoCo's soft contact inverted on kinematic data; its "
                             "forces swing strongly with sub-millimetre penetration (peak at t = "
                          << id.times_s[static_cast<std::size_t>(peak)]
                          << " s): an estimate only; force plates (--grf from-c3d) are the "
                             "measurement\n";
              }
              std::cout << "wrote " << idopt->output << "/{torques.csv, residuals.csv, summary.json, "
                           "torques.png}\n";
              return kExitOk;
            }
            // --- ik ---
            if (ik->c3d.empty() == ik->trc.empty()) {
              throw sim::InvalidArgument("mocap ik: give exactly one of --c3d FILE or --trc FILE");
            }
            if (ik->lab_up != "z" && ik->lab_up != "y") {
              throw sim::InvalidArgument("--lab-up: expected z or y, got '" + ik->lab_up + "'");
            }
            const std::string capture_path = ik->c3d.empty() ? ik->trc : ik->c3d;
            MarkerFile capture = read_markers(capture_path, ik->c3d.empty() ? "--trc" : "--c3d");
            to_z_up(&capture.markers, ik->lab_up);
            // The marker set: given, or the built-in one sharing the most labels.
            models::MarkerSet set;
            if (ik->markerset.empty()) {
              size_t best = 0;
              for (const std::string& name : models::builtin_marker_set_names()) {
                const models::MarkerSet candidate = models::builtin_marker_set(name);
                size_t shared = 0;
                for (const models::MarkerPlacement& p : candidate.markers) {
                  shared += capture.markers.find(p.name) >= 0 ? 1 : 0;
                }
                if (shared > best) {
                  best = shared;
                  set = candidate;
                }
              }
              if (best == 0) {
                throw sim::InvalidArgument(capture_path + ": no built-in marker set shares a label "
                                           "with this capture; give --markerset FILE.json");
              }
            } else if (ik->markerset.find(".json") != std::string::npos) {
              set = models::parse_marker_set(read_file(ik->markerset), ik->markerset);
            } else {
              set = models::builtin_marker_set(ik->markerset);
            }
            models::CharacterSpec spec = ik->character.to_spec();
            spec.markers = set.markers;
            json stats;
            if (!ik->static_trial.empty()) {
              MarkerFile stat = read_markers(ik->static_trial, "--static");
              to_z_up(&stat.markers, ik->lab_up);
              const bool height_given = ik_cmd->count("--height") > 0;
              const mocap_io::ScaleResult scaled =
                  mocap_io::scale_from_static(spec, height_given, set, stat.markers);
              spec = scaled.spec;
              json factors = json::array();
              for (const mocap_io::ScaleFactor& f : scaled.factors) {
                factors.push_back({{"segments", f.segments}, {"measured_m", f.measured_m},
                                   {"model_m", f.model_m}, {"factor", f.factor},
                                   {"frames", f.frames}});
              }
              stats["scaling"] = {{"static_trial", ik->static_trial},
                                  {"height_m", spec.height_m},
                                  {"height_estimated", !height_given},
                                  {"factors", factors},
                                  {"placed_markers", scaled.placed},
                                  {"static_rms_m", scaled.static_rms_m},
                                  {"static_max_m", scaled.static_max_m}};
            }
            const models::Character character = models::generate_character(spec);
            const sim::Model model = sim::Model::from_string(models::to_mjcf(character), "character");
            std::vector<double> weights;
            for (const std::string& label : capture.markers.labels) weights.push_back(set.weight(label));
            mocap_io::MarkerIkOptions options;
            options.max_iterations = ik->max_iterations;
            ProgressBar bar("mocap ik: " + std::to_string(capture.markers.frame_count()) + " frames");
            const mocap_io::MarkerIkResult result = mocap_io::solve_marker_ik(
                *model, capture.markers, weights, options, {},
                [](double fraction, void* user) { static_cast<ProgressBar*>(user)->update(fraction); },
                &bar);
            bar.finish();
            // Statistics over the solved frames.
            int solved = 0;
            double rms_sum = 0.0, rms_max = 0.0, max_error = 0.0;
            std::string max_marker;
            json per_frame = json::array();
            for (int f = 0; f < capture.markers.frame_count(); ++f) {
              const mocap_io::MarkerIkFrame& fr = result.frames[static_cast<size_t>(f)];
              per_frame.push_back({{"solved", fr.solved}, {"rms", fr.rms_error_m},
                                   {"max", fr.max_error_m}, {"markers", fr.markers_used},
                                   {"iterations", fr.iterations}});
              if (!fr.solved) continue;
              ++solved;
              rms_sum += fr.rms_error_m;
              rms_max = std::max(rms_max, fr.rms_error_m);
              if (fr.max_error_m > max_error) {
                max_error = fr.max_error_m;
                max_marker = capture.markers.labels[static_cast<size_t>(fr.max_error_marker)];
              }
            }
            if (solved == 0) {
              throw sim::InvalidArgument(capture_path + ": no frame has enough visible markers "
                                         "of the marker set '" + set.name + "' for IK");
            }
            // Per-marker error over the solved frames (which markers the body cannot follow).
            json per_marker = json::object();
            {
              mocap_io::MarkerIk probe(*model, capture.markers.labels, weights, options);
              const int n = capture.markers.marker_count();
              std::vector<double> sq(static_cast<size_t>(n), 0.0), worst(static_cast<size_t>(n), 0.0);
              std::vector<int> seen(static_cast<size_t>(n), 0);
              std::vector<double> q(static_cast<size_t>(model->nq));
              for (int f = 0; f < capture.markers.frame_count(); ++f) {
                if (!result.frames[static_cast<size_t>(f)].solved) continue;
                for (int k = 0; k < model->nq; ++k) q[static_cast<size_t>(k)] = result.qpos(f, k);
                const Eigen::Matrix3Xd sites = probe.marker_positions(q.data());
                for (int i = 0; i < n; ++i) {
                  if (!capture.markers.visible(f, i) || !sites.col(i).allFinite()) continue;
                  const double e = (sites.col(i) - capture.markers.position(f, i)).norm();
                  sq[static_cast<size_t>(i)] += e * e;
                  worst[static_cast<size_t>(i)] = std::max(worst[static_cast<size_t>(i)], e);
                  ++seen[static_cast<size_t>(i)];
                }
              }
              for (int i = 0; i < n; ++i) {
                if (seen[static_cast<size_t>(i)] == 0) continue;
                per_marker[capture.markers.labels[static_cast<size_t>(i)]] = {
                    {"rms", std::sqrt(sq[static_cast<size_t>(i)] / seen[static_cast<size_t>(i)])},
                    {"max", worst[static_cast<size_t>(i)]},
                    {"frames", seen[static_cast<size_t>(i)]}};
              }
            }
            stats["per_marker"] = per_marker;
            mocap_io::Motion motion;
            motion.columns = mocap_io::qpos_names(*model);
            motion.qpos = result.qpos;
            for (int f = 0; f < capture.markers.frame_count(); ++f) {
              motion.times_s.push_back(capture.markers.time_s(f));
            }
            motion.comments = {" biodyn mocap ik of " + capture_path + " (marker set " + set.name + ")",
                               " character: " + std::string(models::to_string(spec.sex)) + ", " +
                                   std::to_string(spec.height_m) + " m, " +
                                   std::to_string(spec.mass_kg) + " kg, detail " +
                                   models::to_string(spec.detail)};
            stats["frames"] = capture.markers.frame_count();
            stats["frames_solved"] = solved;
            stats["rms_mean"] = rms_sum / solved;
            stats["rms_max"] = rms_max;
            stats["max_error"] = max_error;
            stats["max_error_marker"] = max_marker;
            stats["frames_per_second"] = capture.markers.frame_count() / std::max(result.seconds, 1e-9);
            stats["marker_set"] = set.name;
            stats["unmapped_labels"] = json::array();
            for (const std::string& l : capture.markers.labels) {
              if (mj_name2id(model.get(), mjOBJ_SITE, ("marker_" + l).c_str()) < 0) {
                stats["unmapped_labels"].push_back(l);
              }
            }
            stats["inconsistencies"] = capture.inconsistencies;
            stats["character"] = {{"height_m", spec.height_m}, {"mass_kg", spec.mass_kg},
                                  {"sex", models::to_string(spec.sex)},
                                  {"detail", models::to_string(spec.detail)}};
            stats["per_frame"] = per_frame;
            write_file_atomically(ik->output, mocap_io::format_motion_csv(motion));
            if (!ik->json_path.empty()) write_file_atomically(ik->json_path, stats.dump(1) + "\n");
            std::cout << "mocap ik: " << solved << "/" << capture.markers.frame_count()
                      << " frames solved (marker set " << set.name << "), marker RMS mean "
                      << 1000 * rms_sum / solved << " mm, worst frame " << 1000 * rms_max
                      << " mm, max " << 1000 * max_error << " mm (" << max_marker << "), "
                      << static_cast<long>(stats["frames_per_second"].get<double>())
                      << " frames/s\n";
            for (const std::string& s : capture.inconsistencies) {
              std::cout << "  note: header and contents disagree: " << s << "\n";
            }
            std::cout << "wrote " << ik->output << (ik->json_path.empty() ? "" : " and " + ik->json_path)
                      << "\n";
            return kExitOk;
          }};
}

}  // namespace biodyn::apps
