// Options shared by `biodyn view` and `biodyn render` (view_options.h), and the scenario
// summaries both print: stepping stones and tracked playback.
#include "view_options.h"

#include <cmath>
#include <iomanip>
#include <sstream>

#include "biodyn/sim/errors.h"
#include "biodyn/sim/units.h"
#include "walk_options.h"

namespace biodyn::apps {

void ViewOptions::add_to(CLI::App* cmd) {
  std::string names;
  for (const std::string& n : scenarios::scenario_names())
    names += (names.empty() ? "" : " | ") + n;
  cmd->add_option("--scenario", scenario, "Scenario: " + names)->capture_default_str();
  character.add_to(cmd);
  speed_option =
      cmd->add_option("--speed", speed_m_s,
                      "walk: commanded speed, m/s (default 1.0; stones 0.7, the plan's mean step "
                      "at the gait's cadence)");
  cmd->add_option("--heading-rate", heading_rate_deg_s, "walk: turning rate, deg/s (+ left)")
      ->capture_default_str();
  cmd->add_option("--weld", weld, "Foot-contact mode: off | honest | glue")->capture_default_str();
  cmd->add_option("--controller", controller,
                  "walk, stones: how the walker drives the joints, torque (PD torques) | velocity "
                  "(the paper's velocity-based controllers)")
      ->capture_default_str();
  cmd->add_option("--params", params_path, "Walker parameters (JSON, as biodyn walk --params)");
  cmd->add_option("--controller-params", controller_params_path,
                  "Joint controller parameters (JSON, as biodyn pose --params)");
  cmd->add_option(
      "--motion", motion_path,
      "scenario mocap: the motion to play, kinematically or with --track (qpos CSV from biodyn "
      "mocap ik/retarget for this character, or a BVH retargeted on the fly)");
  only_with_mocap.push_back(
      cmd->add_option("--motion-from", motion_from_s,
                      "scenario mocap: play the motion from this time of its own, s (e.g. "
                      "where a capture's walk begins)")
          ->capture_default_str());
  only_with_mocap.push_back(
      cmd->add_option("--motion-to", motion_to_s,
                      "scenario mocap: play the motion up to this time of its own, s "
                      "(default: its end)"));
  cmd->add_flag(
      "--track", track,
      "scenario mocap: track the motion with the joint controllers (physics, muscles within "
      "tau_max, "
      "the root free; balance feedback through the hips and ankles: motion_tracker.h) instead of "
      "playing it kinematically");
  only_with_track.push_back(cmd->add_flag(
      "--track-open-loop", track_open_loop,
      "scenario mocap --track: without the balance feedback (the joints only follow the motion)"));
  only_with_track.push_back(
      cmd->add_option("--track-lookahead", track_lookahead_s,
                      "scenario mocap --track: each joint's target is the motion this far "
                      "ahead, s")
          ->capture_default_str());
  only_with_stones.push_back(
      cmd->add_option("--steps", steps,
                      "scenario stones: step lengths, m (ankle to ankle along the heading), "
                      "e.g. 0.60,0.20,0.50 (default: the paper's 0.60,0.20,0.50,0.16,0.50,0.30)"));
  only_with_stones.push_back(cmd->add_option(
      "--step-offsets", step_offsets,
      "scenario stones, with --steps: stones in 2D, each stone's offset, m, left (+) of its foot's "
      "line (as biodyn walk --step-offsets), one per --steps length, e.g. 0.05,-0.1,0"));
  only_with_stones.push_back(
      cmd->add_option("--steps-start", steps_start_s,
                      "scenario stones: when the stones begin (steady walking first), s")
          ->capture_default_str());
  muscles.add_to(cmd);
  terrain.add_to(cmd);
}

scenarios::ScenarioConfig ViewOptions::to_config(std::vector<std::string>* notes) const {
  scenarios::ScenarioConfig c;
  c.scenario = scenario;
  const bool motion_csv = scenario == "mocap" && motion_path.size() > 4 &&
                          motion_path.substr(motion_path.size() - 4) == ".csv";
  // A motion CSV is played on the body it was made on (its header), not a default one.
  std::vector<std::string> body_notes;
  c.character =
      motion_csv ? character.spec_for_motion(motion_path, &body_notes) : character.to_spec();
  if (notes != nullptr) *notes = body_notes;
  const bool speed_given = speed_option != nullptr && speed_option->count() > 0;
  c.speed_m_s = speed_given ? speed_m_s : scenario == "stones" ? 0.7 : 1.0;
  // Options of one scenario or mode are refused elsewhere, not silently ignored.
  for (const CLI::Option* o : only_with_stones) {
    if (o->count() > 0 && scenario != "stones") {
      throw sim::InvalidArgument(o->get_name() + ": only --scenario stones walks planned steps");
    }
  }
  for (const CLI::Option* o : only_with_mocap) {
    if (o->count() > 0 && scenario != "mocap")
      throw sim::InvalidArgument(o->get_name() + ": only --scenario mocap plays a motion");
  }
  for (const CLI::Option* o : only_with_track) {
    if (o->count() > 0 && !track) throw sim::InvalidArgument(o->get_name() + ": only with --track");
  }
  if (scenario == "stones" && !only_with_stones.empty() && only_with_stones.front()->count() > 0) {
    c.steps_m = parse_number_list(steps, "--steps", "step lengths in m separated by commas");
    if (c.steps_m.empty())
      throw sim::InvalidArgument("--steps: give at least one step length, got '" + steps + "'");
  }
  if (!step_offsets.empty()) {
    if (c.steps_m.empty()) throw sim::InvalidArgument("--step-offsets: only with --steps");
    c.steps_lateral_m = parse_number_list(step_offsets, "--step-offsets",
                                          "lateral offsets in m separated by commas");
  }
  c.steps_start_s = steps_start_s;
  c.heading_rate_deg_s = heading_rate_deg_s;
  c.weld = controllers::parse_weld_mode(weld, "--weld");
  c.walker_actuation = controllers::parse_walker_actuation(controller, "--controller");
  if (!params_path.empty()) {
    c.gait_json = read_file(params_path);
    c.gait_source = params_path;
  }
  c.motion_path = motion_path;
  c.motion_from_s = motion_from_s;
  c.motion_to_s = motion_to_s;
  c.track = track;
  c.tracker.lookahead_s = track_lookahead_s;
  c.tracker.balance = !track_open_loop;
  if (!controller_params_path.empty()) {
    c.controller_json = read_file(controller_params_path);
    c.controller_source = controller_params_path;
  }
  c.muscles = muscles.to_config();
  c.terrain = terrain.to_terrain();
  return c;
}

std::string ViewOptions::assumption() const {
  std::string part;
  if (motion_from_s != 0 || motion_to_s >= 0) {
    std::ostringstream o;
    o << " (its part from " << motion_from_s << " s to ";
    if (motion_to_s >= 0)
      o << motion_to_s << " s)";
    else
      o << "the end)";
    part = o.str();
  }
  if (scenario == "mocap" && !track) {
    return "kinematic playback of " + motion_path + part +
           ": joint angles as captured, no physics and no controllers (biodyn mocap id gives the "
           "forces it needs)";
  }
  std::string a;
  if (scenario == "mocap") {
    a = "motion " + motion_path + part +
        " tracked by the joint controllers: physics, joint torques within tau_max, the root "
        "moved only by "
        "muscles and contacts (" +
        std::string(track_open_loop ? "open loop, no balance feedback"
                                    : "balance feedback through the hips and ankles' targets") +
        "; a motion this body cannot balance falls); foot contact " + weld_assumption(weld);
  } else {
    a = weld_assumption(weld);
  }
  if (muscles.muscles == "on") {
    a += "; the legs' joint torques given by Hill muscles (tendons " + muscles.tendons +
         (muscles.params_path.empty() ? "" : ", parameters " + muscles.params_path) +
         "), backups within their range";
  }
  return a;
}

nlohmann::json stones_json(const std::vector<double>& plan_m,
                           const std::vector<scenarios::Stone>& stones,
                           const std::vector<double>& lateral_m) {
  nlohmann::json walked = nlohmann::json::array(), errors = nlohmann::json::array();
  nlohmann::json target_across = nlohmann::json::array(), walked_across = nlohmann::json::array();
  double sq = 0;
  for (const scenarios::Stone& st : stones) {
    if (std::isnan(st.walked_m)) continue;
    walked.push_back(st.walked_m);
    errors.push_back(st.error_m());
    target_across.push_back(st.across_m);
    walked_across.push_back(st.walked_across_m);
    sq += st.error_m() * st.error_m();
  }
  // No step walked yet: no error to report (null, "n/a"), rather than a perfect 0.
  const nlohmann::json rms =
      errors.empty() ? nlohmann::json(nullptr)
                     : nlohmann::json(std::sqrt(sq / static_cast<double>(errors.size())));
  nlohmann::json j = {
      {"targets_m", plan_m},
      {"walked_m", walked},
      {"errors_m", errors},
      {"rms_error_m", rms},
      {"definition",
       "step length ankle to ankle along the heading at each strike, against the plan"}};
  if (!lateral_m.empty()) {
    j["lateral_offsets_m"] = lateral_m;
    j["target_across_m"] = target_across;
    j["walked_across_m"] = walked_across;
    j["definition"] =
        "step ankle to ankle at each strike, along the heading (length) and across it (left of "
        "the stance ankle), against the plan; the error is the 2D distance to the stone";
  }
  return j;
}

nlohmann::json tracking_json(const scenarios::TrackingReport& r) {
  return {
      {"motion_length_s", r.motion_length_s},
      {"lookahead_s", r.lookahead_s},
      {"balance_feedback", r.balance},
      {"start_lift_m", r.start_lift_m},
      {"start_swing_lift_deg",
       {r.start_swing_lift_rad[0] * kDegPerRad, r.start_swing_lift_rad[1] * kDegPerRad}},
      {"fell_at_s", r.fell_at_s >= 0 ? nlohmann::json(r.fell_at_s) : nlohmann::json(nullptr)},
      {"kept_up_through_motion", r.kept_up()},
      {"joint_error_rms_deg", r.stats.joint_rms_rad() * kDegPerRad},
      {"joint_error_max_deg", r.stats.joint_max_rad * kDegPerRad},
      {"root_horizontal_error_max_m", r.stats.root_max_m},
      {"definition",
       "joint error: RMS over the joint groups of the rotation from the body's joint orientation "
       "to the motion's, sampled every 20 ms while the motion lasts, until a fall; root: the "
       "pelvis's "
       "horizontal distance from the motion's; kept up: no fall before the motion's end (after "
       "it the targets hold its last frame)"}};
}

std::string tracking_line(const scenarios::TrackingReport& r) {
  if (!r.tracked) return "";
  std::ostringstream out;
  out << std::fixed << std::setprecision(1) << "tracking" << (r.balance ? "" : " (open loop)")
      << ": joint error RMS " << r.stats.joint_rms_rad() * kDegPerRad << " deg (max "
      << r.stats.joint_max_rad * kDegPerRad << "), root off by up to " << std::setprecision(2)
      << r.stats.root_max_m << " m; ";
  if (!r.kept_up()) {
    out << "fell at " << r.fell_at_s << " s (motion " << r.motion_length_s << " s)";
  } else if (r.fell_at_s >= 0) {
    out << "kept up through the whole " << r.motion_length_s << " s motion; fell at " << r.fell_at_s
        << " s, after its end, holding its last frame";
  } else {
    out << "kept up, did not fall (motion " << r.motion_length_s << " s)";
  }
  return out.str();
}

std::string stones_line(const std::vector<double>& plan_m,
                        const std::vector<scenarios::Stone>& stones) {
  if (plan_m.empty()) return "";
  const nlohmann::json j = stones_json(plan_m, stones);
  std::ostringstream out;
  out << "stepping stones: " << j["walked_m"].size() << " of " << plan_m.size()
      << " planned steps walked";
  if (j["rms_error_m"].is_number()) {
    out << ", error RMS " << std::fixed << std::setprecision(1)
        << 100 * j["rms_error_m"].get<double>() << " cm";
  }
  return out.str();
}

}  // namespace biodyn::apps
