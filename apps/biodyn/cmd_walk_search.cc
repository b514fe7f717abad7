// biodyn walk-search: the torque walker's parameters searched against human gait (issue 28): a
// cross-entropy search (gait_search.h) that ships as a command, reproducible from its seed.
#include <iomanip>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>
#include <thread>

#include "biodyn/controllers/torque_walker.h"
#include "biodyn/scenarios/gait_search.h"
#include "biodyn/sim/errors.h"
#include "cli_common.h"
#include "commands.h"

namespace biodyn::apps {
namespace {

using nlohmann::json;

json outcome_json(const scenarios::GaitSearchParams& p, const scenarios::CandidateResult& r) {
  json cases = json::array();
  for (std::size_t k = 0; k < r.cases.size(); ++k) {
    const scenarios::SearchCase& c = p.cases[k];
    const scenarios::CaseOutcome& o = r.cases[k];
    json figures = json::object();
    for (const scenarios::GaitFigure& f : o.figures) figures[f.name] = {f.value, f.met()};
    cases.push_back({{"height_m", c.height_m},
                     {"mass_kg", c.mass_kg},
                     {"sex", models::to_string(c.sex)},
                     {"speed_m_s", c.speed_m_s},
                     {"reaction_time_s", c.reaction_time_s},
                     {"judged_on_gait", c.gait},
                     {"push", c.push_force_N > 0 ? json{{"force_N", c.push_force_N},
                                                        {"duration_s", c.push_duration_s},
                                                        {"direction_deg", c.push_direction_deg},
                                                        {"onset_phase", c.push_phase},
                                                        {"survived", o.push_failure.empty()},
                                                        {"failure", o.push_failure}}
                                                 : json(nullptr)},
                     {"fell", o.fell},
                     {"time_fallen_s", o.fell ? json(o.time_fallen_s) : json(nullptr)},
                     {"steady_speed_m_s", o.speed_m_s},
                     {"cost", o.cost},
                     {"figures", figures}});
  }
  return {{"cost", r.cost}, {"cases", cases}};
}

/// A candidate's parameters as the walker writes them (every field, its own formatting).
std::string best_json(const std::string& candidate) {
  controllers::TorqueWalkerParams found;
  controllers::apply_torque_walker_json(candidate, "the search's best", &found);
  return controllers::torque_walker_json(found);
}

}  // namespace

Command add_walk_search_command(CLI::App* app) {
  struct Options {
    std::string params, out, controller = "torque";
    int generations = 30, population = 32, threads = 0, pushes = 0, push_bodies = 1;
    unsigned long long seed = 1, push_body_seed = 3000;
    double duration_s = 16, spread = 1.0 / 6;
  };
  auto o = std::make_shared<Options>();
  CLI::App* cmd = app->add_subcommand(
      "walk-search",
      "Search the torque walker's parameters against human gait (cross-entropy; the cost: falls, "
      "speed, and the gait figures of biodyn gait outside their human bands) on 1.80 m / 80 kg at "
      "1.0 and 1.3 m/s, 1.55 m / 50 kg and 1.95 m / 120 kg at 1.0 m/s, and walking at 0.5 and "
      "1.5 m/s (--controller velocity: these two at t_r 100 ms, and every body and three women "
      "walking at 1.0 m/s at t_r 100 ms); --pushes adds pushes");
  cmd->add_option("--params", o->params,
                  "Walker parameters to start from (JSON; default: the walker's defaults with a "
                  "double support put first)");
  cmd->add_option("--controller", o->controller,
                  "The walker's actuation the candidates walk with: torque | velocity")
      ->capture_default_str();
  cmd->add_option("--generations", o->generations, "Generations")->capture_default_str();
  cmd->add_option("--population", o->population, "Candidates per generation")
      ->capture_default_str();
  cmd->add_option("--seed", o->seed, "Random seed (the same seed gives the same search)")
      ->capture_default_str();
  cmd->add_option("--duration", o->duration_s, "Simulated time of each walk, s")
      ->capture_default_str();
  cmd->add_option("--pushes", o->pushes,
                  "Also judge each candidate on this many pushes (a multiple of 8, up to 80): "
                  "350 N x 0.2 s at the pelvis, 1.80 m / 80 kg (see --push-bodies) at 1.0 m/s, "
                  "t_r 100 ms, 8 directions at phases push-sweep does not use; the balance gains "
                  "join the searched parameters")
      ->capture_default_str();
  cmd->add_option("--push-bodies", o->push_bodies,
                  "The pushes are shared among this many bodies (1 to 16): 1.80 m / 80 kg and "
                  "walk-sweep's random bodies from --push-body-seed")
      ->capture_default_str();
  cmd->add_option("--push-body-seed", o->push_body_seed,
                  "Seed of the pushed random bodies (walk-sweep's; check the result on other "
                  "seeds)")
      ->capture_default_str();
  cmd->add_option("--spread", o->spread,
                  "The first generation's SD as a fraction of each parameter's range, (0, 0.5] "
                  "(smaller refines a start already good)")
      ->capture_default_str();
  cmd->add_option("--threads", o->threads, "Worker threads (default: all cores)");
  cmd->add_option("-o,--out", o->out,
                  "Output directory: best.json and search.csv (rewritten after every generation), "
                  "best_report.json")
      ->required();
  return {cmd, [o]() {
            check_outputs({{"-o", o->out, true}}, o->params.empty()
                                                      ? std::vector<std::string>{}
                                                      : std::vector<std::string>{o->params});
            const controllers::WalkerActuation actuation =
                controllers::parse_walker_actuation(o->controller, "--controller");
            controllers::TorqueWalkerParams base = controllers::walker_defaults(actuation);
            if (!o->params.empty())
              controllers::apply_torque_walker_json(read_file(o->params), o->params, &base);
            scenarios::GaitSearchParams p =
                scenarios::default_gait_search(controllers::torque_walker_json(base), actuation);
            scenarios::add_push_cases(&p, o->pushes, o->push_bodies, o->push_body_seed);
            p.generations = o->generations;
            p.population = o->population;
            p.seed = o->seed;
            p.duration_s = o->duration_s;
            p.initial_spread = o->spread;
            p.threads = o->threads > 0
                            ? o->threads
                            : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
            p.validate();
            std::cout << "biodyn walk-search: controller " << o->controller << ", "
                      << p.dimensions.size() << " parameters, " << p.cases.size() << " walks ("
                      << o->pushes << " with a push) of " << p.duration_s << " s per candidate, "
                      << p.population << " candidates x " << p.generations
                      << " generations, first spread " << p.initial_spread
                      << " of each range, seed " << p.seed << ", " << p.threads << " threads\n";
            std::ostringstream csv;
            csv << "generation,best_cost,elite_mean_cost";
            for (const scenarios::SearchDimension& d : p.dimensions) csv << ",mean" << d.pointer;
            csv << "\n";
            scenarios::CandidateResult best;
            {
              // One line per generation is the progress (a search takes minutes to hours).
              best = scenarios::run_gait_search(p, [&](const scenarios::GenerationReport& r) {
                csv << r.generation << "," << r.best_cost << "," << r.elite_mean_cost;
                for (double m : r.mean) csv << "," << m;
                csv << "\n";
                // The best so far on disk after every generation: a long search can be
                // stopped and its best used.
                write_file_atomically(o->out + "/search.csv", csv.str());
                write_file_atomically(o->out + "/best.json", best_json(r.best.json));
                std::cout << "  generation " << r.generation + 1 << "/" << p.generations
                          << ": best " << std::fixed << std::setprecision(1) << r.best_cost
                          << ", elite mean " << r.elite_mean_cost << ", best so far " << r.best.cost
                          << std::endl;
              });
            }
            write_file_atomically(o->out + "/best_report.json",
                                  json_text(outcome_json(p, best), 2) + "\n");
            std::cout << "  best cost " << best.cost << "; written " << o->out
                      << "/best.json (biodyn walk --params), search.csv, best_report.json\n";
            return kExitOk;
          }};
}

}  // namespace biodyn::apps
