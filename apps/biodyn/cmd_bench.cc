// biodyn bench: cost of the controllers against the bare physics step, on the same model and
// the same states in one run.
#include <chrono>
#include <iomanip>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>

#include "biodyn/controllers/control_pipeline.h"
#include "biodyn/models/mjcf.h"
#include "biodyn/models/rig.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/model.h"
#include "biodyn/sim/snapshot.h"
#include "cli_common.h"
#include "commands.h"

namespace biodyn::apps {

Command add_bench_command(CLI::App* app) {
  struct Options {
    CharacterOptions character;
    double duration_s = 4.0;
    std::string controller = "velocity";
    std::string weld = "honest";
    std::string json;
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
  return {cmd, [o]() {
            if (!(o->duration_s > 0 && o->duration_s <= 600)) {
              throw sim::InvalidArgument("--duration: must be in (0, 600] s, got " +
                                         std::to_string(o->duration_s));
            }
            const models::CharacterSpec spec = o->character.to_spec();
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
