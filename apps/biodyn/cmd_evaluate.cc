// `biodyn evaluate`: a captured motion on a list of bodies; per body a CSV, summary.json and
// one self-contained HTML report (plots embedded as PNG images).
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>

#include "biodyn/scenarios/evaluate.h"
#include "biodyn/sim/errors.h"
#include "cli_common.h"
#include "cmd_mocap.h"
#include "commands.h"

namespace biodyn::apps {
namespace {

using nlohmann::json;
namespace fs = std::filesystem;

struct EvaluateCli {
  std::string motion, bodies, output, tracking = "on";
  std::string lab_up = "z", markerset;  ///< a capture's IK (mocap ik's options)
  scenarios::EvaluateOptions options;
};

/// The sagittal DOFs the report plots, with their titles.
const std::vector<std::pair<std::string, std::string>>& plotted_dofs() {
  static const std::vector<std::pair<std::string, std::string>> dofs = {
      {"hip_l_y", "hip flexion-extension (left)"},
      {"knee_flexion_l", "knee flexion (left)"},
      {"ankle_dorsiflexion_l", "ankle dorsiflexion (left)"},
      {"hip_r_y", "hip flexion-extension (right)"},
      {"knee_flexion_r", "knee flexion (right)"},
      {"ankle_dorsiflexion_r", "ankle dorsiflexion (right)"}};
  return dofs;
}

/// <name>.csv: per frame, every DOF's torque and power and both feet's ground force.
std::string body_csv(const scenarios::BodyEvaluation& e) {
  std::ostringstream out;
  out << "time";
  for (const std::string& d : e.dof_names) out << ",tau_" << d;
  for (const std::string& d : e.dof_names) out << ",power_" << d;
  out << ",grf_fx_l,grf_fy_l,grf_fz_l,grf_fx_r,grf_fy_r,grf_fz_r\n";
  out.precision(8);
  for (size_t f = 0; f < e.times_s.size(); ++f) {
    const auto i = static_cast<Eigen::Index>(f);
    out << e.times_s[f];
    for (Eigen::Index c = 0; c < e.torque_Nm.cols(); ++c) out << "," << e.torque_Nm(i, c);
    for (Eigen::Index c = 0; c < e.power_W.cols(); ++c) out << "," << e.power_W(i, c);
    for (Eigen::Index c = 0; c < 6; ++c) out << "," << e.grf_N(i, c);
    out << "\n";
  }
  return out.str();
}

json body_json(const scenarios::BodyEvaluation& e) {
  json j = {{"name", e.body.name},
            {"character", character_json(e.body.spec)},
            {"profile", e.body.profile},
            {"tau_max_rule", e.body.tau_rule == scenarios::TauMaxRule::kFixed ? "fixed" : "scaled"},
            {"verdict", e.verdict},
            {"feasible", e.feasible}};
  if (!e.error.empty()) {
    j["error"] = e.error;
    return j;
  }
  json joints = json::array();
  for (const scenarios::JointEvaluation& g : e.joints) {
    joints.push_back({{"joint", g.joint},
                      {"peak_torque_Nm", g.peak_torque_Nm},
                      {"tau_max_Nm", g.tau_max_Nm},
                      {"peak_ratio", g.peak_ratio},
                      {"first_saturation_s", g.first_saturation_s},
                      {"positive_work_J", g.positive_work_J},
                      {"negative_work_J", g.negative_work_J},
                      {"peak_power_W", g.peak_power_W}});
  }
  json muscles = json::object();
  for (size_t i = 0; i < e.muscles.size(); ++i) muscles[e.muscles[i]] = e.muscle_peak_activation[i];
  j["first_saturating_joint"] = e.first_saturating_joint;
  j["joints"] = joints;
  j["residual"] = {{"force_rms_N", e.residual_force_rms_N},
                   {"force_peak_N", e.residual_force_peak_N},
                   {"moment_rms_Nm", e.residual_moment_rms_Nm},
                   {"moment_peak_Nm", e.residual_moment_peak_Nm}};
  j["ground_force_peak_bw"] = e.grf_peak_bw;
  j["static_optimisation"] = {{"peak_activation", muscles}, {"reserve_share", e.reserve_share}};
  if (e.tracked) {
    j["tracking"] = {{"kept_up", e.kept_up},
                     {"fell_at_s", e.fell_at_s},
                     {"joint_rms_deg", e.joint_rms_deg},
                     {"root_max_m", e.root_max_m},
                     {"peak_torque_ratio", e.peak_torque_ratio_tracked},
                     {"joint_stops", joint_load_json(e.joint_load_tracked)},
                     {"start_swing_lift_deg", e.start_swing_lift_deg},
                     {"wall_s", e.tracking_wall_s},
                     {"realtime_factor", e.tracking_realtime_factor}};
  }
  j["wall_s"] = e.wall_s;
  return j;
}

/// The assumptions every figure rests on, for the summary and the report.
json assumptions(const EvaluateCli& o) {
  return {{"ground_forces",
           "estimated from the kinematics (mocap id --grf estimate: sole points near the floor "
           "and slow, friction pyramid mu 0.5, least root residual; flat level floor, the body's "
           "mass the subject's)"},
          {"residuals", "the root force and moment the estimated ground cannot supply, reported"},
          {"weld", o.options.tracking ? "tracking with honest foot welds (no weld in tension)"
                                      : "no tracking"},
          {"tau_max",
           "scaled: tau_ref x mass/82.2 kg x height/1.799 m (paper §5.1); fixed: the "
           "motion's own body's tau_max on every body"},
          {"tracking",
           o.options.tracking
               ? "SAMCON over the feedback tracker; no force on the root; motors within "
                 "tau_max; the joints' range stops (rigid MuJoCo limits) may carry more, so a "
                 "body whose motor + stop load stays above tau_max for 50 ms cannot do it; a "
                 "foot swinging with its toes on the floor at the first frame starts "
                 "dorsiflexed clear of it (start_swing_lift_deg)"
               : "off"},
          {"static_optimisation", "rigid tendons, activations squared plus reserves (mocap so)"}};
}

/// torques.png: the plotted DOFs' torques over time, every body overlaid.
std::string torque_plot(const std::string& dir, const std::vector<scenarios::BodyEvaluation>& all) {
  std::ostringstream data;
  data.precision(6);
  for (const auto& [dof, title] : plotted_dofs()) {
    for (const scenarios::BodyEvaluation& e : all) {
      data << "# " << dof << " " << e.body.name << "\n";
      const auto it = std::find(e.dof_names.begin(), e.dof_names.end(), dof);
      if (it != e.dof_names.end()) {
        const Eigen::Index c = it - e.dof_names.begin();
        for (size_t f = 0; f < e.times_s.size(); ++f)
          data << e.times_s[f] << " " << e.torque_Nm(static_cast<Eigen::Index>(f), c) << "\n";
      } else {
        data << "0 0\n";
      }
      data << "\n\n";
    }
  }
  write_file_atomically(dir + "/torques_plot.dat", data.str());
  std::ostringstream gp;
  gp << "set terminal pngcairo size 1500,850 font 'sans,10'\nset output '" << dir
     << "/torques.png.tmp'\nset multiplot layout 2,3 title 'Joint torques, every body'\n"
     << "set grid\nset xlabel 'time (s)'\nset ylabel 'N m'\nset key top left font ',8'\n";
  const size_t n = all.size();
  for (size_t p = 0; p < plotted_dofs().size(); ++p) {
    gp << "set title '" << plotted_dofs()[p].second << "'\nplot ";
    for (size_t b = 0; b < n; ++b) {
      gp << (b ? ", " : "") << "'" << dir << "/torques_plot.dat' index " << p * n + b
         << " with lines lw 1.5 title '" << all[b].body.name << "'";
    }
    gp << "\n";
  }
  gp << "unset multiplot\n";
  write_file_atomically(dir + "/torques.gp", gp.str());
  plot_with_gnuplot("evaluate", dir + "/torques.gp", dir + "/torques.png.tmp",
                    dir + "/torques.png");
  return dir + "/torques.png";
}

std::string base64(const std::string& bytes) {
  static const char* k = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  size_t i = 0;
  for (; i + 2 < bytes.size(); i += 3) {
    const unsigned v = (static_cast<unsigned char>(bytes[i]) << 16) |
                       (static_cast<unsigned char>(bytes[i + 1]) << 8) |
                       static_cast<unsigned char>(bytes[i + 2]);
    for (int s = 18; s >= 0; s -= 6) out += k[(v >> s) & 63];
  }
  if (i < bytes.size()) {
    unsigned v = static_cast<unsigned char>(bytes[i]) << 16;
    if (i + 1 < bytes.size()) v |= static_cast<unsigned char>(bytes[i + 1]) << 8;
    out += k[(v >> 18) & 63];
    out += k[(v >> 12) & 63];
    out += i + 1 < bytes.size() ? k[(v >> 6) & 63] : '=';
    out += '=';
  }
  return out;
}

std::string html_escape(const std::string& s) {
  std::string out;
  for (char c : s) {
    if (c == '<')
      out += "&lt;";
    else if (c == '>')
      out += "&gt;";
    else if (c == '&')
      out += "&amp;";
    else
      out += c;
  }
  return out;
}

/// The report's joint-load cell: the longest stretch over tau_max and the peak, with their DOFs.
std::string load_cell(const scenarios::JointLoadReport& r) {
  std::ostringstream s;
  s << std::fixed << std::setprecision(3) << r.over_longest_s << " s";
  if (!r.over_longest_dof.empty()) s << " " << r.over_longest_dof;
  s << std::setprecision(2) << " (" << r.load_peak_ratio << "x " << r.load_peak_dof << ")";
  return html_escape(s.str());
}

/// report.html: the torque plot, the feasibility table and the assumptions, in one file.
std::string report_html(const EvaluateCli& o, const std::vector<scenarios::BodyEvaluation>& all,
                        const std::string& png) {
  std::ostringstream h;
  h.precision(3);
  h << "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>biodyn evaluate: "
    << html_escape(fs::path(o.motion).filename().string())
    << "</title><style>body{font-family:sans-serif;margin:2em}table{border-collapse:collapse}"
       "td,th{border:1px solid #999;padding:4px 8px;text-align:right}"
       "td.l,th.l{text-align:left}.no{color:#b00}.yes{color:#070}</style></head><body>\n"
    << "<h1>Can these bodies do " << html_escape(o.motion) << "?</h1>\n"
    << "<h2>Feasibility</h2>\n<table id=\"feasibility\"><tr><th class=\"l\">body</th><th>height "
       "(m)</th><th>mass (kg)</th><th class=\"l\">profile</th><th class=\"l\">tau_max</th><th "
       "class=\"l\">verdict</th><th>peak tau/tau_max</th><th class=\"l\">first to saturate</th>"
       "<th>tracking joint RMS (deg)</th><th>fell at (s)</th><th class=\"l\">tracking motor + "
       "stop over tau_max: longest (peak)</th><th>residual force RMS (N)</th></tr>\n";
  for (const scenarios::BodyEvaluation& e : all) {
    double peak = 0;
    for (const scenarios::JointEvaluation& j : e.joints) peak = std::max(peak, j.peak_ratio);
    h << "<tr><td class=\"l\">" << html_escape(e.body.name) << "</td><td>" << e.body.spec.height_m
      << "</td><td>" << e.body.spec.mass_kg << "</td><td class=\"l\">" << e.body.profile
      << "</td><td class=\"l\">"
      << (e.body.tau_rule == scenarios::TauMaxRule::kFixed ? "fixed" : "scaled")
      << "</td><td class=\"l " << (e.feasible ? "yes" : "no") << "\">" << html_escape(e.verdict)
      << "</td><td>" << peak << "</td><td class=\"l\">" << e.first_saturating_joint << "</td><td>"
      << (e.tracked ? std::to_string(e.joint_rms_deg) : "-") << "</td><td>"
      << (e.fell_at_s >= 0 ? std::to_string(e.fell_at_s) : "-") << "</td><td>"
      << (e.tracked ? load_cell(e.joint_load_tracked) : "-") << "</td><td>"
      << e.residual_force_rms_N << "</td></tr>\n";
  }
  std::ifstream in(png, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  h << "</table>\n<h2>Joint torques</h2>\n<img id=\"torques\" alt=\"joint torques of every body\" "
       "src=\"data:image/png;base64,"
    << base64(bytes) << "\">\n<h2>Assumptions</h2>\n<ul id=\"assumptions\">\n";
  const json notes = assumptions(o);
  for (auto it = notes.begin(); it != notes.end(); ++it)
    h << "<li><b>" << it.key() << "</b>: " << html_escape(it.value().get<std::string>())
      << "</li>\n";
  h << "</ul>\n</body></html>\n";
  return h.str();
}

/// The name of a capture's IK output in the output directory (.csv, .json, .body.json, .xml).
constexpr const char* kCaptureIk = "capture_ik";

int run_evaluate(EvaluateCli o) {
  check_outputs({{"-o", o.output, true}}, {o.motion, o.bodies});
  if (o.tracking != "on" && o.tracking != "off")
    throw sim::InvalidArgument("--tracking: expected on or off, got '" + o.tracking + "'");
  o.options.tracking = o.tracking == "on";
  const std::vector<scenarios::EvaluationBody> bodies =
      scenarios::parse_bodies(read_file(o.bodies), o.bodies);
  const Format format = format_of(o.motion, "--motion");
  const bool capture = format == Format::kC3d || format == Format::kTrc;
  if (capture) {
    for (const scenarios::EvaluationBody& b : bodies)
      if (b.name == kCaptureIk)
        throw sim::InvalidArgument(o.bodies + ": body name '" + b.name +
                                   "' is the capture's IK output's; rename the body");
  } else if (o.lab_up != "z" || !o.markerset.empty()) {
    throw sim::InvalidArgument("--lab-up/--markerset: only for a C3D or TRC --motion");
  }
  fs::create_directories(o.output);
  // A capture's markers become a motion first, as `mocap ik` makes it (its body scaled by the
  // trial at 80 kg: the fixed tau_max rule's body).
  std::string motion = o.motion;
  json ik_status;
  if (capture) {
    motion = o.output + "/" + kCaptureIk + ".csv";
    run_capture_ik(o.motion, "--motion", o.lab_up, o.markerset, motion,
                   o.output + "/" + kCaptureIk + ".json");
    ik_status = json::parse(read_file(o.output + "/" + kCaptureIk + ".json"))["status"];
  }
  std::vector<scenarios::BodyEvaluation> all;
  {
    ProgressBar bar("evaluate: " + std::to_string(bodies.size()) + " bodies");
    all = scenarios::evaluate_motion(motion, bodies, o.options, o.output, [&](int done, int total) {
      bar.update(double(done) / total);
    });
  }
  json summary = {{"motion", o.motion}, {"bodies_file", o.bodies}, {"assumptions", assumptions(o)}};
  if (capture) {
    summary["motion_ik"] = {{"file", motion},
                            {"lab_up", o.lab_up},
                            {"markerset", o.markerset.empty() ? "(by labels)" : o.markerset},
                            {"status", ik_status}};
  }
  json list = json::array();
  for (const scenarios::BodyEvaluation& e : all) list.push_back(body_json(e));
  summary["bodies"] = list;
  // The plot first (gnuplot may fail): then no CSV, summary or report is left half a set.
  const std::string png = torque_plot(o.output, all);
  for (const scenarios::BodyEvaluation& e : all) {
    if (e.error.empty()) write_file_atomically(o.output + "/" + e.body.name + ".csv", body_csv(e));
  }
  write_file_atomically(o.output + "/summary.json", summary.dump(1) + "\n");
  write_file_atomically(o.output + "/report.html", report_html(o, all, png));
  std::cout << "evaluate: " << o.motion << " on " << all.size() << " bodies\n";
  for (const scenarios::BodyEvaluation& e : all)
    std::cout << "  " << e.body.name << " (" << e.body.spec.height_m << " m, "
              << e.body.spec.mass_kg << " kg): " << e.verdict << " [" << e.wall_s << " s]\n";
  std::cout << "wrote " << o.output << "/{<body>.csv, summary.json, report.html}\n";
  // Every body failed to evaluate (not "cannot do it": an answer): the run did not answer.
  const bool any = std::any_of(all.begin(), all.end(),
                               [](const scenarios::BodyEvaluation& e) { return e.error.empty(); });
  return any ? kExitOk : kExitFailure;
}

}  // namespace

Command add_evaluate_command(CLI::App* app) {
  auto o = std::make_shared<EvaluateCli>();
  CLI::App* cmd = app->add_subcommand(
      "evaluate",
      "Can these bodies do this motion? A motion on a list of bodies: ground forces, "
      "torques, muscles, physics tracking; CSV, JSON and an HTML report");
  cmd->add_option("--motion", o->motion,
                  "qpos CSV (with its body, from mocap ik/retarget), BVH, or a C3D/TRC capture "
                  "(marker IK first, as mocap ik with its defaults: <output>/capture_ik.csv)")
      ->required();
  cmd->add_option("--bodies", o->bodies,
                  "bodies.json: {\"bodies\": [{\"name\", \"height_m\", \"mass_kg\", \"sex\", "
                  "\"profile\": standard|heavy_trunk_thighs, \"tau_max\": scaled|fixed}]}")
      ->required();
  cmd->add_option("--tracking", o->tracking, "on: SAMCON physics tracking per body (costly); off")
      ->capture_default_str();
  cmd->add_option("--parents", o->options.samcon.parents, "tracking: states kept per window")
      ->capture_default_str();
  cmd->add_option("--children", o->options.samcon.children, "tracking: rollouts per state")
      ->capture_default_str();
  cmd->add_option("--seed", o->options.samcon.seed, "tracking: random seed of the search")
      ->capture_default_str();
  cmd->add_option("--lab-up", o->lab_up, "a capture's vertical axis, z or y (as mocap ik)")
      ->capture_default_str();
  cmd->add_option("--markerset", o->markerset,
                  "a capture's marker set (as mocap ik; default: the built-in set sharing the "
                  "most labels)");
  cmd->add_option("--threads", o->options.threads, "bodies in parallel (0: every core)")
      ->capture_default_str();
  cmd->add_option("-o,--output", o->output, "output directory")->required();
  return {cmd, [o]() { return run_evaluate(*o); }};
}

}  // namespace biodyn::apps
