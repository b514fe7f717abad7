// biodyn stones-sweep: seeded random stepping-stone sequences (scenarios/stones_sweep.h) on all
// cores, one model copy per worker; results do not depend on the thread count (every sequence
// is its own deterministic run). A failed sequence prints its seed and the `biodyn walk` line
// that replays it.
#include <algorithm>
#include <iomanip>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>

#include "biodyn/models/mjcf.h"
#include "biodyn/scenarios/stones_sweep.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/model.h"
#include "cli_common.h"
#include "commands.h"
#include "walk_options.h"

namespace biodyn::apps {
namespace {

struct StonesOptions {
  WalkOptions walk;
  scenarios::StoneSweepSpec spec;
  int threads = 0;
  std::string out;
  CLI::App* cmd = nullptr;
};

std::string joined(const std::vector<double>& v) {
  std::ostringstream s;
  s << std::setprecision(6);
  for (std::size_t i = 0; i < v.size(); ++i) s << (i ? "," : "") << v[i];
  return s.str();
}

// The `biodyn walk` line that walks one sequence alone, the same run to the bit.
std::string replay_line(const StonesOptions& o, const scenarios::StoneSequence& s) {
  std::ostringstream line;
  line << "biodyn walk --steps " << joined(s.lengths_m);
  if (!s.lateral_m.empty()) line << " --step-offsets " << joined(s.lateral_m);
  line << std::setprecision(6) << " --speed " << s.speed_m_s << " --duration "
       << scenarios::stone_sequence_duration_s(o.spec, s) << " " << o.walk.replay_args();
  return line.str();
}

std::vector<scenarios::StoneSequenceResult> run_sequences(
    const scenarios::StoneSweepSpec& spec, const std::string& mjcf,
    const std::vector<scenarios::StoneSequence>& sequences, int threads) {
  std::vector<scenarios::StoneSequenceResult> results(sequences.size());
  run_batch(sequences.size(), threads, mjcf, "stones-sweep",
            [&](sim::Simulation* sim, std::size_t i) {
              results[i] = scenarios::run_stone_sequence(sim, spec, sequences[i]);
            });
  return results;
}

std::string results_csv(const std::vector<scenarios::StoneSequenceResult>& results) {
  std::ostringstream csv;
  csv << std::setprecision(10)
      << "seed,speed_m_s,lengths_m,lateral_m,walked,complete,fallen,fell_at_s,rms_error_m,"
         "max_error_m,out_of_reach_steps,passed\n";
  for (const scenarios::StoneSequenceResult& r : results) {
    const scenarios::StoneSequence& s = r.sequence;
    csv << s.seed << ',' << s.speed_m_s << ",\"" << joined(s.lengths_m) << "\",\""
        << joined(s.lateral_m) << "\"," << r.walked << ',' << r.complete << ',' << r.fallen << ','
        << r.fell_at_s << ',' << r.rms_error_m << ',' << r.max_error_m << ",\"";
    for (std::size_t k = 0; k < r.out_of_reach.size(); ++k)
      csv << (k ? "," : "") << r.out_of_reach[k];
    csv << "\"," << r.passed << '\n';
  }
  return csv.str();
}

// errors.png: each sequence's step error RMS against its speed, passed or not, and the limit
// (one data block per group that has sequences: gnuplot's `index` counts blocks).
void plot_errors(const StonesOptions& o, const std::string& dir,
                 const std::vector<scenarios::StoneSequenceResult>& results) {
  std::ostringstream data, plot;
  int block = 0;
  for (const bool passed : {true, false}) {
    int n = 0;
    for (const scenarios::StoneSequenceResult& r : results) {
      if (r.passed != passed) continue;
      data << r.sequence.speed_m_s << ' ' << 100 * r.rms_error_m << ' ' << r.walked << '\n';
      ++n;
    }
    if (n == 0) continue;
    data << "\n\n";
    plot << "'" << dir << "/errors.dat' index " << block++ << " using 1:2 with points "
         << (passed ? "pt 7 lc rgb '#2a9d3a' title 'walked to the end'"
                    : "pt 2 ps 1.5 lc rgb '#c0392b' title 'failed (fell, or error above the "
                      "limit)'")
         << ", ";
  }
  write_file_atomically(dir + "/errors.dat", data.str());
  std::ostringstream gp;
  gp << "set terminal pngcairo size 900,600 font 'sans,11'\n"
     << "set output '" << dir << "/errors.png.tmp'\n"
     << "set xlabel 'speed commanded, m/s'\nset ylabel 'step error RMS, cm'\nset grid\n"
     << "set key outside bottom center horizontal\n"
     << "set title 'Stepping stones: " << results.size() << " random sequences of " << o.spec.stones
     << " stones (weld " << o.walk.weld << ", " << o.walk.controller << ")'\n"
     << "plot " << plot.str() << 100 * o.spec.rms_limit_m
     << " with lines dt 2 lc rgb 'black' title 'limit'\n";
  write_file_atomically(dir + "/errors.gp", gp.str());
  plot_with_gnuplot("stones-sweep", dir + "/errors.gp", dir + "/errors.png.tmp",
                    dir + "/errors.png");
}

int run_stones(StonesOptions& o) {
  if (o.cmd->count("--speed") > 0)
    throw sim::InvalidArgument(
        "--speed: stones-sweep draws each sequence's speed from --speed-min .. --speed-max");
  scenarios::StoneSweepSpec& spec = o.spec;
  spec.walk = o.walk.to_params();
  spec.validate();
  check_outputs({{"-o", o.out, true}}, {});
  std::vector<scenarios::StoneSequence> sequences;
  for (int k = 0; k < spec.sequences; ++k)
    sequences.push_back(
        scenarios::random_stone_sequence(spec, spec.seed + static_cast<std::uint64_t>(k)));
  const int threads = batch_threads(o.threads, static_cast<std::size_t>(spec.sequences));
  const models::CharacterSpec character_spec = spec.walk.config.model_spec();
  const std::string mjcf =
      models::to_mjcf(models::generate_character(character_spec), o.walk.physics());
  std::cout << "biodyn stones-sweep: " << spec.sequences << " random sequences of " << spec.stones
            << " stones (lengths " << spec.length_min_m << "-" << spec.length_max_m << " m, "
            << (spec.lateral_m > 0 ? "lateral offsets within +-" + joined({spec.lateral_m}) + " m"
                                   : std::string("lengths only"))
            << ", speed " << spec.speed_min_m_s << "-" << spec.speed_max_m_s << " m/s), seeds "
            << spec.seed << ".." << spec.seed + static_cast<std::uint64_t>(spec.sequences - 1)
            << ", weld " << o.walk.weld << ", controller " << o.walk.controller << ", " << threads
            << " threads" << o.walk.terrain.text() << "\n  " << weld_assumption(o.walk.weld)
            << "\n";
  const std::vector<scenarios::StoneSequenceResult> results =
      run_sequences(spec, mjcf, sequences, threads);

  int passed = 0;
  nlohmann::json failed = nlohmann::json::array();
  for (const scenarios::StoneSequenceResult& r : results) {
    if (r.passed) {
      ++passed;
      continue;
    }
    std::ostringstream why;
    why << std::fixed << std::setprecision(1);
    if (r.fallen)
      why << "fell at " << r.fell_at_s << " s after " << r.walked << " stones";
    else if (!r.complete)
      why << "walked " << r.walked << " of " << spec.stones << " stones";
    else
      why << "error RMS " << 100 * r.rms_error_m << " cm";
    std::cout << "  FAILED seed " << r.sequence.seed << ": " << why.str()
              << "\n    replay: " << replay_line(o, r.sequence) << "\n";
    failed.push_back(
        {{"seed", r.sequence.seed}, {"why", why.str()}, {"replay", replay_line(o, r.sequence)}});
  }
  const double share = static_cast<double>(passed) / static_cast<double>(results.size());
  std::cout << std::fixed << std::setprecision(1) << "  walked to the end (all " << spec.stones
            << " stones, error RMS < " << 100 * spec.rms_limit_m << " cm, no fall for "
            << spec.after_s << " s after): " << passed << " of " << results.size() << " ("
            << 100 * share << "%)\n";
  nlohmann::json j = {
      {"sequences", results.size()},
      {"passed", passed},
      {"passed_fraction", share},
      {"failed", failed},
      {"stones", spec.stones},
      {"seed", spec.seed},
      {"length_range_m", {spec.length_min_m, spec.length_max_m}},
      {"lateral_m", spec.lateral_m},
      {"speed_range_m_s", {spec.speed_min_m_s, spec.speed_max_m_s}},
      {"rms_limit_m", spec.rms_limit_m},
      {"after_s", spec.after_s},
      {"threads", threads},
      {"weld_assumption", weld_assumption(o.walk.weld)},
      {"definition",
       "a sequence passes when every stone is walked, the step error RMS (2D distance from the "
       "stone with lateral offsets, else the length error) is below the limit, and the character "
       "does not fall until after_s of free walking after the stones; sequence k has seed + k; "
       "stone offsets are left of each foot's line, the lines the hips' spacing apart"},
      {"inputs", o.walk.inputs_json(character_spec)}};
  const std::string& dir = o.out;
  write_file_atomically(dir + "/sequences.csv", results_csv(results));
  write_file_atomically(dir + "/summary.json", j.dump(2) + "\n");
  plot_errors(o, dir, results);
  std::cout << "  results:  " << dir << "/sequences.csv\n  summary:  " << dir
            << "/summary.json\n  plot:     " << dir << "/errors.png\n";
  return kExitOk;
}

}  // namespace

Command add_stones_sweep_command(CLI::App* app) {
  auto o = std::make_shared<StonesOptions>();
  CLI::App* cmd = app->add_subcommand(
      "stones-sweep", "Stepping stones on seeded random sequences: the share walked to the end");
  cmd->add_option("--sequences", o->spec.sequences, "Random sequences")->capture_default_str();
  cmd->add_option("--stones", o->spec.stones, "Stones per sequence")->capture_default_str();
  cmd->add_option("--seed", o->spec.seed, "Seed of the first sequence (sequence k: seed + k)")
      ->capture_default_str();
  cmd->add_option("--length-min", o->spec.length_min_m, "Shortest step, m")->capture_default_str();
  cmd->add_option("--length-max", o->spec.length_max_m, "Longest step, m")->capture_default_str();
  cmd->add_option("--lateral", o->spec.lateral_m,
                  "Stone offsets uniform within +- this, m, left of each foot's line (0: lengths "
                  "only, the balance places the feet across)")
      ->capture_default_str();
  cmd->add_option("--speed-min", o->spec.speed_min_m_s, "Slowest commanded speed, m/s")
      ->capture_default_str();
  cmd->add_option("--speed-max", o->spec.speed_max_m_s, "Fastest commanded speed, m/s")
      ->capture_default_str();
  cmd->add_option("--rms-limit", o->spec.rms_limit_m,
                  "Step error RMS a sequence must stay under, m")
      ->capture_default_str();
  cmd->add_option("--after", o->spec.after_s, "Free walking after the stones without a fall, s")
      ->capture_default_str();
  cmd->add_option("--threads", o->threads, "Worker threads (default: all cores)");
  o->walk.add_to(cmd);
  cmd->add_option("--out,-o", o->out, "Output directory (sequences.csv, summary.json, errors.png)")
      ->required();
  o->cmd = cmd;
  return {cmd, [o]() { return run_stones(*o); }};
}

}  // namespace biodyn::apps
