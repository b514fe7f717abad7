// biodyn push-sweep: the push protocol of references.md during steady walking, per direction x
// duration x onset phase (scenarios/push_sweep.h), on all cores: one model copy per worker
// thread; results do not depend on the thread count (every cell is its own deterministic run).
#include <algorithm>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>

#include "biodyn/models/mjcf.h"
#include "biodyn/scenarios/push_sweep.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/model.h"
#include "cli_common.h"
#include "commands.h"
#include "walk_options.h"

namespace biodyn::apps {
namespace {

struct SweepOptions {
  WalkOptions walk;
  scenarios::PushSweepSpec spec;
  std::string durations = "0.1,0.2,0.5";
  bool no_bisect = false;
  std::string body = "pelvis";
  int settle_strides = 5;
  int threads = 0;
  std::string out;
};

// Runs every cell on `threads` workers, each on its own copy of the model; a progress bar.
std::vector<scenarios::PushCellResult> run_cells(const scenarios::PushSweepSpec& spec,
                                                 const std::string& mjcf,
                                                 const std::vector<scenarios::PushSweepCell>& cells,
                                                 int threads) {
  std::vector<scenarios::PushCellResult> results(cells.size());
  run_batch(cells.size(), threads, mjcf, "push-sweep", [&](sim::Simulation* sim, std::size_t i) {
    results[i] = scenarios::run_push_cell(sim, spec, cells[i]);
  });
  return results;
}

// results.csv: one line per cell.
std::string results_csv(const scenarios::PushSweepSpec& spec,
                        const std::vector<scenarios::PushCellResult>& results, double mass) {
  std::ostringstream csv;
  csv << std::setprecision(10);
  csv << "direction_deg,duration_s,onset_phase,max_survived_N,first_failure_N,bisection_N,"
         "max_survived_impulse_N_s,max_survived_delta_v_m_s,fixed_force_N,fixed_survived,failure,"
         "runs\n";
  for (const scenarios::PushCellResult& r : results) {
    const scenarios::PushSweepCell& c = r.cell;
    csv << c.direction_deg << ',' << c.duration_s << ',' << c.onset_phase << ',';
    if (spec.fixed_force_N > 0) {
      csv << ",,,,," << spec.fixed_force_N << ','
          << (r.outcome == scenarios::PushOutcome::kSurvived ? 1 : 0) << ",\"" << r.failure << "\","
          << r.runs << '\n';
    } else {
      csv << r.max_survived_N << ',' << r.first_failure_N << ',' << r.bisection_N << ','
          << r.max_survived_N * c.duration_s << ',' << r.max_survived_N * c.duration_s / mass
          << ",,,\"" << r.failure << "\"," << r.runs << '\n';
    }
  }
  return csv.str();
}

// summary.json's cells, and the polar plot's data (each duration's curve closed by its first
// direction again).
nlohmann::json summary_cells(const scenarios::PushSweepSpec& spec,
                             const scenarios::PushSweepSummary& summary, double mass,
                             std::string* plot_data, double* plot_max) {
  nlohmann::json cells = nlohmann::json::array();
  std::ostringstream plot;
  const bool fixed = spec.fixed_force_N > 0;
  const std::size_t per_duration = static_cast<std::size_t>(spec.directions);
  for (std::size_t d = 0; d < spec.durations_s.size(); ++d) {
    plot << "# duration " << spec.durations_s[d] << " s: direction_deg worst_N mean_N\n";
    for (std::size_t k = 0; k <= per_duration; ++k) {
      const scenarios::PushSweepGroup& g = summary.groups[d * per_duration + k % per_duration];
      if (fixed) {  // share of phases survived, %
        plot << g.direction_deg << ' ' << 100.0 * g.survived_phases / g.phases << ' '
             << 100.0 * g.survived_phases / g.phases << '\n';
        *plot_max = 100;
      } else {
        plot << g.direction_deg << ' ' << g.max_survived_worst_N << ' ' << g.max_survived_mean_N
             << '\n';
        *plot_max = std::max(*plot_max, g.max_survived_mean_N);
      }
      if (k == per_duration) continue;
      nlohmann::json c = {
          {"direction_deg", g.direction_deg}, {"duration_s", g.duration_s}, {"phases", g.phases}};
      if (fixed) {
        c["force_N"] = spec.fixed_force_N;
        c["survived_phases"] = g.survived_phases;
      } else {
        c["max_survived_N_worst_phase"] = g.max_survived_worst_N;
        c["max_survived_N_mean"] = g.max_survived_mean_N;
        c["delta_v_m_s_worst_phase"] = g.max_survived_worst_N * g.duration_s / mass;
        c["delta_v_m_s_mean"] = g.max_survived_mean_N * g.duration_s / mass;
        if (spec.scan.bisect) {
          c["bisection_N_worst_phase"] = g.bisection_worst_N;
          c["bisection_N_mean"] = g.bisection_mean_N;
        }
      }
      c["walk_failed_before_push"] = g.walk_failed_before_push;
      cells.push_back(c);
    }
    plot << "\n\n";
  }
  *plot_data = plot.str();
  return cells;
}

// polar.gp and polar.png through gnuplot.
void plot_polar(const SweepOptions& o, const std::string& dir, double plot_max) {
  const scenarios::PushSweepSpec& spec = o.spec;
  const bool fixed = spec.fixed_force_N > 0;
  std::ostringstream gp;
  gp << "set terminal pngcairo size 900,900 font 'sans,11'\n"
     << "set output '" << dir << "/polar.png.tmp'\n"
     << "set polar\nset angles degrees\nset size square\nunset border\nunset xtics\nunset ytics\n"
     << "set grid polar 45\nset rtics\nset rrange [0:" << std::max(1.1 * plot_max, 1.0) << "]\n"
     << "set key outside bottom center horizontal\n"
     << "set title \""
     << (fixed ? "Share of onset phases surviving a " +
                     std::to_string(static_cast<int>(spec.fixed_force_N)) + " N push, %"
               : std::string("Largest push force survived (upward scan), N"))
     << "\\n0 deg = forward, 90 deg = left; " << o.body << ", weld " << o.walk.weld << ", "
     << spec.walk.config.speed_m_s << " m/s\"\n"
     << "plot ";
  for (std::size_t i = 0; i < spec.durations_s.size(); ++i) {
    const double duration = spec.durations_s[i];
    if (fixed) {
      gp << (i ? ", " : "") << "'" << dir << "/polar.dat' index " << i
         << " using 1:2 with linespoints lw 2 title '" << duration << " s: % of phases survived'";
      continue;
    }
    gp << (i ? ", " : "") << "'" << dir << "/polar.dat' index " << i
       << " using 1:2 with linespoints lw 2 title '" << duration << " s, worst phase', '" << dir
       << "/polar.dat' index " << i << " using 1:3 with lines dt 2 title '" << duration
       << " s, mean'";
  }
  gp << "\n";
  write_file_atomically(dir + "/polar.gp", gp.str());
  plot_with_gnuplot("push-sweep", dir + "/polar.gp", dir + "/polar.png.tmp", dir + "/polar.png");
}

// A few lines a person reads.
void print_summary(const SweepOptions& o, const nlohmann::json& cells,
                   const scenarios::PushSweepSummary& summary, std::size_t cell_count,
                   const std::string& dir) {
  const bool fixed = o.spec.fixed_force_N > 0;
  std::cout << std::fixed << std::setprecision(0);
  for (const auto& c : cells) {
    std::cout << "  " << std::setw(4) << c["direction_deg"].get<double>() << " deg, "
              << std::setprecision(2) << c["duration_s"].get<double>()
              << " s: " << std::setprecision(0);
    if (fixed) {
      std::cout << c["survived_phases"].get<int>() << "/" << c["phases"].get<int>()
                << " phases survived\n";
    } else {
      std::cout << "max survived " << c["max_survived_N_worst_phase"].get<double>()
                << " N worst phase, " << c["max_survived_N_mean"].get<double>() << " N mean";
      if (o.spec.scan.bisect)
        std::cout << " (bisection: " << c["bisection_N_mean"].get<double>() << " N mean)";
      std::cout << "\n";
    }
  }
  if (fixed) {
    std::cout << std::setprecision(1) << "  survived "
              << 100.0 * static_cast<double>(summary.pushes_survived) /
                     static_cast<double>(cell_count)
              << "% of " << cell_count << " pushes of " << o.spec.fixed_force_N << " N\n";
  }
  if (summary.groups_with_failed_walks > 0) {
    std::cout << "  WARNING: no push (the walk fell before it, or never became steady) in "
              << summary.groups_with_failed_walks
              << " direction/duration groups; results.csv says which cells and why\n";
  }
  std::cout << "  results:  " << dir << "/results.csv\n  summary:  " << dir
            << "/summary.json\n  plot:     " << dir << "/polar.png\n";
}

int run_sweep(SweepOptions& o) {
  if (o.body != "pelvis" && o.body != "trunk")
    throw sim::InvalidArgument("--body: expected pelvis or trunk, got '" + o.body + "'");
  scenarios::PushSweepSpec& spec = o.spec;
  spec.durations_s =
      parse_number_list(o.durations, "--durations", "durations in s separated by commas");
  spec.scan.bisect = !o.no_bisect;
  spec.walk = o.walk.to_params();
  scenarios::WalkPush push;
  push.body = o.body;
  push.settle_strides = o.settle_strides;
  spec.walk.config.walk_push = push;
  spec.validate();  // before any worker starts
  const std::vector<scenarios::PushSweepCell> cells = scenarios::push_sweep_cells(spec);
  const int threads = batch_threads(o.threads, cells.size());
  const models::CharacterSpec character_spec = spec.walk.config.model_spec();
  const models::Character character = models::generate_character(character_spec);
  const std::string mjcf = models::to_mjcf(character, o.walk.physics());
  const double mass = character.total_mass_kg();
  std::cout << "biodyn push-sweep: " << cells.size() << " cells (" << spec.directions
            << " directions x " << spec.durations_s.size() << " durations x " << spec.phases
            << " phases) on " << threads << " threads; " << o.body << " pushes after "
            << o.settle_strides << " strides and 4 steady ones, speed "
            << spec.walk.config.speed_m_s << " m/s, weld " << o.walk.weld << ", timestep "
            << 1000 * o.walk.timestep_s << " ms" << o.walk.terrain.text() << "\n"
            << "  " << weld_assumption(o.walk.weld) << "\n";
  const std::vector<scenarios::PushCellResult> results = run_cells(spec, mjcf, cells, threads);
  const scenarios::PushSweepSummary summary = scenarios::summarize_push_sweep(spec, results);

  std::string plot_data;
  double plot_max = 0;
  const nlohmann::json cell_json = summary_cells(spec, summary, mass, &plot_data, &plot_max);
  nlohmann::json j = {
      {"cells", cell_json},
      {"protocol",
       "references.md: horizontal push through the body's CoM, direction relative to the heading, "
       "onset "
       "spread over the stride after the settle strides and 4 steady strides (each within 5% of "
       "their "
       "mean speed); survived = only the feet touch the ground "
       "for "
       "5 s after the push, pelvis >= 0.7 x standing height, stride speed back within 10% by the "
       "4th "
       "stride. max_survived_N: the force below the first failure of an upward scan (every smaller "
       "force at the resolution survived); bisection_N assumes monotonic survival and overstates."},
      {"weld", o.walk.weld},
      {"weld_assumption", weld_assumption(o.walk.weld)},
      {"body_mass_kg", mass},
      {"resolution_N", spec.scan.resolution_N},
      {"max_force_N", spec.scan.max_force_N},
      {"threads", threads},
      {"inputs", o.walk.inputs_json(character_spec)}};
  j["inputs"]["body"] = o.body;
  j["inputs"]["settle_strides"] = o.settle_strides;
  if (spec.fixed_force_N > 0) {
    j["fixed_force_N"] = spec.fixed_force_N;
    j["survived_fraction"] =
        static_cast<double>(summary.pushes_survived) / static_cast<double>(results.size());
  }
  j["cells_where_the_walk_failed_before_the_push"] = summary.groups_with_failed_walks;

  std::filesystem::create_directories(o.out);
  const std::string& dir = o.out;
  write_file_atomically(dir + "/results.csv", results_csv(spec, results, mass));
  write_file_atomically(dir + "/summary.json", j.dump(2) + "\n");
  write_file_atomically(dir + "/polar.dat", plot_data);
  plot_polar(o, dir, plot_max);
  print_summary(o, cell_json, summary, results.size(), dir);
  return kExitOk;
}

}  // namespace

Command add_push_sweep_command(CLI::App* app) {
  auto o = std::make_shared<SweepOptions>();
  CLI::App* cmd = app->add_subcommand(
      "push-sweep",
      "Push protocol during steady walking: per direction x duration x phase, upward force scans");
  cmd->add_option("--directions", o->spec.directions, "Directions, evenly spaced from forward")
      ->capture_default_str();
  cmd->add_option("--durations", o->durations, "Push durations, s")->capture_default_str();
  cmd->add_option("--phases", o->spec.phases, "Onsets spread over one stride")
      ->capture_default_str();
  cmd->add_option("--resolution", o->spec.scan.resolution_N, "Force step of the upward scan, N")
      ->capture_default_str();
  cmd->add_option("--max-force", o->spec.scan.max_force_N, "Largest force tried, N")
      ->capture_default_str();
  cmd->add_flag("--no-bisect", o->no_bisect,
                "Skip the bisection figure (reported beside the scan)");
  cmd->add_option(
      "--fixed-force", o->spec.fixed_force_N,
      "Instead of scanning: one push of this force per cell; reports the share survived");
  cmd->add_option("--body", o->body, "Pushed body: pelvis | trunk")->capture_default_str();
  cmd->add_option(
         "--settle-strides", o->settle_strides,
         "Strides before the push's stride (at least: the push also waits for 4 steady strides)")
      ->capture_default_str();
  cmd->add_option("--threads", o->threads, "Worker threads (default: all cores)");
  o->walk.add_to(cmd);
  cmd->add_option("--out", o->out, "Output directory (results.csv, summary.json, polar.png)")
      ->required();
  return {cmd, [o]() { return run_sweep(*o); }};
}

}  // namespace biodyn::apps
