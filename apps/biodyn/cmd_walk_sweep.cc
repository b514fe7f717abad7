// biodyn walk-sweep: walks from standing on seeded random bodies (scenarios/walk_sweep.h) on all
// cores, each walk generating its own character; results do not depend on the thread count
// (every walk is its own deterministic run). A failed walk prints its body's seed and the
// `biodyn walk` line that walks it again.
#include <algorithm>
#include <iomanip>
#include <iostream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>

#include "biodyn/models/mjcf.h"
#include "biodyn/scenarios/walk_sweep.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/model.h"
#include "cli_common.h"
#include "commands.h"
#include "walk_options.h"

namespace biodyn::apps {
namespace {

struct WalkSweepOptions {
  WalkOptions walk;
  scenarios::WalkSweepSpec spec;
  std::string speeds;
  int threads = 0;
  std::string out;
  CLI::App* cmd = nullptr;
};

// The `biodyn walk` line that walks one of the sweep's walks alone, the same run to the bit.
std::string replay_line(const WalkSweepOptions& o, const scenarios::SweepWalk& w) {
  WalkOptions one = o.walk;
  one.character.height_m = w.body.height_m;
  one.character.mass_kg = w.body.mass_kg;
  one.character.sex = models::to_string(w.body.sex);
  std::ostringstream line;
  line << std::setprecision(6) << "biodyn walk --speed " << w.speed_m_s << " --duration "
       << o.spec.duration_s << " " << one.replay_args();
  return line.str();
}

std::string results_csv(const std::vector<scenarios::SweepWalkResult>& results) {
  std::ostringstream csv;
  csv << std::setprecision(10)
      << "seed,height_m,mass_kg,sex,speed_m_s,fallen,diverged,fell_at_s,distance_m,mean_speed_m_s,"
         "steady_speed_m_s,lateral_drift_m,max_foot_slip_m,steps\n";
  for (const scenarios::SweepWalkResult& r : results) {
    const scenarios::SweepWalk& w = r.walk;
    csv << w.seed << ',' << w.body.height_m << ',' << w.body.mass_kg << ','
        << models::to_string(w.body.sex) << ',' << w.speed_m_s << ',' << r.fallen << ','
        << r.diverged << ',' << r.fell_at_s << ',' << r.distance_m << ',' << r.mean_speed_m_s << ','
        << r.steady_speed_m_s << ',' << r.lateral_drift_m << ',' << r.max_foot_slip_m << ','
        << r.steps << '\n';
  }
  return csv.str();
}

// walks.png: left, each walk's time walked against its speed (a fall below the duration);
// right, the bodies (height, mass) with the walks that fell marked and their speeds. One data block
// per group that has walks (gnuplot's `index` counts blocks).
void plot_walks(const WalkSweepOptions& o, const std::string& dir,
                const std::vector<scenarios::SweepWalkResult>& results) {
  std::ostringstream data, speed_plot, body_plot;
  int block = 0;
  for (const bool fallen : {false, true}) {
    int n = 0;
    for (const scenarios::SweepWalkResult& r : results) {
      if (r.fallen != fallen) continue;
      data << r.walk.speed_m_s << ' ' << (fallen ? r.fell_at_s : o.spec.duration_s) << ' '
           << r.walk.body.height_m << ' ' << r.walk.body.mass_kg << '\n';
      ++n;
    }
    if (n == 0) continue;
    data << "\n\n";
    const std::string style = fallen ? "pt 2 ps 1.5 lc rgb '#c0392b' title 'fell'"
                                     : "pt 7 lc rgb '#2a9d3a' title 'walked to the end'";
    speed_plot << "'" << dir << "/walks.dat' index " << block << " using 1:2 with points " << style
               << ", ";
    body_plot << "'" << dir << "/walks.dat' index " << block << " using 3:4 with points " << style
              << ", ";
    ++block;
  }
  // Beside each body that fell, the speeds it fell at (a body walks several speeds).
  std::map<std::uint64_t, std::string> fell_at;
  std::ostringstream labels;
  for (const scenarios::SweepWalkResult& r : results) {
    if (!r.fallen) continue;
    std::ostringstream v;
    v << r.walk.speed_m_s;
    std::string& text = fell_at[r.walk.seed];
    text += (text.empty() ? "" : ", ") + v.str();
  }
  for (const scenarios::SweepWalkResult& r : results) {
    const auto it = fell_at.find(r.walk.seed);
    if (it == fell_at.end() || it->second.empty()) continue;
    labels << "set label '" << it->second << " m/s' at " << r.walk.body.height_m << ','
           << r.walk.body.mass_kg << " offset 0,1 center tc rgb '#c0392b'\n";
    it->second.clear();  // one label per body
  }
  write_file_atomically(dir + "/walks.dat", data.str());
  std::string speeds = speed_plot.str(), bodies = body_plot.str();
  speeds.resize(speeds.size() - 2);  // the last ", "
  bodies.resize(bodies.size() - 2);
  std::ostringstream gp;
  gp << "set terminal pngcairo size 1400,600 font 'sans,11'\n"
     << "set output '" << dir << "/walks.png.tmp'\n"
     << "set multiplot layout 1,2 title 'Walks from standing: " << results.size() << " walks of "
     << o.spec.bodies << " random bodies, " << o.spec.duration_s << " s (weld " << o.walk.weld
     << ", " << o.walk.controller << ")'\n"
     << "set grid\nset key outside bottom center horizontal\n"
     << "set offsets graph 0.05, graph 0.05, 0, 0\n"
     << "set xlabel 'speed commanded, m/s'\nset ylabel 'time walked, s'\n"
     << "set yrange [0:" << 1.05 * o.spec.duration_s << "]\n"
     << "plot " << speeds << "\n"
     << "set xlabel 'height, m'\nset ylabel 'mass, kg'\nset autoscale y\n"
     << "set offsets graph 0.05, graph 0.05, graph 0.1, graph 0.05\n"
     << labels.str() << "plot " << bodies << "\n"
     << "unset multiplot\n";
  write_file_atomically(dir + "/walks.gp", gp.str());
  plot_with_gnuplot("walk-sweep", dir + "/walks.gp", dir + "/walks.png.tmp", dir + "/walks.png");
}

int run_walk_sweep(WalkSweepOptions& o) {
  for (const char* name :
       {"--speed", "--height", "--mass", "--sex", "--overrides", "--body-file"}) {
    if (o.cmd->count(name) > 0)
      throw sim::InvalidArgument(
          std::string(name) +
          ": walk-sweep draws each body (--height-min .. --height-max, --bmi-min .. --bmi-max, "
          "either sex) and walks it at --speeds (or a speed from --speed-min .. --speed-max)");
  }
  scenarios::WalkSweepSpec& spec = o.spec;
  spec.walk = o.walk.to_params();
  if (!o.speeds.empty())
    spec.speeds_m_s = parse_number_list(o.speeds, "--speeds", "speeds in m/s, e.g. 0.5,1.0,1.5");
  spec.validate();
  check_outputs({{"-o", o.out, true}}, {});
  const models::PhysicsOptions physics = o.walk.physics();
  const std::vector<scenarios::SweepWalk> walks = scenarios::random_sweep_walks(spec);
  const int threads = batch_threads(o.threads, walks.size());
  std::ostringstream speeds;
  if (spec.speeds_m_s.empty()) {
    speeds << "a speed each from " << spec.speed_min_m_s << "-" << spec.speed_max_m_s << " m/s";
  } else {
    speeds << "at ";
    for (std::size_t k = 0; k < spec.speeds_m_s.size(); ++k)
      speeds << (k ? ", " : "") << spec.speeds_m_s[k];
    speeds << " m/s";
  }
  std::cout << "biodyn walk-sweep: " << spec.bodies << " random bodies (height "
            << spec.height_min_m << "-" << spec.height_max_m << " m, BMI " << spec.bmi_min << "-"
            << spec.bmi_max << ", either sex), " << speeds.str() << ", " << spec.duration_s
            << " s from standing, seeds " << spec.seed << ".."
            << spec.seed + static_cast<std::uint64_t>(spec.bodies - 1) << ", weld " << o.walk.weld
            << ", controller " << o.walk.controller << ", " << threads << " threads"
            << o.walk.terrain.text() << "\n  " << weld_assumption(o.walk.weld) << "\n";
  std::vector<scenarios::SweepWalkResult> results(walks.size());
  run_jobs(walks.size(), threads, "walk-sweep", [&](std::size_t i) {
    scenarios::ScenarioConfig config = spec.walk.config;
    config.character = walks[i].body;
    sim::Simulation sim(sim::Model::from_string(
        models::to_mjcf(models::generate_character(config.model_spec()), physics), "<character>"));
    results[i] = scenarios::run_sweep_walk(&sim, spec, walks[i]);
  });

  int fallen = 0;
  nlohmann::json failed = nlohmann::json::array();
  for (const scenarios::SweepWalkResult& r : results) {
    if (!r.fallen) continue;
    ++fallen;
    const scenarios::SweepWalk& w = r.walk;
    std::ostringstream why;
    why << std::fixed << std::setprecision(2) << "fell at " << r.fell_at_s << " s"
        << (r.diverged ? " (the simulation diverged)" : "") << ": " << models::to_string(w.body.sex)
        << " " << w.body.height_m << " m / " << std::setprecision(1) << w.body.mass_kg << " kg at "
        << std::setprecision(2) << w.speed_m_s << " m/s";
    const std::string replay = replay_line(o, w);
    std::cout << "  FELL seed " << w.seed << ": " << why.str() << "\n    replay: " << replay
              << "\n";
    failed.push_back({{"seed", w.seed}, {"why", why.str()}, {"replay", replay}});
  }
  const int walked = static_cast<int>(results.size()) - fallen;
  const double share = static_cast<double>(walked) / static_cast<double>(results.size());
  std::cout << std::fixed << std::setprecision(1) << "  walked " << spec.duration_s
            << " s without falling: " << walked << " of " << results.size() << " (" << 100 * share
            << "%)\n";
  nlohmann::json inputs = o.walk.inputs_json(spec.walk.config.character);
  for (const char* key : {"height_m", "mass_kg", "sex", "speed_m_s"}) inputs.erase(key);
  nlohmann::json j = {
      {"walks", results.size()},
      {"walked", walked},
      {"fallen", fallen},
      {"walked_fraction", share},
      {"failed", failed},
      {"bodies", spec.bodies},
      {"seed", spec.seed},
      {"height_range_m", {spec.height_min_m, spec.height_max_m}},
      {"bmi_range", {spec.bmi_min, spec.bmi_max}},
      {"speeds_m_s", spec.speeds_m_s},
      {"speed_range_m_s", {spec.speed_min_m_s, spec.speed_max_m_s}},
      {"duration_s", spec.duration_s},
      {"threads", threads},
      {"weld_assumption", weld_assumption(o.walk.weld)},
      {"definition",
       "body k has seed + k: height uniform in the height range (to the cm), BMI uniform in the "
       "BMI range (mass = BMI x height^2, to 0.1 kg), either sex; it walks from standing at each "
       "of speeds_m_s (empty: at one speed drawn from speed_range_m_s, to the cm/s); a walk "
       "passes when the character does not fall for duration_s"},
      {"inputs", inputs}};
  const std::string& dir = o.out;
  write_file_atomically(dir + "/walks.csv", results_csv(results));
  write_file_atomically(dir + "/summary.json", j.dump(2) + "\n");
  plot_walks(o, dir, results);
  std::cout << "  results:  " << dir << "/walks.csv\n  summary:  " << dir
            << "/summary.json\n  plot:     " << dir << "/walks.png\n";
  return kExitOk;
}

}  // namespace

Command add_walk_sweep_command(CLI::App* app) {
  auto o = std::make_shared<WalkSweepOptions>();
  CLI::App* cmd = app->add_subcommand(
      "walk-sweep",
      "Walks from standing on seeded random bodies: the share that walks without falling");
  cmd->add_option("--bodies", o->spec.bodies, "Random bodies")->capture_default_str();
  cmd->add_option("--seed", o->spec.seed, "Seed of the first body (body k: seed + k)")
      ->capture_default_str();
  cmd->add_option("--height-min", o->spec.height_min_m, "Shortest body, m")->capture_default_str();
  cmd->add_option("--height-max", o->spec.height_max_m, "Tallest body, m")->capture_default_str();
  cmd->add_option("--bmi-min", o->spec.bmi_min, "Lowest BMI, kg/m^2")->capture_default_str();
  cmd->add_option("--bmi-max", o->spec.bmi_max, "Highest BMI, kg/m^2")->capture_default_str();
  cmd->add_option("--speeds", o->speeds,
                  "Commanded speeds every body walks, m/s, e.g. 0.5,1.0,1.5 (default: one speed "
                  "per body from --speed-min .. --speed-max)");
  cmd->add_option("--speed-min", o->spec.speed_min_m_s, "Slowest drawn speed, m/s")
      ->capture_default_str();
  cmd->add_option("--speed-max", o->spec.speed_max_m_s, "Fastest drawn speed, m/s")
      ->capture_default_str();
  cmd->add_option("--duration", o->spec.duration_s, "Each walk's length, s")->capture_default_str();
  cmd->add_option("--threads", o->threads, "Worker threads (default: all cores)");
  o->walk.add_to(cmd);
  cmd->add_option("--out,-o", o->out, "Output directory (walks.csv, summary.json, walks.png)")
      ->required();
  o->cmd = cmd;
  return {cmd, [o]() { return run_walk_sweep(*o); }};
}

}  // namespace biodyn::apps
