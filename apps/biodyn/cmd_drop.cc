// biodyn drop: the main job for now (./run.sh). Generates a character, writes its MJCF, lets it
// fall with zero torques and reports what happened.
#include <chrono>
#include <iomanip>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>

#include "biodyn/models/mjcf.h"
#include "biodyn/scenarios/drop.h"
#include "biodyn/sim/model.h"
#include "cli_common.h"
#include "commands.h"

namespace biodyn::apps {

Command add_drop_command(CLI::App* app) {
  struct Options {
    CharacterOptions character;
    scenarios::DropParams drop;
    std::string output = "out/character.xml";
    std::string json;
  };
  auto o = std::make_shared<Options>();
  CLI::App* cmd = app->add_subcommand(
      "drop", "Generate a character and simulate it with zero torques (a rag-doll collapse)");
  o->character.add_to(cmd);
  cmd->add_option("--duration", o->drop.duration_s, "Simulated time, s")->capture_default_str();
  cmd->add_option("-o,--output", o->output, "Where to write the character's MJCF")
      ->capture_default_str();
  cmd->add_option("--json", o->json, "Write the run summary as JSON here");
  return {
      cmd, [o]() {
        const models::CharacterSpec spec = o->character.to_spec();
        o->drop.validate();
        const models::Character character = models::generate_character(spec);
        const std::string xml = models::to_mjcf(character);
        sim::Simulation sim(sim::Model::from_string(xml, o->output));
        write_file_atomically(o->output, xml);

        const auto wall_start = std::chrono::steady_clock::now();
        scenarios::DropResult r;
        {
          ProgressBar bar("simulating " + std::to_string(o->drop.duration_s).substr(0, 4) + " s");
          r = scenarios::run_drop(&sim, o->drop, [&](double f) { bar.update(f); });
        }
        const double wall_s =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
        const mjModel& m = sim.model();
        const bool healthy = r.finite && r.warnings.total() == 0;

        std::ostringstream out;
        out << std::fixed << std::setprecision(2);
        out << "biodyn drop: " << to_string(spec.sex) << ", " << spec.height_m << " m, "
            << character.total_mass_kg() << " kg, " << to_string(spec.detail) << " detail\n"
            << "  model:    " << o->output << " (" << character.segments.size() << " segments, "
            << m.nv << " DOF, " << m.nu << " torque actuators, standing height "
            << character.standing_height_m << " m)\n"
            << "  run:      zero torques for " << r.simulated_s << " s (" << r.steps << " steps of "
            << m.opt.timestep * 1000 << " ms) in " << wall_s << " s wall, " << std::setprecision(0)
            << r.simulated_s / wall_s << "x real time\n"
            << std::setprecision(2) << "  fall:     CoM height " << r.com_height_start_m << " m -> "
            << r.com_height_end_m << " m, pelvis " << r.pelvis_height_start_m << " m -> "
            << r.pelvis_height_end_m << " m; ";
        if (r.collapse_time_s >= 0) {
          out << "collapsed (CoM below half its height) at t = " << r.collapse_time_s << " s";
        } else {
          out << "did not collapse";
        }
        out << (r.rest_time_s >= 0
                    ? "; at rest from t = " + std::to_string(r.rest_time_s).substr(0, 4) + " s"
                    : std::string("; still moving at the end"))
            << "\n"
            << "  energy:   " << r.energy_start_J << " J -> " << r.energy_end_J
            << " J, largest rise " << r.max_energy_rise_J << " J\n"
            << "  MuJoCo warnings: " << r.warnings.describe()
            << (r.finite ? "" : "; NON-FINITE STATE") << "\n";
        std::cout << out.str();

        if (!o->json.empty()) {
          nlohmann::json j = {{"inputs", character_json(spec)},
                              {"model_path", o->output},
                              {"total_mass_kg", character.total_mass_kg()},
                              {"dof", m.nv},
                              {"actuators", m.nu},
                              {"timestep_s", m.opt.timestep},
                              {"steps", r.steps},
                              {"simulated_s", r.simulated_s},
                              {"wall_s", wall_s},
                              {"realtime_factor", r.simulated_s / wall_s},
                              {"com_height_start_m", r.com_height_start_m},
                              {"com_height_end_m", r.com_height_end_m},
                              {"com_height_min_m", r.com_height_min_m},
                              {"pelvis_height_start_m", r.pelvis_height_start_m},
                              {"pelvis_height_end_m", r.pelvis_height_end_m},
                              {"collapse_time_s", r.collapse_time_s},
                              {"rest_time_s", r.rest_time_s},
                              {"energy_start_J", r.energy_start_J},
                              {"energy_end_J", r.energy_end_J},
                              {"max_energy_rise_J", r.max_energy_rise_J},
                              {"finite", r.finite},
                              {"mujoco_warnings", r.warnings.total()},
                              {"mujoco_warnings_detail", r.warnings.describe()},
                              {"torques", "zero (no controller)"}};
          write_file_atomically(o->json, j.dump(2) + "\n");
          std::cout << "  summary:  " << o->json << "\n";
        }
        return healthy ? kExitOk : kExitFailure;
      }};
}

}  // namespace biodyn::apps
