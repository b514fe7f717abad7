// biodyn walk / biodyn push: walking headless under the torque walker, and one push during
// steady walking (issue 4; references.md, push protocol).
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>

#include "biodyn/controllers/torque_walker.h"
#include "biodyn/mocap_io/motion_csv.h"
#include "biodyn/models/mjcf.h"
#include "biodyn/scenarios/motion_recorder.h"
#include "biodyn/scenarios/walk.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/model.h"
#include "cli_common.h"
#include "commands.h"
#include "walk_options.h"

namespace biodyn::apps {

void WalkOptions::add_to(CLI::App* cmd) {
  character.add_to(cmd);
  cmd->add_option("--speed", speed_m_s, "Commanded speed, m/s")->capture_default_str();
  cmd->add_option("--heading-rate", heading_rate_deg_s, "Commanded turning rate, deg/s (+ left)")
      ->capture_default_str();
  cmd->add_option("--weld", weld, "Foot-contact mode: off | honest | glue")->capture_default_str();
  cmd->add_option("--controller", controller,
                  "How the walker drives the joints: torque (PD torques, SIMBICON) | velocity (the "
                  "paper's velocity-based controllers: targets with an optimal time, torques from "
                  "the whole-body solve)")
      ->capture_default_str();
  cmd->add_option(
      "--reaction-time", reaction_time_s,
      "Muscle reaction time t_r for every joint, s (default: the controller params, 0.02)");
  cmd->add_option("--params", params_path, "Walker parameters (JSON; see --print-params)");
  cmd->add_option(
      "--controller-params", controller_params_path,
      "Joint controller parameters (JSON as biodyn pose --params; the viewer saves both)");
  cmd->add_option("--timestep", timestep_s, "Physics timestep, s, in [0.0005, 0.004]")
      ->capture_default_str();
  terrain.add_to(cmd);
  muscles.add_to(cmd);
}

models::PhysicsOptions WalkOptions::physics() const {
  if (!(timestep_s >= 0.0005 && timestep_s <= 0.004)) {
    throw sim::InvalidArgument("--timestep: must be in [0.0005, 0.004] s, got " +
                               std::to_string(timestep_s));
  }
  models::PhysicsOptions o;
  o.timestep_s = timestep_s;  // to_mjcf keeps the limit and weld time constants >= 2 steps
  o.terrain = terrain.to_terrain();
  return o;
}

scenarios::WalkRunParams WalkOptions::to_params() const {
  scenarios::WalkRunParams p;
  scenarios::ScenarioConfig& c = p.config;
  c.scenario = "walk";
  c.character = character.to_spec();
  c.speed_m_s = speed_m_s;
  c.heading_rate_deg_s = heading_rate_deg_s;
  c.weld = controllers::parse_weld_mode(weld, "--weld");
  c.walker_actuation = controllers::parse_walker_actuation(controller, "--controller");
  c.reaction_time_s = reaction_time_s;
  c.muscles = muscles.to_config();
  if (!params_path.empty()) {
    c.gait_json = read_file(params_path);
    c.gait_source = params_path;
  }
  if (!controller_params_path.empty()) {
    c.controller_json = read_file(controller_params_path);
    c.controller_source = controller_params_path;
  }
  return p;
}

std::string weld_assumption(const std::string& weld) {
  if (weld == "glue") {
    return "glue: each stance foot is welded to the floor from strike to lift-off, even where "
           "the weld pulls or holds beyond friction (the paper's assumption); compare with --weld "
           "off";
  }
  if (weld == "honest") {
    return "honest: a stance foot is welded only while the weld's ground wrench is one the sole's "
           "contact could give (compressive, inside friction, CoP on the sole); tension steps are "
           "undone";
  }
  return "off: feet held by frictional contacts only";
}

nlohmann::json walk_json(const scenarios::WalkRunResult& r) {
  nlohmann::json ranges = nlohmann::json::object();
  for (const auto& [name, range] : r.joint_ranges_deg) ranges[name] = {range[0], range[1]};
  nlohmann::json j = {
      {"fallen", r.fallen},
      {"time_fallen", r.fallen ? nlohmann::json(r.time_fallen_s) : nlohmann::json(nullptr)},
      {"diverged_at",
       r.diverged_at_s >= 0 ? nlohmann::json(r.diverged_at_s) : nlohmann::json(nullptr)},
      {"distance", r.distance_m},
      {"mean_speed", r.mean_speed_m_s},
      {"steady_speed", r.steady_speed_m_s},
      {"lateral_drift", r.lateral_drift_m},
      {"steps", r.steps},
      {"step_lengths", r.step_lengths_m},
      {"step_widths", r.step_widths_m},
      {"step_times", r.step_times_s},
      {"cadence", r.cadence_steps_per_min},
      {"mean_step_length", r.mean_step_length_m},
      {"joint_ranges_deg", ranges},
      {"swing_knee_peak_deg", r.swing_knee_peak_deg},
      {"heel_strike_fraction", r.heel_strike_fraction},
      {"base_polygon_steps", r.base_polygon_steps},
      {"max_foot_slip", r.max_foot_slip_m},
      {"mean_foot_slip", r.mean_foot_slip_m},
      {"weld", r.weld},
      {"weld_assumption", weld_assumption(r.weld)},
      {"weld_tension_steps", r.weld_tension_steps},
      {"weld_redone_steps", r.weld_redone_steps},
      {"max_weld_force", r.max_weld_force_N},
      {"max_torque_ratio", r.max_torque_ratio},
      {"joint_stops", joint_load_json(r.joint_load)},
      {"max_root_force", r.max_root_force_N},
      {"speed_command", r.speed_command_m_s},
      {"heading_rate_deg_s", r.heading_rate_deg_s},
      {"reaction_time_s", r.reaction_time_s},
      {"simulated_s", r.simulated_s},
      {"wall_s", r.wall_s},
      {"realtime_factor", r.realtime_factor},
      {"mujoco_warnings", r.warnings.describe()},
      {"units",
       "m, s, m/s, N, steps/min; after the start-up (first 5 s) for steady_speed, "
       "cadence, mean_step_length, joint_ranges_deg, swing_knee_peak_deg"}};
  if (r.muscles) j["muscles"] = muscles_json(r.muscles);
  if (r.push) {
    const scenarios::WalkPushOutcome& o = *r.push;
    j["push"] = {{"survived", o.survived},
                 {"failure", o.failure},
                 {"fell", o.fell},
                 {"force_N", o.force_N},
                 {"duration_s", o.duration_s},
                 {"direction_deg", o.direction_deg},
                 {"body", o.body},
                 {"impulse_N_s", o.impulse_N_s},
                 {"delta_v_m_s", o.delta_v_m_s},
                 {"onset_s", o.onset_s},
                 {"end_s", o.end_s},
                 {"speed_before_m_s", o.speed_before_m_s},
                 {"stride_speeds_after_m_s", o.stride_speeds_after_m_s},
                 {"recovery_strides", o.recovery_strides},
                 {"strides_before", o.strides_before}};
    if (o.strides_before < 0) {  // never pushed: no onset, no speed before
      for (const char* k : {"onset_s", "end_s", "speed_before_m_s"}) j["push"][k] = nullptr;
    }
    j["survived"] = o.survived;
  }
  if (r.stopped_at_s >= 0 || r.standing_at_end) {
    j["stop"] = {
        {"stopped_at_s", r.stopped_at_s},
        {"standing_at_end", r.standing_at_end},
        {"final_com_speed", r.final_com_speed_m_s},
        {"method",
         "a half step, then the feet side by side (planned steps), then the standing controller "
         "(pose 'stand' with its balance), both feet in stance"}};
  }
  if (r.stones) {
    const scenarios::SteppingStonesResult& st = *r.stones;
    j["stones"] = {
        {"start_s", st.start_s},
        {"targets", st.targets_m},
        {"lateral_offsets", st.lateral_m},
        {"lengths", st.lengths_m},
        {"target_across", st.target_across_m},
        {"across", st.across_m},
        {"errors", st.errors_m},
        {"out_of_reach_steps", st.out_of_reach},
        {"rms_error", st.rms_error_m},
        {"max_error", st.max_error_m},
        {"complete", st.complete},
        {"method",
         "paper §4.2: in late swing the 2D IK triangle hip-knee-ankle puts the swing ankle on "
         "its target (step lengths ankle to ankle along the heading, at the strike); with "
         "lateral offsets the thigh's roll puts it across too (across: left of the stance "
         "ankle) and the error is the 2D distance; a foot comes down once its ankle is within "
         "2 cm of the stone (one out of reach waits up to placed_wait_s for the hip); the lean "
         "follows the speed the next stones ask (plan_speed_gain)"}};
  }
  return j;
}

void print_walk_summary(const scenarios::WalkRunResult& r, std::ostream& out) {
  out << std::fixed << std::setprecision(2);
  if (r.fallen) {
    out << "  FELL at " << r.time_fallen_s << " s";
    if (r.diverged_at_s >= 0)
      out << " (the simulation diverged: MuJoCo found a bad qpos, qvel or qacc and reset it; "
             "distance to the last strike, and the "
             "last steps' joint figures are not physical)";
  } else {
    out << "  walked " << r.simulated_s << " s without falling";
  }
  out << ": " << r.distance_m << " m, mean " << r.mean_speed_m_s << " m/s (steady "
      << r.steady_speed_m_s << " m/s, commanded " << r.speed_command_m_s << "), " << r.steps
      << " steps\n"
      << "  cadence " << std::setprecision(1) << r.cadence_steps_per_min << " steps/min, mean step "
      << std::setprecision(3) << r.mean_step_length_m << " m, swing knee peak "
      << std::setprecision(1) << r.swing_knee_peak_deg << " deg, heel strikes "
      << std::setprecision(0) << 100 * r.heel_strike_fraction << "%\n"
      << "  foot slip max " << std::setprecision(1) << 100 * r.max_foot_slip_m << " cm (mean "
      << 100 * r.mean_foot_slip_m << " cm per stance), drift " << std::setprecision(2)
      << r.lateral_drift_m << " m sideways\n"
      << "  weld " << weld_assumption(r.weld) << "\n"
      << "  weld tension steps " << r.weld_tension_steps << ", redone steps " << r.weld_redone_steps
      << ", root force " << r.max_root_force_N << " N, peak torque " << std::setprecision(0)
      << 100 * r.max_torque_ratio << "% of tau_max, " << std::setprecision(1) << r.realtime_factor
      << "x real time\n";
  print_joint_load(r.joint_load, out);
  print_muscles(r.muscles, out);
  if (r.stopped_at_s >= 0) {
    out << "  stopped (feet side by side, standing controller) at " << std::setprecision(2)
        << r.stopped_at_s << " s; at the end "
        << (r.standing_at_end ? "standing" : "NOT standing still") << ", CoM "
        << 100 * r.final_com_speed_m_s << " cm/s\n";
  }
  if (r.stones && r.stones->start_s < 0) {
    out << "  stepping stones: not started (no strike after --steps-start before the end)\n";
  } else if (r.stones) {
    const scenarios::SteppingStonesResult& st = *r.stones;
    out << "  stepping stones from " << std::setprecision(2) << st.start_s
        << " s: " << st.lengths_m.size() << " of " << st.targets_m.size() << " steps walked";
    // A fall after the last stone still counts every stone as walked: say so on this line.
    if (r.fallen)
      out << (st.complete ? ", then FELL at " : " before the FALL at ") << r.time_fallen_s << " s";
    out << ", error RMS " << std::setprecision(1) << 100 * st.rms_error_m << " cm, max "
        << 100 * st.max_error_m << " cm\n    planned";
    out << std::setprecision(3);
    for (double t : st.targets_m) out << ' ' << t;
    out << "\n    walked ";
    for (double l : st.lengths_m) out << ' ' << l;
    if (!st.lateral_m.empty()) {
      out << "\n    across planned";
      for (double a : st.target_across_m) out << ' ' << a;
      out << "\n    across walked ";
      for (double a : st.across_m) out << ' ' << a;
    }
    out << "\n";
    for (int k : st.out_of_reach) {
      const auto i = static_cast<std::size_t>(k - 1);
      out << "    step " << k << ": the stone at " << st.targets_m[i] << " m is out of reach; ";
      if (i < st.lengths_m.size())
        out << "stepped to the closest reachable point, " << st.lengths_m[i] << " m\n";
      else
        out << "the character fell reaching for it\n";
    }
  }
}

namespace {

// A number with two decimals, for the push's report line.
std::string fixed2(double v) {
  std::ostringstream s;
  s << std::fixed << std::setprecision(2) << v;
  return s.str();
}

// The summary on stdout, then the trace CSV and the JSON (with `inputs`) where asked for.
void write_walk_outputs(const scenarios::WalkRunResult& r, const nlohmann::json& inputs,
                        const std::string& trace, const std::string& csv_path,
                        const std::string& json_path) {
  print_walk_summary(r, std::cout);
  if (!csv_path.empty()) {
    write_file_atomically(csv_path, trace);
    std::cout << "  trace:    " << csv_path << "\n";
  }
  if (!json_path.empty()) {
    nlohmann::json j = walk_json(r);
    j["inputs"] = inputs;
    write_file_atomically(json_path, j.dump(2) + "\n");
    std::cout << "  summary:  " << json_path << "\n";
  }
}

// --motion-out: the walk as a motion CSV (qpos, the body in its header) and, beside it,
// <stem>.grf.csv with each foot's ground force (weld plus contacts) from the simulation.
void write_recorded_motion(const scenarios::RecordedMotion& rec, const models::CharacterSpec& spec,
                           const models::PhysicsOptions& physics, const std::string& path) {
  const models::Character character = models::generate_character(spec);
  const sim::Model model =
      sim::Model::from_string(models::to_mjcf(character, physics), "<character>");
  mocap_io::Motion motion;
  motion.columns = mocap_io::qpos_names(*model);
  motion.times_s = rec.times_s;
  motion.qpos = rec.qpos;
  motion.comments.push_back(" simulated by biodyn walk (physics: foot welds and contacts only)");
  mocap_io::set_motion_body(&motion, spec);
  std::ostringstream grf;
  grf << "time,fx_l,fy_l,fz_l,fx_r,fy_r,fz_r\n";
  grf.precision(9);
  for (int f = 0; f < rec.frame_count(); ++f) {
    grf << rec.times_s[static_cast<size_t>(f)];
    for (int side = 0; side < 2; ++side) {
      for (int k = 0; k < 3; ++k) grf << "," << rec.ground_force_N[static_cast<size_t>(side)](f, k);
    }
    grf << "\n";
  }
  const std::string text = mocap_io::format_motion_csv(motion);
  const std::string grf_path = ground_force_path(path);
  write_file_atomically(path, text);
  write_file_atomically(grf_path, grf.str());
  std::cout << "  motion:   " << path << " (" << rec.frame_count() << " frames) and " << grf_path
            << " (each foot's ground force in the simulation)\n";
}

}  // namespace

scenarios::WalkRunResult run_walk_on(const models::CharacterSpec& spec,
                                     const models::PhysicsOptions& physics,
                                     scenarios::WalkRunParams p, bool with_trace,
                                     const std::string& label, std::string* trace,
                                     scenarios::RecordedMotion* recording, double record_hz) {
  const models::Character character = models::generate_character(spec);
  sim::Simulation sim(sim::Model::from_string(models::to_mjcf(character, physics), "<character>"));
  std::ostringstream text;
  if (with_trace) p.trace = &text;
  const double dt = sim.model().opt.timestep;
  const int every = std::max(1, static_cast<int>(std::lround(1.0 / (record_hz * dt))));
  scenarios::MotionRecorder recorder(sim.model(), every, std::lround(p.duration_s / dt) + 1);
  if (recording) p.observers.push_back(&recorder);
  scenarios::WalkRunResult r;
  {
    ProgressBar bar(label);
    r = scenarios::run_walk(&sim, p, [&](double f) { bar.update(f); });
  }
  *trace = text.str();
  if (recording) *recording = recorder.motion();
  return r;
}

Command add_walk_command(CLI::App* app) {
  struct Options {
    WalkOptions walk;
    double duration_s = 20;
    std::string steps, step_offsets;
    double steps_start_s = 5.0;
    double stop_at_s = -1;
    std::string json, csv, motion_out;
    double motion_rate_hz = 100;
    bool print_params = false;
  };
  auto o = std::make_shared<Options>();
  CLI::App* cmd =
      app->add_subcommand("walk", "Walk headless from standing under the torque walker");
  cmd->add_option("--duration", o->duration_s, "Simulated time, s")->capture_default_str();
  o->walk.add_to(cmd);
  cmd->add_option(
      "--steps", o->steps,
      "Stepping stones: step lengths, m (ankle to ankle along the heading), e.g. 0.60,0.20,0.50; "
      "walked from the first strike after --steps-start");
  cmd->add_option("--step-offsets", o->step_offsets,
                  "Stones in 2D: each stone's offset, m, left (+) of its foot's line (the lines "
                  "the hips' spacing apart), one per --steps length, e.g. 0.05,-0.1,0");
  cmd->add_option("--steps-start", o->steps_start_s,
                  "When the stepping stones begin (steady walking first), s")
      ->capture_default_str();
  cmd->add_option("--stop-at", o->stop_at_s,
                  "Stop walking at this time, s (a half step, feet side by side, then standing) "
                  "and stand until "
                  "--duration");
  cmd->add_option("--json", o->json, "Write the results as JSON here");
  cmd->add_option("--csv", o->csv, "Write a per-step trace as CSV here");
  cmd->add_option("--motion-out", o->motion_out,
                  "Write the walk as a motion CSV here (qpos; the body in its header), and each "
                  "foot's ground force beside it (<stem>.grf.csv)");
  cmd->add_option("--motion-rate", o->motion_rate_hz, "Frame rate of --motion-out, Hz")
      ->capture_default_str()
      ->check(CLI::Range(1.0, 2000.0));
  cmd->add_flag("--print-params", o->print_params,
                "Print the walker parameters (defaults + --params) as JSON and exit");
  return {cmd, [o]() {
            scenarios::WalkRunParams p = o->walk.to_params();
            p.duration_s = o->duration_s;
            if (o->print_params) {
              std::cout << controllers::torque_walker_json(p.config.walker_params());
              return kExitOk;
            }
            if (!o->steps.empty()) {
              p.config.scenario = "stones";
              p.config.steps_m =
                  parse_number_list(o->steps, "--steps", "step lengths in m separated by commas");
              if (!o->step_offsets.empty())
                p.config.steps_lateral_m = parse_number_list(
                    o->step_offsets, "--step-offsets", "lateral offsets in m separated by commas");
              p.config.steps_start_s = o->steps_start_s;
            }
            if (o->steps.empty() && !o->step_offsets.empty())
              throw sim::InvalidArgument("--step-offsets: only with --steps");
            p.config.stop_at_s = o->stop_at_s;
            p.validate();
            const models::CharacterSpec spec = p.config.model_spec();
            const models::PhysicsOptions physics = o->walk.physics();
            std::cout << "biodyn walk: " << to_string(spec.sex) << " " << spec.height_m << " m "
                      << spec.mass_kg << " kg (" << to_string(spec.detail) << "), " << p.duration_s
                      << " s, weld " << o->walk.weld << ", controller " << o->walk.controller
                      << ", speed " << p.config.speed_m_s << " m/s, heading rate "
                      << p.config.heading_rate_deg_s << " deg/s, timestep "
                      << 1000 * o->walk.timestep_s << " ms" << o->walk.terrain.text() << "\n";
            if (!o->motion_out.empty()) check_outputs({{"--motion-out", o->motion_out, false}}, {});
            std::string trace;
            scenarios::RecordedMotion recording;
            const scenarios::WalkRunResult r =
                run_walk_on(spec, physics, p, !o->csv.empty(), "walk", &trace,
                            o->motion_out.empty() ? nullptr : &recording, o->motion_rate_hz);
            nlohmann::json inputs = o->walk.inputs_json(spec);
            inputs["duration_s"] = p.duration_s;
            write_walk_outputs(r, inputs, trace, o->csv, o->json);
            if (!o->motion_out.empty())
              write_recorded_motion(recording, spec, physics, o->motion_out);
            return r.fallen ? kExitFailure : kExitOk;
          }};
}

std::string ground_force_path(const std::string& motion_path) {
  const std::filesystem::path p(motion_path);
  return (p.parent_path() / (p.stem().string() + ".grf.csv")).string();
}

nlohmann::json WalkOptions::inputs_json(const models::CharacterSpec& spec) const {
  nlohmann::json j = character_json(spec);
  j["speed_m_s"] = speed_m_s;
  j["heading_rate_deg_s"] = heading_rate_deg_s;
  j["weld"] = weld;
  j["controller"] = controller;
  j["reaction_time_s"] = reaction_time_s;
  j["params"] = params_path;
  j["timestep_s"] = timestep_s;
  if (terrain.kind != "flat") j["terrain"] = terrain.json();
  if (muscles.muscles == "on") {
    j["muscles"] = "on";
    j["tendons"] = muscles.tendons;
    j["muscle_params"] = muscles.params_path;
  }
  return j;
}

std::string WalkOptions::replay_args() const {
  std::ostringstream a;
  a << std::setprecision(6);
  if (!character.body_path.empty()) {
    a << "--body-file '" << character.body_path << "' --mass " << character.mass_kg;
  } else {
    a << "--height " << character.height_m << " --mass " << character.mass_kg << " --sex "
      << character.sex << " --detail " << character.detail;
    if (!character.overrides_path.empty()) a << " --overrides '" << character.overrides_path << "'";
  }
  a << " --heading-rate " << heading_rate_deg_s << " --weld " << weld << " --controller "
    << controller << " --timestep " << timestep_s;
  if (reaction_time_s > 0) a << " --reaction-time " << reaction_time_s;  // 0: the default
  a << terrain.args();
  if (!params_path.empty()) a << " --params '" << params_path << "'";
  if (!controller_params_path.empty())
    a << " --controller-params '" << controller_params_path << "'";
  if (muscles.muscles == "on") {
    a << " --muscles on --tendons " << muscles.tendons;
    if (!muscles.params_path.empty()) a << " --muscle-params '" << muscles.params_path << "'";
  }
  return a.str();
}

Command add_push_command(CLI::App* app) {
  struct Options {
    WalkOptions walk;
    scenarios::WalkPush push;
    std::string json, csv;
  };
  auto o = std::make_shared<Options>();
  o->push.force_N = -1;
  CLI::App* cmd =
      app->add_subcommand("push", "One push during steady walking: survived, and the recovery");
  cmd->add_option("--force", o->push.force_N, "Push force, N")->required();
  cmd->add_option("--duration", o->push.duration_s, "Push duration, s")->capture_default_str();
  cmd->add_option("--direction", o->push.direction_deg,
                  "Direction relative to the heading, deg (0 forward, 90 left)")
      ->capture_default_str();
  cmd->add_option("--body", o->push.body, "Pushed body: pelvis | trunk")->capture_default_str();
  cmd->add_option("--onset-phase", o->push.onset_phase,
                  "Onset as a fraction of the stride (from a left strike)")
      ->capture_default_str();
  cmd->add_option(
         "--settle-strides", o->push.settle_strides,
         "Strides before the push's stride (at least: the push also waits for 4 steady strides)")
      ->capture_default_str();
  o->walk.add_to(cmd);
  cmd->add_option("--json", o->json, "Write the results as JSON here");
  cmd->add_option("--csv", o->csv, "Write a per-step trace as CSV here");
  return {cmd, [o]() {
            if (o->push.body != "pelvis" && o->push.body != "trunk") {
              throw sim::InvalidArgument("--body: expected pelvis or trunk, got '" + o->push.body +
                                         "'");
            }
            scenarios::WalkRunParams p = o->walk.to_params();
            p.config.walk_push = o->push;
            p.validate();
            const models::CharacterSpec spec = p.config.model_spec();
            const models::PhysicsOptions physics = o->walk.physics();
            std::cout << "biodyn push: " << o->push.force_N << " N for " << o->push.duration_s
                      << " s on the " << o->push.body << ", " << o->push.direction_deg
                      << " deg from the heading, at " << o->push.onset_phase
                      << " of the stride after " << o->push.settle_strides << " strides; weld "
                      << o->walk.weld << ", speed " << p.config.speed_m_s << " m/s, timestep "
                      << 1000 * o->walk.timestep_s << " ms" << o->walk.terrain.text() << "\n";
            std::string trace;
            const scenarios::WalkRunResult r =
                run_walk_on(spec, physics, p, !o->csv.empty(), "push", &trace);
            const scenarios::WalkPushOutcome& po = *r.push;
            std::cout << std::fixed << std::setprecision(2) << "  "
                      << (po.survived ? "SURVIVED" : "FAILED: " + po.failure) << "; impulse "
                      << po.impulse_N_s << " N s, delta-v " << po.delta_v_m_s << " m/s, "
                      << (po.strides_before < 0
                              ? std::string("not pushed")
                              : "onset " + fixed2(po.onset_s) + " s after " +
                                    std::to_string(po.strides_before) +
                                    " strides (the last 4 steady); speed before " +
                                    fixed2(po.speed_before_m_s) + " m/s")
                      << ", recovered in "
                      << (po.recovery_strides > 0 ? std::to_string(po.recovery_strides) + " strides"
                                                  : std::string("-"))
                      << "\n";
            write_walk_outputs(r, o->walk.inputs_json(spec), trace, o->csv, o->json);
            return kExitOk;
          }};
}

}  // namespace biodyn::apps
