// biodyn push-sweep: the push protocol of references.md during steady walking, per direction x
// duration x onset phase, on all cores (one model copy per worker; results do not depend on
// the thread count: every cell is its own deterministic run).
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <map>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <sstream>
#include <thread>

#include "biodyn/models/mjcf.h"
#include "biodyn/scenarios/walk.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/model.h"
#include "cli_common.h"
#include "commands.h"
#include "walk_options.h"

namespace biodyn::apps {
namespace {

struct CellResult {
  scenarios::WalkingPushCell cell;
  bool fixed_survived = false;  // --fixed-force mode
  std::string fixed_failure;
};

std::vector<double> durations_from(const std::string& text) {
  const std::vector<double> v = parse_number_list(text, "--durations", "durations in s separated by commas");
  if (v.empty()) throw sim::InvalidArgument("--durations: at least one duration");
  for (double x : v)
    if (!(x > 0 && x <= 10)) throw sim::InvalidArgument("--durations: each must be in (0, 10] s, got " + std::to_string(x));
  return v;
}

}  // namespace

Command add_push_sweep_command(CLI::App* app) {
  struct Options {
    WalkOptions walk;
    int directions = 8;
    std::string durations = "0.1,0.2,0.5";
    int phases = 10;
    scenarios::WalkingPushScanSettings scan;
    bool no_bisect = false;
    double fixed_force_N = 0;
    std::string body = "pelvis";
    int settle_strides = 5;
    int threads = 0;
    std::string out;
  };
  auto o = std::make_shared<Options>();
  CLI::App* cmd = app->add_subcommand(
      "push-sweep", "Push protocol during steady walking: per direction x duration x phase, upward force scans");
  cmd->add_option("--directions", o->directions, "Directions, evenly spaced from forward")->capture_default_str();
  cmd->add_option("--durations", o->durations, "Push durations, s")->capture_default_str();
  cmd->add_option("--phases", o->phases, "Onsets spread over one stride")->capture_default_str();
  cmd->add_option("--resolution", o->scan.resolution_N, "Force step of the upward scan, N")->capture_default_str();
  cmd->add_option("--max-force", o->scan.max_force_N, "Largest force tried, N")->capture_default_str();
  cmd->add_flag("--no-bisect", o->no_bisect, "Skip the bisection figure (reported beside the scan)");
  cmd->add_option("--fixed-force", o->fixed_force_N,
                  "Instead of scanning: one push of this force per cell; reports the share survived");
  cmd->add_option("--body", o->body, "Pushed body: pelvis | trunk")->capture_default_str();
  cmd->add_option("--settle-strides", o->settle_strides, "Steady strides before the push's stride")
      ->capture_default_str();
  cmd->add_option("--threads", o->threads, "Worker threads (default: all cores)");
  o->walk.add_to(cmd);
  cmd->add_option("--out", o->out, "Output directory (results.csv, summary.json, polar.png)")->required();
  return {cmd, [o]() {
            if (o->directions < 1 || o->directions > 360)
              throw sim::InvalidArgument("--directions: must be in [1, 360], got " + std::to_string(o->directions));
            if (o->phases < 1 || o->phases > 100)
              throw sim::InvalidArgument("--phases: must be in [1, 100], got " + std::to_string(o->phases));
            if (o->body != "pelvis" && o->body != "trunk")
              throw sim::InvalidArgument("--body: expected pelvis or trunk, got '" + o->body + "'");
            if (o->fixed_force_N < 0)
              throw sim::InvalidArgument("--fixed-force: must be >= 0 N, got " + std::to_string(o->fixed_force_N));
            const std::vector<double> durations = durations_from(o->durations);
            o->scan.bisect = !o->no_bisect;
            scenarios::WalkRunParams base = o->walk.to_params();
            scenarios::WalkPush push;
            push.body = o->body;
            push.settle_strides = o->settle_strides;
            base.push = push;
            base.validate();
            if (o->fixed_force_N == 0) {  // before any worker starts (scan_walking_push checks too)
              if (!(o->scan.resolution_N > 0) || !(o->scan.max_force_N >= o->scan.resolution_N))
                throw sim::InvalidArgument("--resolution/--max-force: need 0 < resolution <= max force");
            }
            int threads = o->threads > 0 ? o->threads : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
            const models::CharacterSpec spec = o->walk.character.to_spec();
            const models::Character character = models::generate_character(spec);
            const std::string mjcf = models::to_mjcf(character, o->walk.physics());
            const double mass = character.total_mass_kg();

            struct Job {
              double direction_deg, duration_s, phase;
            };
            std::vector<Job> jobs;
            for (double dur : durations)
              for (int k = 0; k < o->directions; ++k)
                for (int p = 0; p < o->phases; ++p)
                  jobs.push_back({360.0 * k / o->directions, dur, static_cast<double>(p) / o->phases});
            threads = std::min<int>(threads, static_cast<int>(jobs.size()));
            std::vector<CellResult> results(jobs.size());
            std::cout << "biodyn push-sweep: " << jobs.size() << " cells (" << o->directions << " directions x "
                      << durations.size() << " durations x " << o->phases << " phases) on " << threads
                      << " threads; " << o->body << " pushes after " << o->settle_strides
                      << " steady strides, speed " << base.speed_m_s << " m/s, weld " << o->walk.weld << ", timestep "
                      << 1000 * o->walk.timestep_s << " ms\n"
                      << "  " << weld_assumption(o->walk.weld) << "\n";
            std::atomic<std::size_t> next{0}, done{0};
            std::mutex error_mutex;
            std::string first_error;
            {
              ProgressBar bar("push-sweep");
              std::mutex bar_mutex;
              std::vector<std::thread> workers;
              for (int t = 0; t < threads; ++t) {
                workers.emplace_back([&]() {
                  try {
                    sim::Simulation sim(sim::Model::from_string(mjcf, "<character>"));  // this worker's copy
                    for (std::size_t i = next++; i < jobs.size(); i = next++) {
                      const Job& job = jobs[i];
                      CellResult& res = results[i];
                      if (o->fixed_force_N > 0) {
                        scenarios::WalkRunParams run = base;
                        run.push->force_N = o->fixed_force_N;
                        run.push->direction_deg = job.direction_deg;
                        run.push->duration_s = job.duration_s;
                        run.push->onset_phase = job.phase;
                        const scenarios::WalkRunResult r = scenarios::run_walk(&sim, run);
                        res.cell.direction_deg = job.direction_deg;
                        res.cell.duration_s = job.duration_s;
                        res.cell.onset_phase = job.phase;
                        res.cell.runs = 1;
                        res.fixed_survived = r.push->survived;
                        res.fixed_failure = r.push->failure;
                        res.cell.fell_before_push = r.push->failure == "fell before the push";
                      } else {
                        res.cell = scenarios::scan_walking_push(&sim, base, job.direction_deg, job.duration_s,
                                                                job.phase, o->scan);
                      }
                      const std::size_t n = ++done;
                      std::lock_guard<std::mutex> lock(bar_mutex);
                      bar.update(static_cast<double>(n) / static_cast<double>(jobs.size()));
                    }
                  } catch (const std::exception& e) {
                    std::lock_guard<std::mutex> lock(error_mutex);
                    if (first_error.empty()) first_error = e.what();
                    next = jobs.size();
                  }
                });
              }
              for (std::thread& w : workers) w.join();
            }
            if (!first_error.empty()) throw sim::Error("push-sweep: " + first_error);

            // results.csv
            std::ostringstream csv;
            csv << std::setprecision(10);
            csv << "direction_deg,duration_s,onset_phase,max_survived_N,first_failure_N,bisection_N,"
                   "max_survived_impulse_N_s,max_survived_delta_v_m_s,fixed_force_N,fixed_survived,failure,runs\n";
            for (const CellResult& r : results) {
              const scenarios::WalkingPushCell& c = r.cell;
              csv << c.direction_deg << ',' << c.duration_s << ',' << c.onset_phase << ',';
              if (o->fixed_force_N > 0) {
                csv << ",,,,," << o->fixed_force_N << ',' << (r.fixed_survived ? 1 : 0) << ",\"" << r.fixed_failure
                    << "\"," << c.runs << '\n';
              } else {
                csv << c.max_survived_N << ',' << c.first_failure_N << ',' << c.bisection_N << ','
                    << c.max_survived_N * c.duration_s << ',' << c.max_survived_N * c.duration_s / mass << ",,,\""
                    << (c.fell_before_push ? std::string("fell before the push") : c.failure) << "\"," << c.runs << '\n';
              }
            }
            // summary.json: per direction and duration, worst phase and mean.
            nlohmann::json cells = nlohmann::json::array();
            std::size_t fixed_ok = 0, invalid = 0;
            std::ostringstream plot_data;
            double plot_max = 0;
            for (double dur : durations) {
              plot_data << "# duration " << dur << " s: direction_deg worst_N mean_N\n";
              std::vector<double> first_worst;
              for (int k = 0; k <= o->directions; ++k) {  // the first direction again closes the curve
                const double dir = 360.0 * (k % o->directions) / o->directions;
                double worst = 1e18, sum = 0, bis_worst = 1e18, bis_sum = 0;
                int n = 0, survived = 0;
                bool any_invalid = false;
                for (const CellResult& r : results) {
                  if (r.cell.duration_s != dur || r.cell.direction_deg != dir) continue;
                  if (r.cell.fell_before_push) any_invalid = true;
                  const double f = o->fixed_force_N > 0 ? (r.fixed_survived ? o->fixed_force_N : 0.0) : r.cell.max_survived_N;
                  worst = std::min(worst, f);
                  sum += f;
                  bis_worst = std::min(bis_worst, r.cell.bisection_N);
                  bis_sum += r.cell.bisection_N;
                  survived += r.fixed_survived ? 1 : 0;
                  ++n;
                }
                if (o->fixed_force_N > 0) {  // share of phases survived, %
                  plot_data << dir << ' ' << 100.0 * survived / n << ' ' << 100.0 * survived / n << '\n';
                  plot_max = 100;
                } else {
                  plot_data << dir << ' ' << worst << ' ' << sum / n << '\n';
                  plot_max = std::max(plot_max, sum / n);
                }
                if (k == o->directions) continue;
                if (o->fixed_force_N > 0) fixed_ok += static_cast<std::size_t>(survived);
                invalid += any_invalid ? 1 : 0;
                nlohmann::json c = {{"direction_deg", dir}, {"duration_s", dur}, {"phases", n}};
                if (o->fixed_force_N > 0) {
                  c["force_N"] = o->fixed_force_N;
                  c["survived_phases"] = survived;
                } else {
                  c["max_survived_N_worst_phase"] = worst;
                  c["max_survived_N_mean"] = sum / n;
                  c["delta_v_m_s_worst_phase"] = worst * dur / mass;
                  c["delta_v_m_s_mean"] = sum / n * dur / mass;
                  if (o->scan.bisect) {
                    c["bisection_N_worst_phase"] = bis_worst;
                    c["bisection_N_mean"] = bis_sum / n;
                  }
                }
                c["walk_failed_before_push"] = any_invalid;
                cells.push_back(c);
              }
              plot_data << "\n\n";
            }
            nlohmann::json summary = {
                {"cells", cells},
                {"protocol",
                 "references.md: horizontal push through the body's CoM, direction relative to the heading, onset "
                 "spread over the stride after the settle strides; survived = only the feet touch the ground for "
                 "5 s after the push, pelvis >= 0.7 x standing height, stride speed back within 10% by the 4th "
                 "stride. max_survived_N: the force below the first failure of an upward scan (every smaller "
                 "force at the resolution survived); bisection_N assumes monotonic survival and overstates."},
                {"weld", o->walk.weld},
                {"weld_assumption", weld_assumption(o->walk.weld)},
                {"body_mass_kg", mass},
                {"resolution_N", o->scan.resolution_N},
                {"max_force_N", o->scan.max_force_N},
                {"threads", threads},
                {"inputs", o->walk.inputs_json(spec)}};
            summary["inputs"]["body"] = o->body;
            summary["inputs"]["settle_strides"] = o->settle_strides;
            if (o->fixed_force_N > 0) {
              summary["fixed_force_N"] = o->fixed_force_N;
              summary["survived_fraction"] = static_cast<double>(fixed_ok) / static_cast<double>(results.size());
            }
            summary["cells_where_the_walk_failed_before_the_push"] = invalid;

            std::filesystem::create_directories(o->out);
            const std::string dir = o->out;
            write_file_atomically(dir + "/results.csv", csv.str());
            write_file_atomically(dir + "/summary.json", summary.dump(2) + "\n");
            write_file_atomically(dir + "/polar.dat", plot_data.str());
            std::ostringstream gp;
            gp << "set terminal pngcairo size 900,900 font 'sans,11'\n"
               << "set output '" << dir << "/polar.png.tmp'\n"
               << "set polar\nset angles degrees\nset size square\nunset border\nunset xtics\nunset ytics\n"
               << "set grid polar 45\nset rtics\nset rrange [0:" << std::max(1.1 * plot_max, 1.0) << "]\n"
               << "set key outside bottom center horizontal\n"
               << "set title \"" << (o->fixed_force_N > 0 ? "Share of onset phases surviving a " + std::to_string(static_cast<int>(o->fixed_force_N)) + " N push, %" : std::string("Largest push force survived (upward scan), N"))
               << "\\n0 deg = forward, 90 deg = left; " << o->body << ", weld " << o->walk.weld << ", "
               << base.speed_m_s << " m/s\"\n"
               << "plot ";
            for (std::size_t i = 0; i < durations.size(); ++i) {
              if (o->fixed_force_N > 0) {
                gp << (i ? ", " : "") << "'" << dir << "/polar.dat' index " << i
                   << " using 1:2 with linespoints lw 2 title '" << durations[i] << " s: % of phases survived'";
                continue;
              }
              gp << (i ? ", " : "") << "'" << dir << "/polar.dat' index " << i
                 << " using 1:2 with linespoints lw 2 title '" << durations[i] << " s, worst phase', '" << dir
                 << "/polar.dat' index " << i << " using 1:3 with lines dt 2 title '" << durations[i] << " s, mean'";
            }
            gp << "\n";
            write_file_atomically(dir + "/polar.gp", gp.str());
            plot_with_gnuplot("push-sweep", dir + "/polar.gp", dir + "/polar.png.tmp", dir + "/polar.png");

            std::cout << std::fixed << std::setprecision(0);
            for (const auto& c : cells) {
              std::cout << "  " << std::setw(4) << c["direction_deg"].get<double>() << " deg, " << std::setprecision(2)
                        << c["duration_s"].get<double>() << " s: " << std::setprecision(0);
              if (o->fixed_force_N > 0) {
                std::cout << c["survived_phases"].get<int>() << "/" << c["phases"].get<int>() << " phases survived\n";
              } else {
                std::cout << "max survived " << c["max_survived_N_worst_phase"].get<double>() << " N worst phase, "
                          << c["max_survived_N_mean"].get<double>() << " N mean";
                if (o->scan.bisect) std::cout << " (bisection: " << c["bisection_N_mean"].get<double>() << " N mean)";
                std::cout << "\n";
              }
            }
            if (o->fixed_force_N > 0) {
              std::cout << std::setprecision(1) << "  survived " << 100.0 * static_cast<double>(fixed_ok) / static_cast<double>(results.size()) << "% of "
                        << results.size() << " pushes of " << o->fixed_force_N << " N\n";
            }
            if (invalid > 0) std::cout << "  WARNING: the walk fell before the push in " << invalid << " direction/duration groups\n";
            std::cout << "  results:  " << dir << "/results.csv\n  summary:  " << dir << "/summary.json\n  plot:     "
                      << dir << "/polar.png\n";
            return kExitOk;
          }};
}

}  // namespace biodyn::apps
