// biodyn gait: a walk's gait beside normative adult walking (Winter 2009; Perry & Burnfield
// 2010) and beside captured walks: the figures human walking is judged by (issue 28) and a plot
// of the mean cycles.
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>

#include "biodyn/mocap_io/motion_csv.h"
#include "biodyn/models/mjcf.h"
#include "biodyn/scenarios/gait_analysis.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/file_io.h"
#include "biodyn/sim/model.h"
#include "cli_common.h"
#include "commands.h"
#include "walk_options.h"

namespace biodyn::apps {
namespace {

using nlohmann::json;

/// One analysed walk: where it came from and what the analysis found.
struct AnalysedWalk {
  std::string label;   ///< the file's stem, or "simulated"
  std::string source;  ///< how it was made, said for a person
  bool reference = false;
  scenarios::GaitAnalysis gait;
};

/// The <stem>.grf.csv beside a motion (biodyn walk --motion-out): each foot's vertical force,
/// frames x 2, on the motion's frames; empty when there is none.
Eigen::MatrixXd read_foot_forces(const std::string& motion_path, const mocap_io::Motion& motion) {
  const std::string path = ground_force_path(motion_path);
  if (!std::filesystem::exists(path)) return {};
  std::istringstream in(read_file(path));
  std::string line;
  int number = 0;
  std::vector<std::array<double, 2>> rows;
  while (std::getline(in, line)) {
    ++number;
    if (line.empty() || line[0] == '#') continue;
    if (line.rfind("time,", 0) == 0) {
      if (line != "time,fx_l,fy_l,fz_l,fx_r,fy_r,fz_r")
        throw sim::InvalidArgument(path + ":" + std::to_string(number) +
                                   ": header: expected time,fx_l,fy_l,fz_l,fx_r,fy_r,fz_r, got " +
                                   line);
      continue;
    }
    const std::vector<double> v = parse_number_list(line, path + ":" + std::to_string(number),
                                                    "7 numbers (time and two forces)");
    const std::size_t f = rows.size();
    if (v.size() != 7 || f >= motion.times_s.size() || std::abs(v[0] - motion.times_s[f]) > 1e-6) {
      throw sim::InvalidArgument(
          path + ":" + std::to_string(number) + ": expected 7 numbers at the motion's frame " +
          std::to_string(f) + " time " +
          (f < motion.times_s.size() ? std::to_string(motion.times_s[f]) : std::string("(none)")) +
          ", got '" + line + "'");
    }
    rows.push_back({v[3], v[6]});
  }
  if (rows.size() != motion.times_s.size()) {
    throw sim::InvalidArgument(path + ": " + std::to_string(rows.size()) +
                               " force rows for the motion's " +
                               std::to_string(motion.times_s.size()) + " frames");
  }
  Eigen::MatrixXd out(static_cast<Eigen::Index>(rows.size()), 2);
  for (std::size_t f = 0; f < rows.size(); ++f)
    out.row(static_cast<Eigen::Index>(f)) << rows[f][0], rows[f][1];
  return out;
}

AnalysedWalk analyse_file(const std::string& path, bool reference, double from_s) {
  AnalysedWalk w;
  w.label = std::filesystem::path(path).stem().string();
  w.reference = reference;
  const mocap_io::Motion all = mocap_io::read_motion_csv(path);
  std::vector<std::string> notes;
  const models::CharacterSpec spec = CharacterOptions().spec_for_motion(path, &notes);
  const sim::Model model =
      sim::Model::from_string(models::to_mjcf(models::generate_character(spec)), "character");
  mocap_io::check_motion_matches(all, *model, path);
  int first = 0;
  const mocap_io::Motion motion = mocap_io::longest_solved_span(all, &first);
  scenarios::GaitInput in;
  in.model = model.get();
  in.times_s = motion.times_s;
  in.qpos = motion.qpos;
  if (first == 0 && motion.frame_count() == all.frame_count())
    in.foot_force_N = read_foot_forces(path, all);
  in.from_s = from_s;
  w.gait = scenarios::analyse_gait(in);
  std::ostringstream s;
  s << path << " (" << motion.frame_count() << " frames; events from " << w.gait.events << ")";
  w.source = s.str();
  return w;
}

AnalysedWalk analyse_simulated(const WalkOptions& walk, double duration_s, double from_s) {
  scenarios::WalkRunParams p = walk.to_params();
  p.duration_s = duration_s;
  p.validate();
  const models::CharacterSpec spec = p.config.model_spec();
  const models::PhysicsOptions physics = walk.physics();
  std::string trace;
  scenarios::RecordedMotion rec;
  const scenarios::WalkRunResult r =
      run_walk_on(spec, physics, p, false, "walk", &trace, &rec, 100);
  if (r.fallen) {
    throw sim::Error("gait: the walk fell at " + std::to_string(r.time_fallen_s) +
                     " s: no gait to analyse");
  }
  const sim::Model model = sim::Model::from_string(
      models::to_mjcf(models::generate_character(spec), physics), "character");
  AnalysedWalk w;
  w.label = "simulated";
  std::ostringstream s;
  s << "biodyn walk: " << to_string(spec.sex) << " " << spec.height_m << " m " << spec.mass_kg
    << " kg, " << p.config.speed_m_s << " m/s, controller " << walk.controller << ", weld "
    << walk.weld << ", " << duration_s << " s (cycles from " << from_s
    << " s; events from the ground force)";
  w.source = s.str();
  w.gait = scenarios::analyse_gait(scenarios::gait_input(*model, rec, from_s));
  return w;
}

void print_table(const std::vector<AnalysedWalk>& walks, std::ostream& out) {
  out << std::fixed;
  out << "  " << std::left << std::setw(34) << "figure" << std::setw(18) << "human band";
  for (const AnalysedWalk& w : walks) out << std::setw(20) << w.label.substr(0, 19);
  out << "\n";
  const std::size_t rows = walks.front().gait.figures.size();
  for (std::size_t i = 0; i < rows; ++i) {
    const scenarios::GaitFigure& f0 = walks.front().gait.figures[i];
    std::ostringstream band;
    band << std::setprecision(f0.unit == "r" ? 2 : (f0.unit == "m" ? 3 : 0)) << std::fixed;
    if (f0.lo <= -5 && f0.unit == "deg")
      band << "<= " << f0.hi;
    else
      band << f0.lo << "-" << f0.hi;
    band << " " << f0.unit;
    out << "  " << std::setw(34) << f0.name << std::setw(18) << band.str();
    for (const AnalysedWalk& w : walks) {
      const scenarios::GaitFigure& f = w.gait.figures[i];
      std::ostringstream v;
      if (std::isfinite(f.value)) {
        v << std::fixed << std::setprecision(f.unit == "r" || f.unit == "m" ? 3 : 1) << f.value
          << (f.met() ? "" : " (out)");
      } else {
        v << "n/a";
      }
      out << std::setw(20) << v.str();
    }
    out << "\n";
  }
  out << std::right;
}

json analysed_walk_json(const AnalysedWalk& w) {
  const scenarios::GaitAnalysis& g = w.gait;
  json figures = json::array();
  for (const scenarios::GaitFigure& f : g.figures) {
    figures.push_back({{"name", f.name},
                       {"value", f.value},
                       {"unit", f.unit},
                       {"band", {f.lo, f.hi}},
                       {"band_source", f.source},
                       {"met", f.met()}});
  }
  json curves = json::object();
  for (int j = 0; j < 3; ++j) {
    std::vector<double> mean(g.mean_deg.col(j).data(),
                             g.mean_deg.col(j).data() + g.mean_deg.rows());
    curves[scenarios::kGaitJointNames[j]] = mean;
  }
  return {{"label", w.label},
          {"source", w.source},
          {"reference", w.reference},
          {"events", g.events},
          {"cycles", g.cycles},
          {"cycles_left_out", g.cycles_left_out},
          {"cycle_s", g.cycle_s},
          {"speed_m_s", g.speed_m_s},
          {"stride_length_m", g.stride_length_m},
          {"trunk_lean_mean_deg", g.trunk_lean_mean_deg},
          {"rms_from_normative_deg",
           {{"hip", g.rms_from_normative_deg[0]},
            {"knee", g.rms_from_normative_deg[1]},
            {"ankle", g.rms_from_normative_deg[2]}}},
          {"human_like", g.all_met()},
          {"figures", figures},
          {"mean_cycle_deg", curves}};
}

/// gait_cycle.csv: percent, the normative mean and SD, then each walk's mean and SD per joint.
std::string cycle_csv(const std::vector<AnalysedWalk>& walks, const Eigen::MatrixXd& norm_mean,
                      const Eigen::MatrixXd& norm_sd) {
  std::ostringstream csv;
  csv.precision(6);
  csv << "percent";
  for (const char* j : scenarios::kGaitJointNames)
    csv << ",normative_" << j << ",normative_" << j << "_sd";
  for (const AnalysedWalk& w : walks)
    for (const char* j : scenarios::kGaitJointNames)
      csv << "," << w.label << "_" << j << "," << w.label << "_" << j << "_sd";
  csv << "\n";
  for (int p = 0; p < scenarios::kGaitCyclePoints; ++p) {
    csv << p;
    for (int j = 0; j < 3; ++j) csv << "," << norm_mean(p, j) << "," << norm_sd(p, j);
    for (const AnalysedWalk& w : walks)
      for (int j = 0; j < 3; ++j) csv << "," << w.gait.mean_deg(p, j) << "," << w.gait.sd_deg(p, j);
    csv << "\n";
  }
  return csv.str();
}

/// gait.png: per joint the normative mean +- SD (grey), each walk's mean cycle (solid) and
/// each reference's (dashed), with each walk's toe off dotted.
void plot_cycles(const std::string& dir, const std::vector<AnalysedWalk>& walks) {
  static const char* colours[] = {"#b2182b", "#ef8a62", "#762a83", "#1b7837"};
  static const char* ref_colours[] = {"#2166ac", "#67a9cf", "#4d4d4d", "#01665e"};
  std::ostringstream gp;
  gp << "set terminal pngcairo size 1650,560 font 'sans,10' noenhanced\n"
     << "set output '" << dir << "/gait.png.tmp'\n"
     << "set datafile separator ','\n"
     << "set multiplot layout 1,3 title \"Mean gait cycle from heel strike, beside normative "
        "adult walking (grey: mean +- 1 SD; Winter 2009, Perry & Burnfield 2010); dashed: "
        "captured references; dotted: toe off\"\n"
     << "set xrange [0:100]\nset xtics 0,20,100\nset grid\nset xlabel '% gait cycle'\n"
     << "set key top left font ',9'\n";
  const char* titles[] = {"hip flexion (+) / extension, deg", "knee flexion, deg",
                          "ankle dorsiflexion (+) / plantarflexion, deg"};
  for (int j = 0; j < 3; ++j) {
    gp << "unset arrow\n";
    int walk_index = 0, ref_index = 0;
    for (const AnalysedWalk& w : walks) {
      const char* c = w.reference ? ref_colours[ref_index++ % 4] : colours[walk_index++ % 4];
      gp << "set arrow from first " << w.gait.stance_percent << ", graph 0 to first "
         << w.gait.stance_percent << ", graph 1 nohead dt 3 lc rgb '" << c << "'\n";
    }
    gp << "set title '" << titles[j] << "'\n"
       << "plot '" << dir << "/gait_cycle.csv' skip 1 using 1:($" << 2 + 2 * j << "-$" << 3 + 2 * j
       << "):($" << 2 + 2 * j << "+$" << 3 + 2 * j
       << ") with filledcurves fc rgb '#cccccc' fs solid 0.6 title 'normative +- SD', '' skip 1 "
          "using 1:"
       << 2 + 2 * j << " with lines lw 2 lc rgb '#000000' title 'normative'";
    walk_index = 0;
    ref_index = 0;
    for (std::size_t k = 0; k < walks.size(); ++k) {
      const AnalysedWalk& w = walks[k];
      const int column = 8 + 6 * static_cast<int>(k) + 2 * j;
      const char* c = w.reference ? ref_colours[ref_index++ % 4] : colours[walk_index++ % 4];
      gp << ", '' skip 1 using 1:" << column << " with lines lw 2" << (w.reference ? " dt 2" : "")
         << " lc rgb '" << c << "' title '" << w.label << "'";
    }
    gp << "\n";
  }
  gp << "unset multiplot\n";
  write_file_atomically(dir + "/gait.gp", gp.str());
  plot_with_gnuplot("gait", dir + "/gait.gp", dir + "/gait.png.tmp", dir + "/gait.png");
}

}  // namespace

Command add_gait_command(CLI::App* app) {
  struct Options {
    WalkOptions walk;
    std::vector<std::string> motions, references;
    double duration_s = 30, from_s = -1;
    std::string out;
  };
  auto o = std::make_shared<Options>();
  CLI::App* cmd = app->add_subcommand(
      "gait",
      "A walk's gait beside normative adult walking and captured walks: the figures (knee, hip, "
      "ankle, trunk, stance, cadence, curve correlations) and a plot of the mean cycles. Without "
      "--motion it walks first (the walk options as in biodyn walk)");
  cmd->add_option("--motion", o->motions,
                  "Motion CSV to analyse (biodyn walk --motion-out: its <stem>.grf.csv gives the "
                  "events; else the soles' heights do); repeat for more");
  cmd->add_option("--reference", o->references,
                  "Motion CSV of a captured walk (e.g. biodyn mocap ik's), drawn dashed; repeat");
  cmd->add_option("--duration", o->duration_s, "Without --motion: the walk's simulated time, s")
      ->capture_default_str();
  cmd->add_option("--from", o->from_s,
                  "Analyse cycles from this time, s (default: 5 for a walk simulated here or a "
                  "--motion, 0 for a --reference)");
  cmd->add_option("-o,--out", o->out, "Output directory: gait.json, gait_cycle.csv, gait.png")
      ->required();
  o->walk.add_to(cmd);
  return {cmd, [o]() {
            std::vector<std::string> inputs = o->motions;
            inputs.insert(inputs.end(), o->references.begin(), o->references.end());
            check_outputs({{"-o", o->out, true}}, inputs);
            std::vector<AnalysedWalk> walks;
            const double from = o->from_s >= 0 ? o->from_s : scenarios::kWalkStartup_s;
            if (o->motions.empty())
              walks.push_back(analyse_simulated(o->walk, o->duration_s, from));
            for (const std::string& m : o->motions) walks.push_back(analyse_file(m, false, from));
            for (const std::string& r : o->references)
              walks.push_back(analyse_file(r, true, o->from_s >= 0 ? o->from_s : 0));
            std::cout << "biodyn gait: mean cycles from heel strike\n";
            for (const AnalysedWalk& w : walks) {
              std::cout << "  " << w.label << ": " << w.source << "; " << w.gait.cycles
                        << " cycles (" << w.gait.cycles_left_out << " left out), "
                        << std::setprecision(2) << std::fixed << w.gait.speed_m_s << " m/s\n";
            }
            print_table(walks, std::cout);
            Eigen::MatrixXd norm_mean, norm_sd;
            scenarios::normative_gait_curves(&norm_mean, &norm_sd);
            json j = {{"about",
                       "gait figures beside the human bands (issue 28; references.md); mean "
                       "cycles in degrees at every 1 % from heel strike; normative curves: "
                       "models/data/normative_gait.csv"},
                      {"walks", json::array()}};
            for (const AnalysedWalk& w : walks) j["walks"].push_back(analysed_walk_json(w));
            write_file_atomically(o->out + "/gait_cycle.csv", cycle_csv(walks, norm_mean, norm_sd));
            plot_cycles(o->out, walks);
            write_file_atomically(o->out + "/gait.json", json_text(j, 2) + "\n");
            std::cout << "  written: " << o->out << "/gait.json, gait_cycle.csv, gait.png\n";
            return kExitOk;
          }};
}

}  // namespace biodyn::apps
