// biodyn pose: a character stands, squats, reaches or balances on one leg under the
// velocity-based (or PD) joint controllers; optionally pushed. Headless; JSON summary.
#include <iomanip>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>

#include "biodyn/models/mjcf.h"
#include "biodyn/scenarios/pose.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/model.h"
#include "cli_common.h"
#include "commands.h"

namespace biodyn::apps {
namespace {

// "N,dur,deg" -> push.
scenarios::TimedPush parse_push(const std::string& text, double onset_s) {
  const std::string expected = "3 numbers N,duration_s,direction_deg (e.g. 150,0.2,0)";
  const std::vector<double> v = parse_number_list(text, "--push", expected);
  if (v.size() != 3)
    throw sim::InvalidArgument("--push: expected " + expected + ", got '" + text + "'");
  scenarios::TimedPush p;
  p.force_N = v[0];
  p.duration_s = v[1];
  p.direction_deg = v[2];
  p.onset_s = onset_s;
  return p;
}

}  // namespace

nlohmann::json pose_result_json(const scenarios::PoseRunResult& r) {
  nlohmann::json targets = nlohmann::json::array();
  for (const scenarios::TargetCheck& t : r.targets) {
    targets.push_back({{"pose", t.pose},
                       {"time_s", t.time_s},
                       {"orientation_error_deg", t.error_deg},
                       {"worst_joint", t.worst_joint},
                       {"pose_error_deg", t.pose_error_deg}});
  }
  return {{"scenario", r.scenario},
          {"controller", r.controller},
          {"weld", r.weld},
          {"reaction_time_s", r.reaction_time_s},
          {"fallen", r.fallen},
          {"time_fallen", r.time_fallen_s},
          {"max_orientation_error_deg", r.max_orientation_error_deg},
          {"max_pose_error_deg", r.max_pose_error_deg},
          {"targets", targets},
          {"weld_tension_steps", r.weld_tension_steps},
          {"weld_redone_steps", r.weld_redone_steps},
          {"max_weld_force_N", r.max_weld_force_N},
          {"weld_active_fraction", r.weld_active_fraction},
          {"max_torque_ratio", r.max_torque_ratio},
          {"com_outside_support_s", r.com_outside_support_s},
          {"max_com_outside_support_m", r.max_com_outside_support_m},
          {"max_foot_displacement_m", r.max_foot_displacement_m},
          {"joint_velocity_rms", r.joint_velocity_rms},
          {"joints_outside_limits_steps", r.joints_outside_limits_steps},
          {"solver_converged", r.solver_converged},
          {"steps", r.steps},
          {"simulated_s", r.simulated_s},
          {"wall_s", r.wall_s},
          {"realtime_factor", r.realtime_factor},
          {"mujoco_warnings", r.warnings.total()},
          {"mujoco_warnings_detail", r.warnings.describe()}};
}

Command add_pose_command(CLI::App* app) {
  struct Options {
    CharacterOptions character;
    scenarios::PoseRunParams run;
    std::string controller = "velocity";
    std::string weld = "honest";
    std::string push;
    double push_onset_s = 1.0;
    std::string params_path;
    std::string json;
    std::string csv;
    MuscleOptions muscles;
  };
  auto o = std::make_shared<Options>();
  CLI::App* cmd = app->add_subcommand(
      "pose", "Stand, squat, reach or balance on one leg under the joint controllers (headless)");
  o->character.add_to(cmd);
  cmd->add_option("--scenario", o->run.config.scenario, "stand | squat | reach | one-leg")
      ->capture_default_str();
  cmd->add_option("--duration", o->run.config.pose_duration_s,
                  "Simulated time, s (0: the scenario's own length; longer: the last pose holds)")
      ->capture_default_str();
  cmd->add_option("--reaction-time", o->run.config.reaction_time_s,
                  "Muscle reaction time t_r for every joint, s (default: params, 0.02 = paper)");
  cmd->add_option("--controller", o->controller, "velocity | pd")->capture_default_str();
  cmd->add_option("--weld", o->weld, "Foot-contact weld: off | honest | glue")
      ->capture_default_str();
  cmd->add_option("--push", o->push,
                  "Push on the pelvis: N,duration_s,direction_deg (0 forward, 90 left)");
  cmd->add_option("--push-onset", o->push_onset_s, "Simulation time of the push, s")
      ->capture_default_str();
  cmd->add_option("--params", o->params_path, "Controller parameters (JSON; see README)");
  o->muscles.add_to(cmd);
  cmd->add_option("--json", o->json, "Write the run summary as JSON here");
  cmd->add_option("--csv", o->csv, "Write a per-step trace (CSV) here");
  return {
      cmd, [o]() {
        scenarios::PoseRunParams run = o->run;
        run.config.character = o->character.to_spec();
        run.config.muscles = o->muscles.to_config();
        const models::CharacterSpec spec = run.config.model_spec();
        run.config.controller = controllers::parse_controller_kind(o->controller, "--controller");
        run.config.weld = controllers::parse_weld_mode(o->weld, "--weld");
        if (!o->push.empty()) run.config.pose_push = parse_push(o->push, o->push_onset_s);
        if (!o->params_path.empty()) {
          run.config.controller_json = read_file(o->params_path);
          run.config.controller_source = o->params_path;
        }
        run.validate();
        const models::Character character = models::generate_character(spec);
        sim::Simulation sim(sim::Model::from_string(models::to_mjcf(character), "<character>"));
        std::ostringstream trace;
        if (!o->csv.empty()) run.trace = &trace;
        scenarios::PoseRunResult r;
        {
          ProgressBar bar("pose " + run.config.scenario);
          r = scenarios::run_pose(&sim, run, [&](double f) { bar.update(f); });
        }
        std::ostringstream out;
        out << std::fixed << std::setprecision(2);
        out << "biodyn pose: " << r.scenario << ", " << to_string(spec.sex) << " " << spec.height_m
            << " m " << spec.mass_kg << " kg (" << to_string(spec.detail) << "), " << r.controller
            << " controller, weld " << r.weld << ", t_r "
            << (r.reaction_time_s > 0
                    ? std::to_string(r.reaction_time_s * 1000).substr(0, 5) + " ms"
                    : std::string("per joint"))
            << "\n";
        out << "  result:   "
            << (r.fallen ? "FELL at t = " + std::to_string(r.time_fallen_s).substr(0, 5) + " s"
                         : std::string("stayed up"))
            << (run.config.pose_push ? (r.fallen ? " after the push" : ", survived the push") : "")
            << "\n";
        for (const scenarios::TargetCheck& t : r.targets) {
          out << "  target:   " << std::setw(16) << std::left << t.pose << std::right << " at "
              << t.time_s << " s: error " << t.error_deg << " deg (" << t.worst_joint
              << "), vs pose without balance " << t.pose_error_deg << " deg\n";
        }
        out << "  torques:  peak |tau|/tau_max " << r.max_torque_ratio << "\n"
            << "  weld:     " << r.weld << ", on " << r.weld_active_fraction * 100
            << "% of foot-steps, tension steps " << r.weld_tension_steps
            << ", released for tension " << r.weld_redone_steps << "x, max force "
            << r.max_weld_force_N << " N\n"
            << "  balance:  CoM outside the support polygon " << r.com_outside_support_s
            << " s (max " << r.max_com_outside_support_m * 100 << " cm), feet moved up to "
            << r.max_foot_displacement_m * 100 << " cm\n"
            << "  run:      " << r.simulated_s << " s simulated in " << r.wall_s << " s, "
            << std::setprecision(1) << r.realtime_factor
            << "x real time; MuJoCo warnings: " << r.warnings.describe() << "\n";
        print_muscles(r.muscles, out);
        std::cout << out.str();
        if (!o->csv.empty()) {
          write_file_atomically(o->csv, trace.str());
          std::cout << "  trace:    " << o->csv << "\n";
        }
        if (!o->json.empty()) {
          nlohmann::json j = pose_result_json(r);
          j["inputs"] = character_json(spec);
          j["inputs"]["params"] = o->params_path;
          j["inputs"]["push"] = o->push;
          if (r.muscles) {
            j["muscles"] = muscles_json(r.muscles);
            j["inputs"]["muscles"] = "on";
            j["inputs"]["tendons"] = o->muscles.tendons;
            j["inputs"]["muscle_params"] = o->muscles.params_path;
          }
          write_file_atomically(o->json, j.dump(2) + "\n");
          std::cout << "  summary:  " << o->json << "\n";
        }
        return r.warnings.total() == 0 ? kExitOk : kExitFailure;
      }};
}

}  // namespace biodyn::apps
