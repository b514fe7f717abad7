// `biodyn mocap track`: a motion reproduced by the simulated body with physics only, by the
// feedback tracker alone or searched by SAMCON (scenarios/samcon.h).
#include <chrono>
#include <filesystem>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>

#include "biodyn/mocap_io/motion_csv.h"
#include "biodyn/models/mjcf.h"
#include "biodyn/scenarios/samcon.h"
#include "biodyn/sim/errors.h"
#include "cli_common.h"
#include "cmd_mocap.h"

namespace biodyn::apps {
namespace {

using nlohmann::json;

struct TrackOptions {
  std::string motion, output;
  CharacterOptions character;
  std::string weld = "honest";
  double from_s = 0, to_s = -1;
  /// s: half the feedback tracker's default; its lag is most of the error left once SAMCON
  /// keeps the body up (the body's own walk, 3 s: 2.5 deg RMS at 0.1 s, 1.8 at 0.05, 2.7 at 0.03)
  double lookahead_s = 0.05;
  bool residual = false;
  scenarios::SamconParams samcon;
};

json samcon_json(const scenarios::SamconParams& p) {
  return {{"window_s", p.window_s},
          {"parents", p.parents},
          {"children", p.children},
          {"max_attempts", p.max_attempts},
          {"seed", p.seed},
          {"sigma_hip_rad", p.sigma_hip_rad},
          {"sigma_knee_rad", p.sigma_knee_rad},
          {"sigma_ankle_rad", p.sigma_ankle_rad},
          {"sigma_trunk_rad", p.sigma_trunk_rad},
          {"root_scale_m", p.root_scale_m},
          {"load_scale", p.load_scale}};
}

/// Whether `path` is a qpos CSV written by mocap ik (its first comment says so).
bool made_by_marker_ik(const std::string& path) {
  const std::string ext = std::filesystem::path(path).extension().string();
  if (ext != ".csv" && ext != ".CSV") return false;
  const mocap_io::Motion m = mocap_io::read_motion_csv(path);
  return !m.comments.empty() && m.comments.front().rfind(" biodyn mocap ik", 0) == 0;
}

int run_track(const TrackOptions& o) {
  check_outputs({{"-o", o.output, true}}, {o.motion});
  std::vector<std::string> notes;
  scenarios::ScenarioConfig config;
  config.scenario = "mocap";
  config.motion_path = o.motion;
  config.track = true;
  config.motion_from_s = o.from_s;
  config.motion_to_s = o.to_s;
  config.tracker.lookahead_s = o.lookahead_s;
  config.residual = o.residual;
  config.character = o.character.spec_for_motion(o.motion, &notes);
  if (made_by_marker_ik(o.motion)) {
    notes.push_back(o.motion +
                    " is a marker-IK motion: its stance feet stand as the markers put them "
                    "(walking5's left foot 10-29 deg plantarflexed), which drives a tracked foot "
                    "into the floor; biodyn mocap retarget --motion " +
                    o.motion + " -o DIR plants them flat on the same body first");
  }
  config.weld = controllers::parse_weld_mode(o.weld, "--weld");
  config.validate();
  const models::PhysicsOptions physics;
  scenarios::SamconResult r;
  {
    ProgressBar bar("mocap track");
    r = scenarios::run_samcon(config, physics, o.samcon, 5, [&](double f) { bar.update(f); });
  }
  const double motion_s = r.windows * o.samcon.window_s;
  const double simulated_s = r.simulated_s;
  json summary = {
      {"motion", o.motion},
      {"character", character_json(config.character)},
      {"method", "SAMCON (Liu et al. 2010) over the feedback tracker (motion_tracker.h)"},
      {"physics",
       std::string(o.residual ? "WITH A RESIDUAL FORCE AND MOMENT ON THE PELVIS (--residual: "
                                "see residual); "
                              : "no force on the root; ") +
           "motors within tau_max and the floor; the joints' range stops are passive structure "
           "and carry load beside the motors (joint_stops)"},
      {"residual",
       {{"on", o.residual},
        {"force_rms_N", r.residual_force_rms_N},
        {"force_peak_N", r.residual_force_peak_N},
        {"moment_rms_Nm", r.residual_moment_rms_Nm},
        {"moment_peak_Nm", r.residual_moment_peak_Nm},
        {"about",
         "a force the simulation applied (not mocap id's inverse-dynamics root residual): a "
         "critically damped 2 Hz pull of the pelvis to the motion's root, force and moment "
         "about the root's origin; only with --residual"}}},
      {"weld", o.weld},
      {"start_swing_lift_deg",
       {{"left", r.start_swing_lift_rad[0] * 180 / M_PI},
        {"right", r.start_swing_lift_rad[1] * 180 / M_PI},
        {"clearance_mm",
         {r.start_swing_clearance_m[0] * 1000, r.start_swing_clearance_m[1] * 1000}},
        {"about",
         "dorsiflexion added to the first pose of a foot the motion has in the air with its "
         "lowest point within 1.5 cm of the floor and not leaving it (a toe set down on the "
         "floor at swing speed trips the body), the smallest that clears 1.5 cm (at most 15 "
         "deg); clearance_mm: that foot's lowest point then; the targets stay the motion's"}}},
      {"lookahead_s", o.lookahead_s},
      {"samcon", samcon_json(o.samcon)},
      {"windows", r.windows},
      {"windows_kept_up", r.windows_kept_up},
      {"kept_up", r.windows_kept_up == r.windows && (r.fell_at_s < 0 || r.fell_at_s > motion_s)},
      {"kept_up_unaided", !o.residual && r.windows_kept_up == r.windows &&
                              (r.fell_at_s < 0 || r.fell_at_s > motion_s)},
      {"fell_at_s", r.fell_at_s},
      {"joint_rms_deg", r.joint_rms_rad * 180 / M_PI},
      {"joint_max_deg", r.joint_max_rad * 180 / M_PI},
      {"root_max_m", r.root_max_m},
      {"peak_torque_ratio", r.peak_torque_ratio},
      {"joint_stops", joint_load_json(r.joint_load)},
      {"rollouts", r.rollouts},
      {"simulated_steps", r.steps},
      {"wall_s", r.wall_s},
      {"realtime_factor", r.wall_s > 0 ? motion_s / r.wall_s : 0.0},
      {"search_realtime_factor", r.wall_s > 0 ? simulated_s / r.wall_s : 0.0},
      {"notes", notes}};
  mocap_io::Motion tracked;
  {
    const sim::Model model = sim::Model::from_string(
        models::to_mjcf(models::generate_character(config.model_spec()), physics), "<character>");
    tracked.columns = mocap_io::qpos_names(*model);
  }
  tracked.times_s = r.times_s;
  tracked.qpos = r.qpos;
  tracked.comments.push_back(" the simulated body tracking " + o.motion + " (mocap track)");
  mocap_io::set_motion_body(&tracked, config.character);
  std::ostringstream offsets;
  offsets << "window_start_s";
  for (int v = 0; v < r.offsets_rad.cols(); ++v) offsets << ",dof" << v;
  offsets << "\n";
  for (int w = 0; w < r.offsets_rad.rows(); ++w) {
    offsets << w * o.samcon.window_s;
    for (int v = 0; v < r.offsets_rad.cols(); ++v) offsets << "," << r.offsets_rad(w, v);
    offsets << "\n";
  }
  std::filesystem::create_directories(o.output);
  write_file_atomically(o.output + "/tracked.csv", mocap_io::format_motion_csv(tracked));
  write_file_atomically(o.output + "/offsets.csv", offsets.str());
  write_file_atomically(o.output + "/summary.json", summary.dump(1) + "\n");
  std::cout << "mocap track: " << r.windows_kept_up << "/" << r.windows << " windows of "
            << o.samcon.window_s << " s kept up"
            << (o.residual ? " (with a residual on the pelvis)" : "")
            << (r.fell_at_s >= 0 ? ", fell at " + std::to_string(r.fell_at_s) + " s" : "")
            << "; joint RMS " << r.joint_rms_rad * 180 / M_PI << " deg (max "
            << r.joint_max_rad * 180 / M_PI << "), root off by up to " << r.root_max_m
            << " m; peak torque " << 100 * r.peak_torque_ratio << "% of tau_max\n"
            << "  " << r.rollouts << " rollouts, " << r.wall_s << " s wall ("
            << (r.wall_s > 0 ? motion_s / r.wall_s : 0.0) << "x real time)\n";
  print_joint_load(r.joint_load, std::cout);
  for (int s = 0; s < 2; ++s) {
    const double lift = r.start_swing_lift_rad[static_cast<std::size_t>(s)];
    if (lift > 0) {
      std::cout << "  the " << (s == 0 ? "left" : "right")
                << " foot swings low over the floor at the start: it starts with "
                << lift * 180 / M_PI << " deg more dorsiflexion, its lowest point "
                << r.start_swing_clearance_m[static_cast<std::size_t>(s)] * 1000
                << " mm above the floor\n";
    }
  }
  if (o.residual) {
    std::cout << "  RESIDUAL on the pelvis (--residual): force RMS " << r.residual_force_rms_N
              << " N (peak " << r.residual_force_peak_N << "), moment RMS "
              << r.residual_moment_rms_Nm << " N m (peak " << r.residual_moment_peak_Nm
              << "): the body did not do this alone\n";
  }
  std::cout << "wrote " << o.output << "/{tracked.csv, offsets.csv, summary.json}\n";
  for (const std::string& n : notes) std::cout << "  note: " << n << "\n";
  return summary["kept_up"].get<bool>() ? kExitOk : kExitFailure;
}

}  // namespace

Command add_mocap_track_command(CLI::App* mocap) {
  auto o = std::make_shared<TrackOptions>();
  CLI::App* cmd = mocap->add_subcommand(
      "track",
      "Reproduce a motion (qpos CSV or BVH) on the simulated body with physics only: SAMCON "
      "sampling over the feedback tracker");
  cmd->add_option("--motion", o->motion, "motion CSV (mocap ik/retarget) or BVH")->required();
  o->character.add_to(cmd);
  cmd->add_option("--weld", o->weld, "Foot-contact mode: off | honest | glue")
      ->capture_default_str();
  cmd->add_option("--from", o->from_s, "track the motion from this time of its own, s")
      ->capture_default_str();
  cmd->add_option("--to", o->to_s,
                  "track the motion up to this time of its own, s (default: its end)");
  cmd->add_option("--lookahead", o->lookahead_s,
                  "each joint's target is the motion this far ahead, s (the feedback tracker's)")
      ->capture_default_str();
  cmd->add_flag("--residual", o->residual,
                "add a residual force and moment on the pelvis pulling it to the motion's root "
                "(a 'hand of god': reported, RMS and peak; off by default)");
  cmd->add_option("--window", o->samcon.window_s, "SAMCON window, s")->capture_default_str();
  cmd->add_option("--parents", o->samcon.parents, "states kept per window")->capture_default_str();
  cmd->add_option("--children", o->samcon.children, "rollouts per kept state")
      ->capture_default_str();
  cmd->add_option("--seed", o->samcon.seed, "random seed of the offsets")->capture_default_str();
  cmd->add_option("--root-scale", o->samcon.root_scale_m,
                  "the root this far off the motion's (horizontally or in height) costs as much "
                  "as 0.03 rad of joint error, m (smaller: the root path is held closer, the "
                  "joints less so)")
      ->capture_default_str();
  cmd->add_option("--load-scale", o->samcon.load_scale,
                  "the worst judged joint's load (motor + range stop) this far over tau_max "
                  "through a window, past its first 10 ms, costs as much as 0.03 rad of joint "
                  "error (large: stops are free)")
      ->capture_default_str();
  cmd->add_option("--threads", o->samcon.threads, "worker threads (0: every core)")
      ->capture_default_str();
  cmd->add_option("-o,--output", o->output, "output directory")->required();
  return {cmd, [o]() { return run_track(*o); }};
}

}  // namespace biodyn::apps
