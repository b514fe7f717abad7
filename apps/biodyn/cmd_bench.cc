// biodyn bench: cost of the controllers against the bare physics step, on the same model and
// the same states in one run.
#include <algorithm>
#include <chrono>
#include <iomanip>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>

#include "biodyn/controllers/control_pipeline.h"
#include "biodyn/models/mjcf.h"
#include "biodyn/models/rig.h"
#include "biodyn/muscles/muscle_set.h"
#include "biodyn/muscles/static_optimization.h"
#include "biodyn/scenarios/walk.h"
#include "biodyn/scenarios/walk_scenario.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/model.h"
#include "biodyn/sim/snapshot.h"
#include "cli_common.h"
#include "commands.h"

namespace biodyn::apps {
namespace {

// Wall time per simulated second of a walk at 1 m/s on `spec`, with the legs' muscles or not.
double walk_wall_per_sim_s(const models::CharacterSpec& spec, bool muscles, double duration_s) {
  scenarios::WalkRunParams p;
  p.config.scenario = "walk";
  p.config.character = spec;
  p.config.muscles.on = muscles;
  p.duration_s = duration_s;
  const models::Character c = models::generate_character(p.config.model_spec());
  sim::Simulation sim(sim::Model::from_string(models::to_mjcf(c), "<character>"));
  const scenarios::WalkRunResult r = scenarios::run_walk(&sim, p, {});
  if (r.fallen) throw sim::Error("bench --muscles: the walk fell; no speed figure");
  return r.wall_s / r.simulated_s;
}

// Static optimisation's per-frame loop (kinematics, moment arms, Hill forces, QP; what `mocap so`
// runs) on every step of the torque-only walk at 1 m/s: its states and the joint torques that
// drove it, on the same body with the legs' muscles (rigid tendons, as `mocap so`). Returns
// frames per second on this thread; `frames` gets the count.
double so_frames_per_s(const models::CharacterSpec& spec, double duration_s, long* frames) {
  scenarios::ScenarioConfig config;
  config.scenario = "walk";
  config.character = spec;
  sim::Simulation sim(sim::Model::from_string(
      models::to_mjcf(models::generate_character(config.model_spec())), "<character>"));
  scenarios::WalkScenario walk(&sim, config);
  const mjModel& m = sim.model();
  const long steps = std::lround(duration_s / m.opt.timestep);
  walk.set_max_steps(steps);
  Eigen::MatrixXd qpos(steps, m.nq), qvel(steps, m.nv), tau(steps, m.nv);
  long f = 0;
  for (; f < steps && !walk.run_over(); ++f) {
    const mjData& d = sim.data();
    qpos.row(f) = Eigen::Map<const Eigen::RowVectorXd>(d.qpos, m.nq);
    qvel.row(f) = Eigen::Map<const Eigen::RowVectorXd>(d.qvel, m.nv);
    walk.step();
    tau.row(f) = Eigen::Map<const Eigen::RowVectorXd>(sim.data().qfrc_applied, m.nv);
  }
  if (walk.fallen()) throw sim::Error("bench --muscles: the walk fell; no speed figure");
  models::CharacterSpec muscled = config.model_spec();
  muscled.muscles = true;
  const models::Character c = models::generate_character(muscled);
  const sim::Model model = sim::Model::from_string(models::to_mjcf(c), "<character, muscles>");
  if (model->nq != m.nq || model->nv != m.nv)
    throw sim::Error("bench --muscles: the muscled body's joints differ from the walk's");
  muscles::StaticOptimization so(muscles::MuscleSet(
      *model, muscles::muscle_params(c.muscles, muscles::TendonChoice::kAllRigid)));
  const muscles::StaticOptimizationResult r =
      muscles::static_optimization(*model, &so, qpos.topRows(f), qvel.topRows(f), tau.topRows(f));
  *frames = f;
  return static_cast<double>(f) / r.solve_time_s;
}

// bench --muscles: the same walk without and with muscles, alternated `repeats` times (the
// median of each: other load on the machine hits both alike); then static optimisation's speed.
int bench_muscles(const models::CharacterSpec& spec, double duration_s, int repeats,
                  const std::string& json_path) {
  std::vector<double> off, on;
  {
    ProgressBar bar("bench: walks without and with muscles");
    for (int k = 0; k < repeats; ++k) {
      off.push_back(walk_wall_per_sim_s(spec, false, duration_s));
      bar.update((2.0 * k + 1) / (2.0 * repeats));
      on.push_back(walk_wall_per_sim_s(spec, true, duration_s));
      bar.update((2.0 * k + 2) / (2.0 * repeats));
    }
  }
  long so_frames = 0;
  const double so_fps = so_frames_per_s(spec, duration_s, &so_frames);
  const auto median = [](std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
  };
  const double t_off = median(off), t_on = median(on);
  std::cout << std::fixed << std::setprecision(2) << "biodyn bench --muscles: walk at 1 m/s, "
            << duration_s << " s, " << to_string(spec.detail) << " character, median of " << repeats
            << " alternated runs\n"
            << "  without muscles: " << 1.0 / t_off << "x real time\n"
            << "  with muscles:    " << 1.0 / t_on << "x real time\n"
            << "  speed ratio:     " << t_off / t_on << " (goal >= 0.75)\n"
            << std::setprecision(0) << "  static optimisation: " << so_fps
            << " frames/s on one thread (goal >= 2000): the per-frame loop of `mocap so` over "
            << so_frames << " states and joint torques of the torque-only walk\n";
  if (!json_path.empty()) {
    const nlohmann::json j = {{"detail", to_string(spec.detail)},
                              {"duration_s", duration_s},
                              {"repeats", repeats},
                              {"realtime_factor_without_muscles", 1.0 / t_off},
                              {"realtime_factor_with_muscles", 1.0 / t_on},
                              {"speed_ratio", t_off / t_on},
                              {"static_optimization_frames_per_s", so_fps},
                              {"static_optimization_frames", so_frames},
                              {"wall_per_sim_s_without", off},
                              {"wall_per_sim_s_with", on}};
    write_file_atomically(json_path, j.dump(2) + "\n");
  }
  return kExitOk;
}

}  // namespace

Command add_bench_command(CLI::App* app) {
  struct Options {
    CharacterOptions character;
    double duration_s = 4.0;
    std::string controller = "velocity";
    std::string weld = "honest";
    std::string json;
    bool muscles = false;
    int repeats = 3;
  };
  auto o = std::make_shared<Options>();
  CLI::App* cmd = app->add_subcommand(
      "bench", "Steps per second of bare mj_step and of step + controller (quiet standing)");
  o->character.add_to(cmd, false);
  cmd->add_option("--duration", o->duration_s, "Simulated time per measurement, s")
      ->capture_default_str();
  cmd->add_option("--controller", o->controller, "velocity | pd")->capture_default_str();
  cmd->add_option("--weld", o->weld, "off | honest | glue")->capture_default_str();
  cmd->add_option("--json", o->json, "Write the figures as JSON here");
  cmd->add_flag("--muscles", o->muscles,
                "Instead: the speed of walking with the legs' Hill muscles against without "
                "(a walk of --duration, alternated --repeats times)");
  cmd->add_option("--repeats", o->repeats, "With --muscles: runs of each kind (median)")
      ->capture_default_str();
  return {cmd, [o]() {
            if (!(o->duration_s > 0 && o->duration_s <= 600)) {
              throw sim::InvalidArgument("--duration: must be in (0, 600] s, got " +
                                         std::to_string(o->duration_s));
            }
            const models::CharacterSpec spec = o->character.to_spec();
            if (o->muscles) {
              if (!(o->repeats >= 1 && o->repeats <= 50))
                throw sim::InvalidArgument("--repeats: must be in [1, 50], got " +
                                           std::to_string(o->repeats));
              return bench_muscles(spec, o->duration_s, o->repeats, o->json);
            }
            const models::Character character = models::generate_character(spec);
            sim::Simulation sim(sim::Model::from_string(models::to_mjcf(character), "<character>"));
            const mjModel& m = sim.model();
            controllers::ControlPipelineConfig config;
            config.kind = controllers::parse_controller_kind(o->controller, "--controller");
            config.weld.mode = controllers::parse_weld_mode(o->weld, "--weld");
            const models::Rig rig(m);
            const auto& groups = rig.groups();
            controllers::ControlPipeline ctrl(&sim, rig, controllers::default_params(m, groups),
                                              config);
            ctrl.reset_in_pose(controllers::pose_scenario("stand", groups, 0).front());
            const int steps = static_cast<int>(o->duration_s / m.opt.timestep);

            // Controlled steps, keeping every start state and the torques applied, so the bare
            // measurement steps the same states with the same forces (only the controller's
            // own work is missing from it).
            std::vector<std::unique_ptr<sim::StateSnapshot>> states;
            std::vector<std::vector<mjtNum>> applied;
            states.reserve(static_cast<std::size_t>(steps));
            applied.reserve(static_cast<std::size_t>(steps));
            double controlled_s = 0;
            {
              ProgressBar bar("bench: controlled steps");
              for (int s = 0; s < steps; ++s) {
                states.push_back(std::make_unique<sim::StateSnapshot>(m));
                states.back()->save(m, sim.data());
                const auto t0 = std::chrono::steady_clock::now();
                ctrl.step();
                controlled_s +=
                    std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
                applied.emplace_back(sim.data().qfrc_applied, sim.data().qfrc_applied + m.nv);
                if (s % 100 == 0) bar.update(static_cast<double>(s + 1) / steps);
              }
            }
            // Bare mj_step from the same states with the same applied forces.
            double bare_s = 0;
            {
              ProgressBar bar("bench: bare mj_step");
              mjData& d = sim.data();
              for (int s = 0; s < steps; ++s) {
                states[static_cast<std::size_t>(s)]->restore(sim.mutable_model(), d);
                const std::vector<mjtNum>& f = applied[static_cast<std::size_t>(s)];
                std::copy(f.begin(), f.end(), d.qfrc_applied);
                const auto t0 = std::chrono::steady_clock::now();
                mj_step(&m, &d);
                bare_s +=
                    std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
                if (s % 100 == 0) bar.update(static_cast<double>(s + 1) / steps);
              }
            }
            const double bare_rate = steps / bare_s, controlled_rate = steps / controlled_s;
            std::ostringstream out;
            out << std::fixed << std::setprecision(1) << "biodyn bench: " << to_string(spec.detail)
                << " character (" << m.nv << " DOF), " << o->controller << " controller, weld "
                << o->weld << ", " << steps << " steps of quiet standing\n"
                << "  bare mj_step:        " << std::setprecision(0) << bare_rate << " steps/s ("
                << std::setprecision(1) << 1e6 / bare_rate << " us/step)\n"
                << "  step + controller:   " << std::setprecision(0) << controlled_rate
                << " steps/s (" << std::setprecision(1) << 1e6 / controlled_rate << " us/step)\n"
                << "  ratio:               " << std::setprecision(2) << controlled_rate / bare_rate
                << " (goal >= 0.5)\n";
            std::cout << out.str();
            if (!o->json.empty()) {
              const nlohmann::json j = {{"detail", to_string(spec.detail)},
                                        {"dof", m.nv},
                                        {"controller", o->controller},
                                        {"weld", o->weld},
                                        {"steps", steps},
                                        {"bare_steps_per_second", bare_rate},
                                        {"controlled_steps_per_second", controlled_rate},
                                        {"ratio", controlled_rate / bare_rate}};
              write_file_atomically(o->json, j.dump(2) + "\n");
            }
            return kExitOk;
          }};
}

}  // namespace biodyn::apps
