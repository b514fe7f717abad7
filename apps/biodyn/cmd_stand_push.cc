// biodyn stand-push: the largest push a quietly standing character survives without
// stepping, per direction and foot-contact mode (issue 3), by an upward force scan.
#include <iomanip>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>

#include "biodyn/models/mjcf.h"
#include "biodyn/scenarios/pose.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/file_io.h"
#include "biodyn/sim/model.h"
#include "cli_common.h"
#include "commands.h"

namespace biodyn::apps {
namespace {

std::vector<double> parse_directions(const std::string& text) {
  const std::string expected = "degrees separated by commas (0 forward, 90 left)";
  std::vector<double> out = parse_number_list(text, "--directions", expected);
  if (out.empty())
    throw sim::InvalidArgument("--directions: expected " + expected + ", got '" + text + "'");
  return out;
}

std::string direction_name(double deg) {
  if (deg == 0) return "forward";
  if (deg == 180 || deg == -180) return "backward";
  if (deg == 90) return "left";
  if (deg == -90 || deg == 270) return "right";
  return std::to_string(deg).substr(0, 5) + " deg";
}

}  // namespace

Command add_stand_push_command(CLI::App* app) {
  struct Options {
    CharacterOptions character;
    std::string directions = "0,180,90";
    std::string welds = "off,honest";
    std::string controller = "velocity";
    double reaction_time_s = 0;
    scenarios::PushScanParams scan;
    std::string params_path;
    std::string json;
  };
  auto o = std::make_shared<Options>();
  CLI::App* cmd = app->add_subcommand(
      "stand-push",
      "Largest pelvis push survived standing without stepping, per direction and weld mode");
  o->character.add_to(cmd);
  cmd->add_option("--directions", o->directions, "Push directions, deg (0 forward, 90 left)")
      ->capture_default_str();
  cmd->add_option("--welds", o->welds, "Foot-contact modes to scan: off, honest, glue")
      ->capture_default_str();
  cmd->add_option("--controller", o->controller, "velocity | pd")->capture_default_str();
  cmd->add_option("--reaction-time", o->reaction_time_s,
                  "Muscle reaction time t_r for every joint, s (default: params)");
  cmd->add_option("--duration", o->scan.duration_s, "Push duration, s")->capture_default_str();
  cmd->add_option("--resolution", o->scan.resolution_N, "Force step of the upward scan, N")
      ->capture_default_str();
  cmd->add_option("--max-force", o->scan.max_force_N, "Largest force tried, N")
      ->capture_default_str();
  cmd->add_option("--body", o->scan.body, "Pushed body")->capture_default_str();
  cmd->add_option("--params", o->params_path, "Controller parameters (JSON)");
  cmd->add_option("--json", o->json, "Write the results as JSON here");
  return {
      cmd, [o]() {
        const models::CharacterSpec spec = o->character.to_spec();
        scenarios::PoseRunParams base;
        base.config.controller = controllers::parse_controller_kind(o->controller, "--controller");
        base.config.reaction_time_s = o->reaction_time_s;
        if (!o->params_path.empty()) {
          base.config.controller_json = read_file(o->params_path);
          base.config.controller_source = o->params_path;
        }
        const std::vector<double> directions = parse_directions(o->directions);
        std::vector<controllers::WeldMode> welds;
        for (const std::string& w : sim::split_fields(o->welds))
          welds.push_back(controllers::parse_weld_mode(w, "--welds"));
        if (welds.empty()) throw sim::InvalidArgument("--welds: at least one mode");
        base.validate();
        const models::Character character = models::generate_character(spec);
        sim::Simulation sim(sim::Model::from_string(models::to_mjcf(character), "<character>"));

        std::cout << "biodyn stand-push: " << to_string(spec.sex) << " " << spec.height_m << " m "
                  << spec.mass_kg << " kg (" << to_string(spec.detail) << "), " << o->controller
                  << " controller, " << o->scan.duration_s << " s pushes on the " << o->scan.body
                  << ", upward scan in " << o->scan.resolution_N
                  << " N steps; survived = not fallen and no foot moved 3 cm\n";
        nlohmann::json results = nlohmann::json::array();
        for (controllers::WeldMode w : welds) {
          for (double deg : directions) {
            scenarios::PoseRunParams run = base;
            run.config.weld = w;
            scenarios::StandingPushScan s;
            {
              ProgressBar bar(std::string("stand-push ") + controllers::to_string(w) + " " +
                              direction_name(deg));
              s = scenarios::scan_standing_push(&sim, run, deg, o->scan,
                                                [&](double f) { bar.update(f); });
            }
            const double mass = character.total_mass_kg();
            std::cout << "  weld " << std::setw(7) << std::left << s.weld << std::setw(9)
                      << direction_name(deg) << std::right << std::fixed << std::setprecision(0)
                      << " survived up to " << std::setw(4) << s.max_survived_N << " N (impulse "
                      << std::setprecision(1) << s.max_survived_N * o->scan.duration_s
                      << " N s, delta-v " << std::setprecision(2)
                      << s.max_survived_N * o->scan.duration_s / mass << " m/s)"
                      << (s.first_failure_N > 0
                              ? "; first failure " +
                                    std::to_string(static_cast<int>(s.first_failure_N)) + " N (" +
                                    s.failure + ")"
                              : std::string("; no failure up to the maximum"))
                      << "\n";
            results.push_back(
                {{"weld", s.weld},
                 {"direction_deg", deg},
                 {"direction", direction_name(deg)},
                 {"max_survived_N", s.max_survived_N},
                 {"max_survived_delta_v_m_s", s.max_survived_N * o->scan.duration_s / mass},
                 {"first_failure_N", s.first_failure_N},
                 {"failure", s.failure},
                 {"runs", s.runs}});
          }
        }
        if (!o->json.empty()) {
          nlohmann::json j = {
              {"results", results},
              {"controller", o->controller},
              {"push_duration_s", o->scan.duration_s},
              {"resolution_N", o->scan.resolution_N},
              {"body", o->scan.body},
              {"survived_means", "not fallen and no foot moved 3 cm or more, 3 s after the push"},
              {"inputs", character_json(spec)}};
          j["inputs"]["reaction_time_s"] = o->reaction_time_s;
          j["inputs"]["params"] = o->params_path;
          write_file_atomically(o->json, j.dump(2) + "\n");
          std::cout << "  summary:  " << o->json << "\n";
        }
        return kExitOk;
      }};
}

}  // namespace biodyn::apps
