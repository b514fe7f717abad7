#include "biodyn/controllers/torque_walker.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>

#include "biodyn/sim/errors.h"
#include "biodyn/sim/queries.h"
#include "json_fields.h"

namespace biodyn::controllers {
namespace {

using Eigen::AngleAxisd;
using Eigen::Quaterniond;
using Eigen::Vector3d;

constexpr double kReferenceMass_kg = 80.0;
constexpr double kMaxSwingKnee_rad = 2.0;
// A placed step leaves early swing once its ankle is this close behind the target, m.
constexpr double kPlacedLandingReach_m = 0.02;
// A swing time phase shortens only for forward CoM speed this far above the walk's own step
// speed (catch_step_s_per_m_s): the CoM's speed within a step swings by ~0.2 m/s about the
// step's mean, and a walk's own steps stay on the clock. Chosen on random bodies at 0.25
// (0.2 and 0.35 saved fewer pushes: controllers/README.md).
constexpr double kCatchDeadband_m_s = 0.25;
// Nor in turns faster than this, rad/s (~6 deg/s): there the walk's own CoM speed along the
// heading peaks 0.3 m/s above its step mean (1.55 m / 50 kg at 1.0 m/s and 20-30 deg/s), and
// shortened swings in 30 deg/s turns cost a walk (controllers/README.md).
constexpr double kCatchMaxTurn_rad_s = 0.1;
// Nor before this many free steps after the start: a short, light body's speed still swings
// from the start's lean at ~4 s (1.55 m / 45 kg at 0.6 m/s, t_r 100 ms).
constexpr int kCatchAfterSteps = 3;
// A catching step still swings for at least this share of its time phase: the velocity
// actuation's 0.28 s early swing, cut to nothing by a hard push, put the foot straight back
// down behind the body (every push from behind at t_r 20 ms fell).
constexpr double kCatchMinShare = 0.5;
// stance_hip_load_share: below this share of the body weight on both feet together (in the air,
// or a foot only grazing the floor) the stance hip keeps the whole torso torque.
constexpr double kLoadShareMinWeight = 0.1;
// The plan's speed (plan_speed_gain) is taken within this of the command before the gain,
// m/s (a stone out of reach would otherwise lean the body far forward).
constexpr double kPlanSpeedLimit_m_s = 0.3;
// The longest leg a placed step lands with, as a fraction of thigh + shank.
constexpr double kPlacedReachFraction = 0.97;  // the IK's most flexed knee (the joint allows 2.36)

using Eigen::Vector2d;

using json_fields::check;

// Every parameter by its JSON name (the member's name).
struct NamedField {
  const char* name;
  double TorqueWalkerParams::*member;
};
#define BIODYN_FIELD(n) \
  NamedField { #n, &TorqueWalkerParams::n }
constexpr NamedField kFields[] = {BIODYN_FIELD(sagittal_cd),
                                  BIODYN_FIELD(sagittal_cv),
                                  BIODYN_FIELD(frontal_cd),
                                  BIODYN_FIELD(frontal_cv),
                                  BIODYN_FIELD(swing_hip_out_rad),
                                  BIODYN_FIELD(max_swing_roll_rad),
                                  BIODYN_FIELD(toe_up_rad),
                                  BIODYN_FIELD(pelvis_pitch_rad),
                                  BIODYN_FIELD(start_pitch_rad),
                                  BIODYN_FIELD(start_time_s),
                                  BIODYN_FIELD(start_shift_s),
                                  BIODYN_FIELD(start_shift_reach_s),
                                  BIODYN_FIELD(torso_kp),
                                  BIODYN_FIELD(hip_kp),
                                  BIODYN_FIELD(knee_kp),
                                  BIODYN_FIELD(ankle_kp),
                                  BIODYN_FIELD(stance_knee_kp),
                                  BIODYN_FIELD(stance_ankle_kp),
                                  BIODYN_FIELD(stance_weight_support),
                                  BIODYN_FIELD(toe_kp),
                                  BIODYN_FIELD(trunk_kp),
                                  BIODYN_FIELD(arm_kp),
                                  BIODYN_FIELD(distal_kp),
                                  BIODYN_FIELD(damping_time_s),
                                  BIODYN_FIELD(reference_speed_m_s),
                                  BIODYN_FIELD(speed_lean_rad_per_m_s),
                                  BIODYN_FIELD(speed_integral_rad_per_m),
                                  BIODYN_FIELD(speed_integral_step_limit_m_s),
                                  BIODYN_FIELD(speed_step_gain_rad_per_m_s),
                                  BIODYN_FIELD(speed_step_limit_rad),
                                  BIODYN_FIELD(speed_step_fade_m_s),
                                  BIODYN_FIELD(speed_recovery_gain_rad_per_m_s),
                                  BIODYN_FIELD(speed_recovery_deadband_m_s),
                                  BIODYN_FIELD(speed_lean_limit_rad),
                                  BIODYN_FIELD(speed_integral_limit_rad),
                                  BIODYN_FIELD(lateral_integral_rad_per_m),
                                  BIODYN_FIELD(lateral_integral_step_limit_m),
                                  BIODYN_FIELD(step_clearance_m),
                                  BIODYN_FIELD(placement_gain),
                                  BIODYN_FIELD(placed_wait_s),
                                  BIODYN_FIELD(placed_tuck_m),
                                  BIODYN_FIELD(catch_step_s_per_m_s),
                                  BIODYN_FIELD(catch_side_deadband_m_s),
                                  BIODYN_FIELD(plan_speed_gain),
                                  BIODYN_FIELD(stop_brake_rad_per_m_s),
                                  BIODYN_FIELD(stop_speed_m_s),
                                  BIODYN_FIELD(stop_speed_per_m_s),
                                  BIODYN_FIELD(tolerance_fraction)};
#undef BIODYN_FIELD

// A state's numbers by their JSON names.
struct StateField {
  const char* name;
  double TorqueWalkerPhase::*member;
};
#define BIODYN_STATE_FIELD(n) \
  StateField { #n, &TorqueWalkerPhase::n }
constexpr StateField kStateFields[] = {
    BIODYN_STATE_FIELD(duration_s),      BIODYN_STATE_FIELD(duration_per_m_s),
    BIODYN_STATE_FIELD(swing_hip_rad),   BIODYN_STATE_FIELD(swing_knee_rad),
    BIODYN_STATE_FIELD(swing_ankle_rad), BIODYN_STATE_FIELD(stance_knee_rad),
    BIODYN_STATE_FIELD(stance_ankle_rad)};
#undef BIODYN_STATE_FIELD

constexpr std::size_t kMaxStates = 16;

TorqueWalkerPhase read_torque_phase(const nlohmann::json& j, const std::string& where) {
  TorqueWalkerPhase st;
  st.name.clear();
  std::map<std::string, std::function<void(const nlohmann::json&, const std::string&)>> keys;
  for (const StateField& f : kStateFields)
    keys[f.name] = [&st, f](const nlohmann::json& v, const std::string& w) {
      st.*(f.member) = json_fields::read_number(v, w);
    };
  keys["name"] = [&st](const nlohmann::json& v, const std::string& w) {
    if (!v.is_string()) json_fields::fail(w, "must be a string", v.dump());
    st.name = v.get<std::string>();
  };
  keys["end"] = [&st](const nlohmann::json& v, const std::string& w) {
    if (!v.is_string() || (v != "time" && v != "strike"))
      json_fields::fail(w, "must be \"time\" or \"strike\"", v.dump());
    st.ends_at_strike = v == "strike";
  };
  keys["swing_foot_down"] = [&st](const nlohmann::json& v, const std::string& w) {
    st.swing_foot_down = json_fields::boolean(v, w);
  };
  json_fields::read_object(j, where, keys);
  return st;
}

// What a regulation integral counts of one step's value: within +-limit (0: the whole value).
// The speed and drift integrals both bound a step so that a push's step does not wind them up.
double within_step_limit(double value, double limit) {
  return limit > 0 ? std::clamp(value, -limit, limit) : value;
}

// The torque (world) of a PD turning a body at orientation q to `goal`: kp times the rotation
// between them, less kp damping_time_s times w_damped, the angular velocity it is damped
// against (SIMBICON's swing thigh and torso; kd = kp damping_time_s).
Vector3d orientation_pd(double kp, double damping_time_s, const Quaterniond& goal,
                        const Quaterniond& q, const Vector3d& w_damped) {
  return kp * rotation_vector(goal * q.conjugate()) - kp * damping_time_s * w_damped;
}

}  // namespace

const char* to_string(WalkerActuation a) {
  return a == WalkerActuation::kVelocity ? "velocity" : "torque";
}

WalkerActuation parse_walker_actuation(const std::string& text, const std::string& field) {
  if (text == "torque") return WalkerActuation::kTorque;
  if (text == "velocity") return WalkerActuation::kVelocity;
  throw sim::InvalidArgument(field + ": expected torque or velocity, got '" + text + "'");
}

TorqueWalkerParams velocity_walker_defaults() {
  // From the torque defaults' searches (walk-search: seed 1, then seed 3 from a shorter early
  // swing), then `walk-search --controller velocity --seed 4` from there (its best after 25
  // generations), then `walk-search --controller velocity --seed 5 --duration 30` from that
  // (its best, at generation 5: the first to walk t_r 100 ms at 1.0 and 1.5 m/s) with a gentler
  // start (start_pitch_rad 0.03: the searched 0.073 fell at the start on 1.55 m / 50 kg and
  // 1.95 m / 120 kg at t_r 100 ms), rounded to three decimals and re-measured
  // (controllers/README.md).
  TorqueWalkerParams p;
  TorqueWalkerPhase ds = p.phases[0];
  ds.name = "double support";
  ds.duration_s = 0.139;
  ds.duration_per_m_s = 0;
  ds.swing_hip_rad = 0;
  ds.swing_knee_rad = 0.881;
  ds.swing_ankle_rad = -0.364;
  ds.stance_knee_rad = 0.185;
  ds.stance_ankle_rad = -0.123;
  ds.swing_foot_down = true;
  TorqueWalkerPhase& early = p.phases[0];
  early.duration_s = 0.283;
  early.swing_hip_rad = 0.603;
  early.swing_knee_rad = 1.046;
  early.stance_knee_rad = 0.274;
  early.stance_ankle_rad = -0.02;
  TorqueWalkerPhase& late = p.phases[1];
  late.swing_hip_rad = -0.034;
  late.swing_knee_rad = 0.164;
  late.stance_knee_rad = 0.335;
  late.stance_ankle_rad = 0.129;
  p.phases.insert(p.phases.begin(), ds);
  p.sagittal_cd = 0.425;
  p.sagittal_cv = 0.163;
  // Lateral velocity feedback below the torque walker's 0.48, chosen by hand on pushes
  // (controllers/README.md: 0.36 survives more of them on the named and held-out bodies; the
  // torque walker loses pushes with it, and 0.30 or lower falls while walking at t_r 100 ms).
  p.frontal_cv = 0.36;
  p.toe_up_rad = 0.009;
  p.pelvis_pitch_rad = -0.04;
  p.start_pitch_rad = 0.03;
  p.hip_kp = 369.429;
  p.knee_kp = 216.92;
  p.ankle_kp = 57.013;
  p.stance_knee_kp = 723.24;
  p.stance_ankle_kp = 41.437;
  p.stance_weight_support = 0.038;
  p.back_step_landing_knee = true;
  // Its integral builds the walk's lean slowly: without the start's lean handed over, small
  // bodies met the terrain's step up still slow and stalled (controllers/README.md).
  p.start_pitch_handover = true;
  p.start_at_reference_speed = true;
  // At t_r 100 ms its first swing, lifted with the CoM midway between the feet, let light bodies
  // fall towards the swing side (controllers/README.md, eighteenth session).
  p.start_shift_s = 0.08;
  // At t_r 100 ms, 1.95 m / 115-120 kg at 0.5 m/s (weld off) fell backwards at 3.1-3.7 s, after a
  // start of 1.934 s had handed the lean over to the slow command (controllers/README.md,
  // eighteenth session).
  p.start_time_s = 3.0;
  // Its speed levels off below the command at t_r 100 ms (0.85 m/s of 1.0), the integral at its
  // bound, and with 0.1 rad short heavy women's speed ran away forwards after 8-40 s
  // (speed_integral_limit_rad; controllers/README.md, eighteenth session). Where the integral is
  // bound the speed recovery term is what answers a push from the front: it acts from a 0.3 m/s
  // deficit (speed_recovery_deadband_m_s).
  p.speed_integral_limit_rad = 0.08;
  p.speed_recovery_deadband_m_s = 0.3;
  return p;
}

TorqueWalkerParams walker_defaults(WalkerActuation actuation) {
  return actuation == WalkerActuation::kVelocity ? velocity_walker_defaults()
                                                 : TorqueWalkerParams{};
}

std::vector<TorqueWalkerPhase> default_torque_walker_phases() {
  // SIMBICON's two states per step; the numbers from the cross-entropy search (README).
  TorqueWalkerPhase early;
  early.name = "early swing";
  early.duration_s = 0.471;
  early.duration_per_m_s = 0.011;
  early.swing_hip_rad = 0.698;
  early.swing_knee_rad = 1.323;
  early.swing_ankle_rad = -0.019;
  early.stance_knee_rad = 0.207;
  early.stance_ankle_rad = -0.047;
  TorqueWalkerPhase late = early;
  late.name = "late swing";
  late.ends_at_strike = true;
  late.duration_s = 0.3;  // not used: the state ends at the strike
  late.duration_per_m_s = 0;
  late.swing_hip_rad = 0.095;
  late.swing_knee_rad = 0.186;
  late.swing_ankle_rad = 0;
  return {early, late};
}

void apply_torque_walker_json(const std::string& json_text, const std::string& source,
                              TorqueWalkerParams* params) {
  nlohmann::json root;
  try {
    root = nlohmann::json::parse(json_text);
  } catch (const nlohmann::json::exception& e) {  // parse_error, or out_of_range for 1e400
    throw sim::InvalidArgument(source + ": not valid JSON (" + std::string(e.what()) + ")");
  }
  TorqueWalkerParams p = *params;
  std::map<std::string, std::function<void(const nlohmann::json&, const std::string&)>> keys;
  for (const NamedField& f : kFields) {
    keys[f.name] = [&p, f](const nlohmann::json& v, const std::string& w) {
      p.*(f.member) = json_fields::read_number(v, w);
    };
  }
  keys["base_polygon_rule"] = [&p](const nlohmann::json& v, const std::string& w) {
    p.base_polygon_rule = json_fields::boolean(v, w);
  };
  keys["back_step_capture_point"] = [&p](const nlohmann::json& v, const std::string& w) {
    p.back_step_capture_point = json_fields::boolean(v, w);
  };
  keys["back_step_landing_knee"] = [&p](const nlohmann::json& v, const std::string& w) {
    p.back_step_landing_knee = json_fields::boolean(v, w);
  };
  keys["stance_hip_load_share"] = [&p](const nlohmann::json& v, const std::string& w) {
    p.stance_hip_load_share = json_fields::boolean(v, w);
  };
  keys["flight_stance_thigh"] = [&p](const nlohmann::json& v, const std::string& w) {
    p.flight_stance_thigh = json_fields::boolean(v, w);
  };
  keys["start_pitch_handover"] = [&p](const nlohmann::json& v, const std::string& w) {
    p.start_pitch_handover = json_fields::boolean(v, w);
  };
  keys["start_at_reference_speed"] = [&p](const nlohmann::json& v, const std::string& w) {
    p.start_at_reference_speed = json_fields::boolean(v, w);
  };
  keys["states"] = [&p](const nlohmann::json& v, const std::string& w) {
    if (!v.is_array()) json_fields::fail(w, "must be an array of states", v.dump());
    p.phases.clear();
    for (std::size_t i = 0; i < v.size(); ++i)
      p.phases.push_back(read_torque_phase(v[i], w + "[" + std::to_string(i) + "]"));
  };
  json_fields::read_object(root, source, keys);
  try {
    p.validate();
  } catch (const sim::InvalidArgument& e) {
    throw sim::InvalidArgument(source + ": " + e.what());
  }
  *params = p;
}

std::string torque_walker_json(const TorqueWalkerParams& params) {
  nlohmann::ordered_json j;
  nlohmann::ordered_json states = nlohmann::ordered_json::array();
  for (const TorqueWalkerPhase& st : params.phases) {
    nlohmann::ordered_json o;
    o["name"] = st.name;
    o["end"] = st.ends_at_strike ? "strike" : "time";
    for (const StateField& f : kStateFields) o[f.name] = st.*(f.member);
    o["swing_foot_down"] = st.swing_foot_down;
    states.push_back(o);
  }
  j["states"] = states;
  for (const NamedField& f : kFields) j[f.name] = params.*(f.member);
  j["base_polygon_rule"] = params.base_polygon_rule;
  j["back_step_capture_point"] = params.back_step_capture_point;
  j["back_step_landing_knee"] = params.back_step_landing_knee;
  j["stance_hip_load_share"] = params.stance_hip_load_share;
  j["flight_stance_thigh"] = params.flight_stance_thigh;
  j["start_pitch_handover"] = params.start_pitch_handover;
  j["start_at_reference_speed"] = params.start_at_reference_speed;
  return j.dump(2) + "\n";
}

void TorqueWalkerParams::validate() const {
  const std::vector<TorqueWalkerPhase>& states = phases;  // JSON "states"
  const std::string w = "walker.";
  if (states.empty()) json_fields::fail(w + "states", "needs at least one state", "none");
  if (states.size() > kMaxStates)
    json_fields::fail(w + "states", "has at most " + std::to_string(kMaxStates) + " states",
                      std::to_string(states.size()));
  for (std::size_t i = 0; i < states.size(); ++i) {
    const TorqueWalkerPhase& st = states[i];
    const std::string ws = w + "states[" + std::to_string(i) + "]";
    if (st.name.empty()) json_fields::fail(ws + ".name", "must be a non-empty string", "\"\"");
    for (std::size_t k = 0; k < i; ++k)
      if (states[k].name == st.name)
        json_fields::fail(ws + ".name", "must differ from the other states' names",
                          "\"" + st.name + "\"");
    const bool last = i + 1 == states.size();
    if (st.ends_at_strike != last)
      json_fields::fail(ws + ".end",
                        last ? "the last state of a step must end at the strike"
                             : "only the last state ends at the strike",
                        st.ends_at_strike ? "\"strike\"" : "\"time\"");
    if (last && st.swing_foot_down)
      json_fields::fail(ws + ".swing_foot_down",
                        "the state that ends at the strike must lift the swing foot", "true");
    check(st.duration_s > 0.05 && st.duration_s <= 2, ws + ".duration_s", "must be in (0.05, 2] s",
          st.duration_s);
    check(st.duration_per_m_s >= 0 && st.duration_per_m_s <= 1, ws + ".duration_per_m_s",
          "must be in [0, 1] s per m/s", st.duration_per_m_s);
    for (const StateField& f : kStateFields) {
      const std::string n = f.name;
      if (n.size() > 4 && n.compare(n.size() - 4, 4, "_rad") == 0)
        check(std::abs(st.*(f.member)) <= M_PI, ws + "." + n, "must be within +-pi rad",
              st.*(f.member));
    }
  }
  check(start_time_s >= 0 && start_time_s <= 10, w + "start_time_s", "must be in [0, 10] s",
        start_time_s);
  check(start_shift_s >= 0 && start_shift_s <= 1, w + "start_shift_s", "must be in [0, 1] s",
        start_shift_s);
  check(start_shift_reach_s > 0 && start_shift_reach_s <= 2, w + "start_shift_reach_s",
        "must be in (0, 2] s", start_shift_reach_s);
  check(damping_time_s >= 0 && damping_time_s <= 1, w + "damping_time_s", "must be in [0, 1] s",
        damping_time_s);
  const std::pair<const char*, double> angles[] = {{"swing_hip_out_rad", swing_hip_out_rad},
                                                   {"toe_up_rad", toe_up_rad},
                                                   {"pelvis_pitch_rad", pelvis_pitch_rad},
                                                   {"start_pitch_rad", start_pitch_rad}};
  for (const auto& [name, a] : angles)
    check(std::abs(a) <= M_PI, w + name, "must be within +-pi rad", a);
  const std::pair<const char*, double> gains[] = {{"torso_kp", torso_kp},
                                                  {"hip_kp", hip_kp},
                                                  {"knee_kp", knee_kp},
                                                  {"ankle_kp", ankle_kp},
                                                  {"stance_knee_kp", stance_knee_kp},
                                                  {"stance_ankle_kp", stance_ankle_kp},
                                                  {"toe_kp", toe_kp},
                                                  {"trunk_kp", trunk_kp},
                                                  {"arm_kp", arm_kp},
                                                  {"distal_kp", distal_kp}};
  for (const auto& [name, k] : gains)
    check(k >= 0 && k <= 1e5, w + name, "must be in [0, 1e5] N m/rad", k);
  const std::pair<const char*, double> feedback[] = {{"sagittal_cd", sagittal_cd},
                                                     {"sagittal_cv", sagittal_cv},
                                                     {"frontal_cd", frontal_cd},
                                                     {"frontal_cv", frontal_cv}};
  for (const auto& [name, c] : feedback)
    check(std::abs(c) <= 10, w + name, "must be within +-10", c);
  check(max_swing_roll_rad > 0 && max_swing_roll_rad <= M_PI / 2, w + "max_swing_roll_rad",
        "must be in (0, pi/2] rad", max_swing_roll_rad);
  check(stance_weight_support >= 0 && stance_weight_support <= 1.5, w + "stance_weight_support",
        "must be in [0, 1.5] body weights", stance_weight_support);
  check(reference_speed_m_s > 0 && reference_speed_m_s <= 3, w + "reference_speed_m_s",
        "must be in (0, 3] m/s", reference_speed_m_s);
  check(std::abs(speed_lean_rad_per_m_s) <= 1, w + "speed_lean_rad_per_m_s", "must be within +-1",
        speed_lean_rad_per_m_s);
  check(speed_integral_rad_per_m >= 0 && speed_integral_rad_per_m <= 2,
        w + "speed_integral_rad_per_m", "must be in [0, 2]", speed_integral_rad_per_m);
  check(speed_step_gain_rad_per_m_s >= 0 && speed_step_gain_rad_per_m_s <= 2,
        w + "speed_step_gain_rad_per_m_s", "must be in [0, 2]", speed_step_gain_rad_per_m_s);
  check(speed_integral_step_limit_m_s >= 0 && speed_integral_step_limit_m_s <= 3,
        w + "speed_integral_step_limit_m_s", "must be in [0, 3] m/s (0: no limit)",
        speed_integral_step_limit_m_s);
  check(speed_step_limit_rad >= 0 && speed_step_limit_rad <= 0.5, w + "speed_step_limit_rad",
        "must be in [0, 0.5]", speed_step_limit_rad);
  check(speed_step_fade_m_s > 0 && speed_step_fade_m_s <= 2, w + "speed_step_fade_m_s",
        "must be in (0, 2]", speed_step_fade_m_s);
  check(speed_recovery_gain_rad_per_m_s >= 0 && speed_recovery_gain_rad_per_m_s <= 2,
        w + "speed_recovery_gain_rad_per_m_s", "must be in [0, 2]",
        speed_recovery_gain_rad_per_m_s);
  check(speed_recovery_deadband_m_s >= 0 && speed_recovery_deadband_m_s <= 2,
        w + "speed_recovery_deadband_m_s", "must be in [0, 2]", speed_recovery_deadband_m_s);
  check(lateral_integral_rad_per_m >= 0 && lateral_integral_rad_per_m <= 2,
        w + "lateral_integral_rad_per_m", "must be in [0, 2]", lateral_integral_rad_per_m);
  check(lateral_integral_step_limit_m >= 0 && lateral_integral_step_limit_m <= 5,
        w + "lateral_integral_step_limit_m", "must be in [0, 5] m (0: no limit)",
        lateral_integral_step_limit_m);
  check(step_clearance_m >= 0 && step_clearance_m <= 0.5, w + "step_clearance_m",
        "must be in [0, 0.5] m", step_clearance_m);
  check(std::abs(stop_brake_rad_per_m_s) <= 2, w + "stop_brake_rad_per_m_s", "must be within +-2",
        stop_brake_rad_per_m_s);
  check(stop_speed_m_s > 0 && stop_speed_m_s <= 1, w + "stop_speed_m_s", "must be in (0, 1] m/s",
        stop_speed_m_s);
  check(tolerance_fraction > 0 && tolerance_fraction <= 0.5, w + "tolerance_fraction",
        "must be in (0, 0.5]", tolerance_fraction);
  check(placement_gain >= 0 && placement_gain <= 10, w + "placement_gain", "must be in [0, 10]",
        placement_gain);
  check(placed_wait_s >= 0 && placed_wait_s <= 0.5, w + "placed_wait_s", "must be in [0, 0.5] s",
        placed_wait_s);
  check(catch_step_s_per_m_s >= 0 && catch_step_s_per_m_s <= 1, w + "catch_step_s_per_m_s",
        "must be in [0, 1] s per m/s", catch_step_s_per_m_s);
  check(catch_side_deadband_m_s >= 0 && catch_side_deadband_m_s <= 2, w + "catch_side_deadband_m_s",
        "must be in [0, 2] m/s", catch_side_deadband_m_s);
  check(std::abs(placed_tuck_m) <= 1, w + "placed_tuck_m", "must be within +-1 m", placed_tuck_m);
  check(plan_speed_gain >= 0 && plan_speed_gain <= 10, w + "plan_speed_gain", "must be in [0, 10]",
        plan_speed_gain);
  check(speed_lean_limit_rad >= 0 && speed_lean_limit_rad <= 0.5, w + "speed_lean_limit_rad",
        "must be in [0, 0.5] rad", speed_lean_limit_rad);
  check(speed_integral_limit_rad >= 0 && speed_integral_limit_rad <= 0.5,
        w + "speed_integral_limit_rad", "must be in [0, 0.5] rad", speed_integral_limit_rad);
}

void TorqueWalker::set_params(const TorqueWalkerParams& params) {
  params.validate();
  params_ = params;
  const int last = static_cast<int>(params_.phases.size()) - 1;
  state_.phase = std::min(state_.phase, last);
  set_gains();
}

TorqueWalker::TorqueWalker(const models::Rig& rig, TorqueWalkerParams params)
    : params_(std::move(params)), rig_(&rig) {
  params_.validate();
  rig.require_legs("torque walker");
  lumbar_ = rig.require_lower_back("torque walker");
  state_.plan.reserve(8);  // the stop plan is made inside drive(): no allocation there
  state_.support.reserve(128);
  state_.tolerance.reserve(128);
  gain_scale_ = rig.mass_kg() / kReferenceMass_kg;
  body_mass_kg_ = rig.mass_kg();
  const std::vector<JointGroup>& groups = rig.groups();
  leg_.assign(groups.size(), false);
  for (int s = 0; s < 2; ++s) {
    const models::RigLeg& leg = rig.leg(s);
    for (int g : {leg.hip, leg.knee, leg.ankle, leg.toe})
      if (g >= 0) leg_[static_cast<std::size_t>(g)] = true;
  }
  set_gains();
}

void TorqueWalker::set_gains() {
  // Non-leg groups hold the standing pose (zero angles) by PD.
  const std::vector<JointGroup>& groups = rig_->groups();
  kp_.assign(groups.size(), 0.0);
  for (std::size_t g = 0; g < groups.size(); ++g) {
    const std::string& n = groups[g].name;
    const auto starts = [&](const char* p) { return n.rfind(p, 0) == 0; };
    if (starts("lumbar") || starts("thorax") || starts("trunk"))
      kp_[g] = params_.trunk_kp;
    else if (starts("shoulder") || starts("clavicle"))
      kp_[g] = params_.arm_kp;
    else
      kp_[g] = params_.distal_kp;
  }
}

void TorqueWalker::reset(const mjData& d) {
  const double speed = state_.speed_m_s, rate = state_.heading_rate_rad_s;
  std::vector<double> plan = std::move(state_.plan);
  std::vector<Eigen::Vector2d> support = std::move(state_.support),
                               tolerance = std::move(state_.tolerance);
  state_ = TorqueWalkerState{};
  state_.speed_m_s = speed;  // the command stays
  state_.heading_rate_rad_s = rate;
  state_.plan = std::move(plan);  // keeps the buffers' capacity (the stop plan is made in drive())
  state_.plan.clear();
  state_.support = std::move(support);
  state_.support.clear();
  state_.tolerance = std::move(tolerance);
  state_.tolerance.clear();
  // From standing the first step starts with its first phase that lifts the swing foot (a
  // double support's push-off has nothing to push off from yet).
  while (params_.phases[static_cast<std::size_t>(state_.phase)].swing_foot_down) ++state_.phase;
  state_.phase_start_s = state_.start_s = d.time;
  const Vector3d forward = sim::quat_at(d.xquat + 4 * rig_->pelvis()) * Vector3d::UnitX();
  state_.heading.reset(std::atan2(forward.y(), forward.x()), d.time);
  // Ankle height above the floor with the sole flat (the character starts standing).
  state_.ankle_height_m = std::min(d.xpos[3 * rig_->leg(models::kLeft).foot + 2],
                                   d.xpos[3 * rig_->leg(models::kRight).foot + 2]);
}

void TorqueWalker::request_stop() {
  if (state_.stopping) return;
  state_.stopping = true;  // braking first: see on_strike()
  state_.stop_from_m_s = state_.speed_m_s;
  state_.speed_m_s = 0;
  state_.lean_step = 0;  // the step term is for a walking command, not for braking
}

void TorqueWalker::validate_plan(const std::vector<double>& lengths_m,
                                 const std::vector<double>& widths_m) {
  for (std::size_t i = 0; i < lengths_m.size(); ++i)
    check(lengths_m[i] >= 0 && lengths_m[i] <= 1.5, "planned step " + std::to_string(i + 1),
          "must be in [0, 1.5] m", lengths_m[i]);
  if (widths_m.empty()) return;
  check(widths_m.size() == lengths_m.size(), "planned widths",
        "must be one per planned step (" + std::to_string(lengths_m.size()) + ")",
        static_cast<double>(widths_m.size()));
  for (std::size_t i = 0; i < widths_m.size(); ++i)
    check(widths_m[i] >= -0.3 && widths_m[i] <= 0.8,
          "planned step " + std::to_string(i + 1) + " width", "must be in [-0.3, 0.8] m",
          widths_m[i]);
}

void TorqueWalker::plan_steps(const std::vector<double>& lengths_m,
                              const std::vector<double>& widths_m) {
  validate_plan(lengths_m, widths_m);
  state_.plan = lengths_m;
  state_.plan_width = widths_m;
  state_.plan_next = 0;
}

double TorqueWalker::speed_lean_rad(bool starting) const {
  const TorqueWalkerParams& p = params_;
  // start_at_reference_speed: the command's feed-forward lean waits for the start to end.
  const double v =
      starting && p.start_at_reference_speed ? p.reference_speed_m_s
      : std::isnan(state_.plan_speed_m_s)
          ? state_.speed_m_s
          : state_.speed_m_s +
                p.plan_speed_gain * std::clamp(state_.plan_speed_m_s - state_.speed_m_s,
                                               -kPlanSpeedLimit_m_s, kPlanSpeedLimit_m_s);
  return std::clamp(p.speed_lean_rad_per_m_s * (v - p.reference_speed_m_s) + state_.lean_integral +
                        state_.lean_step,
                    -p.speed_lean_limit_rad, p.speed_lean_limit_rad);
}

double TorqueWalker::phase_duration_s(int phase, bool starting) const {
  const TorqueWalkerPhase& ph = params_.phases[static_cast<std::size_t>(phase)];
  // start_at_reference_speed: the command's phase lengths wait for the start to end.
  const double v =
      starting && params_.start_at_reference_speed ? params_.reference_speed_m_s : state_.speed_m_s;
  return std::max(ph.duration_s - ph.duration_per_m_s * (v - params_.reference_speed_m_s), 0.05);
}

double TorqueWalker::hinge_pd(ControlFrame* f, const mjModel& m, const mjData& d, int dof,
                              double target, double kp, double target_rate,
                              double feedforward) const {
  const double k = kp * gain_scale_;
  const double tau = k * (target - d.qpos[m.jnt_qposadr[m.dof_jntid[dof]]]) +
                     k * params_.damping_time_s * (target_rate - d.qvel[dof]) + feedforward;
  f->set_torque(dof, tau);
  return tau;
}

void TorqueWalker::hip_torque(ControlFrame* f, const mjData& d, int side,
                              const Vector3d& torque_W) const {
  // Ball-joint DOFs act in the child's (thigh's) frame.
  const models::RigLeg& leg = rig_->leg(side);
  const Vector3d t_B = sim::quat_at(d.xquat + 4 * leg.thigh).conjugate() * torque_W;
  const int dof = rig_->groups()[static_cast<std::size_t>(leg.hip)].dof_begin;
  for (int k = 0; k < 3; ++k) f->set_torque(dof + k, t_B[k]);
}

void TorqueWalker::drive(const ControlInput& in, ControlFrame* frame) {
  const mjModel& m = in.m;
  const mjData& d = in.d;
  state_.heading.advance(d.time, state_.heading_rate_rad_s);
  const sim::CenterOfMass com =
      sim::center_of_mass(m, d);  // for the speed regulation and placement
  advance_phases(m, d, com);
  const int stance = state_.stance, swing = 1 - stance;
  const TorqueWalkerPhase& ph = params_.phases[static_cast<std::size_t>(state_.phase)];
  frame->set_stance(stance, true);
  frame->set_stance(swing, ph.swing_foot_down);
  const Vector3d tau_lumbar = hold_upper_body(frame, m, d);

  // The balance feedback's inputs (SIMBICON): CoM relative to the stance ankle, and its
  // velocity, in the heading frame.
  const models::RigLeg& stance_leg = rig_->leg(stance);
  const Vector3d rel = state_.heading.to_heading(
      Vector3d(com.position_W - sim::vec3_at(d.xpos + 3 * stance_leg.foot)));
  const Vector3d vel = state_.heading.to_heading(com.velocity_W);
  if (params_.base_polygon_rule && !state_.stopped && !ph.swing_foot_down &&
      std::isnan(state_.swing_target_m))
    apply_base_polygon_rule(m, d, com.position_W, vel);
  const bool placed = !std::isnan(state_.swing_target_m) && !ph.swing_foot_down;
  LegTriangle ik;
  if (placed) {
    ik = placed_step_ik(d, ph);
  } else {
    state_.ik_valid = false;
  }
  leg_joints(frame, m, d, ph, placed, ik);

  // Swing thigh in the heading frame, placed by the balance feedback (SIMBICON), or by the IK.
  const Vector2d pitch_roll = swing_thigh_angles(d, ph, placed, ik, rel, vel);
  const Quaterniond q_heading = state_.heading.rotation();
  const Quaterniond q_thigh_goal = q_heading *
                                   Quaterniond(AngleAxisd(-pitch_roll.x(), Vector3d::UnitY())) *
                                   Quaterniond(AngleAxisd(pitch_roll.y(), Vector3d::UnitX()));
  const Vector3d w_pelvis = sim::vec3_at(d.cvel + 6 * rig_->pelvis());
  const Vector3d w_thigh = sim::vec3_at(d.cvel + 6 * rig_->leg(swing).thigh);
  const TorqueWalkerParams& p = params_;
  const double k_hip = p.hip_kp * gain_scale_;
  // A placed step's thigh follows the IK pitch's rate in the world; a free one is damped
  // relative to the pelvis (SIMBICON).
  const Vector3d w_damped =
      placed ? Vector3d(w_thigh - q_heading * Vector3d(0, -state_.ik_pitch_rate, 0))
             : Vector3d(w_thigh - w_pelvis);
  const Vector3d tau_swing =
      orientation_pd(k_hip, p.damping_time_s, q_thigh_goal,
                     sim::quat_at(d.xquat + 4 * rig_->leg(swing).thigh), w_damped);

  // Pelvis in the world by the virtual torso torque; the stance hip makes it (Coros 2010).
  const bool starting = in_start(d.time);
  const double lean =
      p.pelvis_pitch_rad + (starting ? p.start_pitch_rad : 0.0) + speed_lean_rad(starting);
  const Quaterniond q_pelvis_goal = q_heading * Quaterniond(AngleAxisd(lean, Vector3d::UnitY()));
  const double k_torso = p.torso_kp * gain_scale_;
  const Vector3d tau_torso = orientation_pd(k_torso, p.damping_time_s, q_pelvis_goal,
                                            sim::quat_at(d.xquat + 4 * rig_->pelvis()), w_pelvis);
  if (actuation_ == WalkerActuation::kVelocity) {
    hip_targets(frame, m, d, q_thigh_goal, q_pelvis_goal, ph.swing_foot_down);
    return;
  }
  hip_torque(frame, d, swing, tau_swing);
  // SIMBICON's whole torque on the pelvis; in the air (flight_stance_thigh) the stance thigh
  // upright in the heading frame instead, damped relative to the pelvis like a free swing;
  // stance_hip_load_share: the roll and yaw parts follow the stance foot's share of the load,
  // the pitch part (about the heading's sideways axis) stays whole.
  Vector3d tau_stance = -tau_torso - tau_swing - tau_lumbar;
  if (params_.flight_stance_thigh && !foot_touches_floor(m, d, *rig_, stance) &&
      !foot_touches_floor(m, d, *rig_, swing)) {
    const int thigh = rig_->leg(stance).thigh;
    tau_stance =
        orientation_pd(k_hip, p.damping_time_s, q_heading, sim::quat_at(d.xquat + 4 * thigh),
                       sim::vec3_at(d.cvel + 6 * thigh) - w_pelvis);
  } else if (params_.stance_hip_load_share) {
    const Vector2d along = state_.heading.along();
    const Vector3d pitch_axis(-along.y(), along.x(), 0);
    const Vector3d tau_pitch = tau_stance.dot(pitch_axis) * pitch_axis;
    tau_stance = tau_pitch + stance_hip_share(m, in.last_report) * (tau_stance - tau_pitch);
  }
  hip_torque(frame, d, stance, tau_stance);
}

double TorqueWalker::stance_hip_share(const mjModel& m, const StepReport& last) const {
  const double stance = foot_load_N(last, state_.stance);
  const double swing = foot_load_N(last, 1 - state_.stance);
  const double weight = body_mass_kg_ * std::abs(m.opt.gravity[2]);
  if (stance + swing <= kLoadShareMinWeight * weight) return 1.0;  // in the air: nothing to share
  return stance / (stance + swing);
}

void TorqueWalker::hinge_target(ControlFrame* f, const mjData& d, int group, double angle,
                                double kp, bool spring) const {
  f->set_joint_angles(group, Vector3d(angle, 0, 0), d.time + params_.damping_time_s);
  if (spring) {
    const double k = kp * gain_scale_;
    f->set_spring(group, k, k * params_.damping_time_s);
  }
}

void TorqueWalker::hip_targets(ControlFrame* f, const mjModel& m, const mjData& d,
                               const Quaterniond& q_thigh_goal, const Quaterniond& q_pelvis_goal,
                               bool swing_down) const {
  const TorqueWalkerParams& p = params_;
  const double t = p.damping_time_s;  // the optimal time of every target
  const Quaterniond q_pelvis = sim::quat_at(d.xquat + 4 * rig_->pelvis());
  const Vector3d w_pelvis = sim::vec3_at(d.cvel + 6 * rig_->pelvis());
  const int stance = state_.stance, swing = 1 - stance;
  // Stance hip (paper §4.1): the pelvis to its world goal. Its relative target is the one that
  // puts the pelvis there for the thigh where it is; with the foot on the floor the thigh's own
  // rotation is fed forward, so the pelvis's world velocity goes to e / t.
  const models::RigLeg& stance_leg = rig_->leg(stance);
  const Quaterniond q_stance_thigh = sim::quat_at(d.xquat + 4 * stance_leg.thigh);
  f->set_target(stance_leg.hip, q_pelvis_goal.conjugate() * q_stance_thigh, d.time + t);
  if (foot_touches_floor(m, d, *rig_, stance)) {
    const Vector3d w_wanted = rotation_vector(q_pelvis_goal * q_pelvis.conjugate()) / t;
    const Vector3d w_thigh = sim::vec3_at(d.cvel + 6 * stance_leg.thigh);
    f->set_velocity(stance_leg.hip, q_stance_thigh.conjugate() * (w_thigh - w_wanted));
  }
  // Swing hip: the thigh to its heading-frame goal (balance feedback, IK), the pelvis's rotation
  // fed forward; a trailing foot still on the floor makes it a spring.
  const models::RigLeg& swing_leg = rig_->leg(swing);
  f->set_target(swing_leg.hip, q_pelvis.conjugate() * q_thigh_goal, d.time + t);
  if (swing_down) {
    const double k = p.hip_kp * gain_scale_;
    f->set_spring(swing_leg.hip, k, k * t);
    return;
  }
  const Quaterniond q_thigh = sim::quat_at(d.xquat + 4 * swing_leg.thigh);
  const Vector3d w_wanted = rotation_vector(q_thigh_goal * q_thigh.conjugate()) / t;
  f->set_velocity(swing_leg.hip, q_thigh.conjugate() * (w_wanted - w_pelvis));
}

void TorqueWalker::advance_phases(const mjModel& m, const mjData& d, const sim::CenterOfMass& com) {
  const int swing = 1 - state_.stance;
  const bool struck = state_.strike.update(foot_touches_floor(m, d, *rig_, swing));
  const TorqueWalkerPhase& ph = params_.phases[static_cast<std::size_t>(state_.phase)];
  if (!ph.ends_at_strike) {
    double duration = phase_duration_s(state_.phase, in_start(d.time));
    // Not while stopping (the command is 0 then) or stepping on planned stones (their own
    // timing and speed; a placed step comes down by its target, below).
    // Nor before the walk has a speed of its own (the start from standing overshoots a slow
    // command): the reference is the walk's last free step, so a push acts, and a walk that
    // speeds up (down a hill) moves its reference along.
    if (!ph.swing_foot_down && params_.catch_step_s_per_m_s > 0 && !state_.stopping &&
        std::isnan(state_.swing_target_m) && std::isnan(state_.plan_speed_m_s) &&
        state_.walk_steps >= kCatchAfterSteps &&
        std::abs(state_.heading_rate_rad_s) <= kCatchMaxTurn_rad_s) {
      const Vector2d v = state_.heading.to_heading(Vector2d(com.velocity_W.head<2>()));
      const double reference = std::max(state_.walk_step_speed_m_s, state_.speed_m_s);
      double excess = v.x() - reference - kCatchDeadband_m_s;
      // Sideways, either way (catch_side_deadband_m_s): towards the swing side the side step,
      // towards the stance side the crossover comes sooner.
      if (params_.catch_side_deadband_m_s > 0)
        excess = std::max(excess, std::abs(v.y()) - params_.catch_side_deadband_m_s);
      if (excess > 0)
        duration =
            std::max(duration - params_.catch_step_s_per_m_s * excess, kCatchMinShare * duration);
    }
    bool done = d.time - state_.phase_start_s >= duration;
    // (Not the closing step of a stop: it starts beside its target and needs the time to
    // move the foot out to the standing width.)
    if (!done && !closing_step() && !std::isnan(state_.swing_target_m) && !ph.swing_foot_down) {
      // A placed step comes down as soon as its ankle is over the target (a short step would
      // otherwise be overtaken by the hip).
      const Vector2d along = state_.heading.along();
      const Vector3d delta = sim::vec3_at(d.xpos + 3 * rig_->leg(swing).foot) -
                             sim::vec3_at(d.xpos + 3 * rig_->leg(state_.stance).foot);
      done = along.x() * delta.x() + along.y() * delta.y() >=
             state_.swing_target_m - kPlacedLandingReach_m;
    }
    if (done) {
      ++state_.phase;
      state_.phase_start_s = d.time;
    }
  }
  if (!state_.stopped && params_.phases[static_cast<std::size_t>(state_.phase)].ends_at_strike &&
      struck) {
    on_strike(d, com, swing);
  }
}

void TorqueWalker::on_strike(const mjData& d, const sim::CenterOfMass& com, int swing) {
  const TorqueWalkerParams& p = params_;
  TorqueWalkerState& st = state_;
  const Vector3d delta = sim::vec3_at(d.xpos + 3 * rig_->leg(swing).foot) -
                         sim::vec3_at(d.xpos + 3 * rig_->leg(st.stance).foot);
  const double ch = std::cos(st.heading.heading_rad()), sh = std::sin(st.heading.heading_rad());
  // Speed regulation: the step's mean CoM speed along the heading against the command
  // (not during the start from standing, and not before there was a step).
  const Vector3d& com_now = com.position_W;
  // Planned steps and steps the base-polygon rule moved are not the gait's own.
  if (st.strikes > 0 && !in_start(d.time) && std::isnan(st.swing_target_m) &&
      !base_polygon_rule_active()) {
    const double t_step = d.time - st.last_strike.time_s;
    const double v_step =
        (ch * (com_now.x() - st.com_at_strike.x()) + sh * (com_now.y() - st.com_at_strike.y())) /
        std::max(t_step, 1e-3);
    const double deficit = st.speed_m_s - v_step;
    const double fade =
        st.stopping
            ? 0.0
            : std::clamp((p.reference_speed_m_s - st.speed_m_s) / p.speed_step_fade_m_s, 0.0, 1.0);
    // Where the step term acts (weighted by its fade), the integral counts the deficit only
    // within +-speed_integral_step_limit_m_s: a push's deficit is the step term's to answer,
    // and counted whole it wound the lean up. Elsewhere (at and above the reference, where the
    // integral is the only regulator, and while stopping) it counts the whole deficit.
    const double counted =
        fade * within_step_limit(deficit, p.speed_integral_step_limit_m_s) + (1.0 - fade) * deficit;
    // Above the reference the feed-forward lean counts against the integral's bound: a command
    // the gait cannot reach winds the integral to it, and that lean on top of the feed-forward
    // tipped short bodies over at 1.5 m/s (speed_integral_limit_rad).
    const double feedforward =
        std::max(0.0, p.speed_lean_rad_per_m_s * (st.speed_m_s - p.reference_speed_m_s));
    const double integral_max = std::max(0.0, p.speed_integral_limit_rad - feedforward);
    st.lean_integral = std::clamp(st.lean_integral + p.speed_integral_rad_per_m * counted * t_step,
                                  -p.speed_integral_limit_rad, integral_max);
    if (p.start_pitch_handover && st.walk_steps == 0 && !st.stopping)  // the first free step
      st.lean_integral = std::clamp(std::max(st.lean_integral, p.start_pitch_rad),
                                    -p.speed_integral_limit_rad, integral_max);
    st.lean_step = std::clamp(fade * p.speed_step_gain_rad_per_m_s * deficit,
                              -p.speed_step_limit_rad, p.speed_step_limit_rad);
    // After a near stop (a push from the front) the lean comes at once, not after the integral's
    // windup (speed_recovery_gain_rad_per_m_s); where the step term acts, it does this already.
    // Only once the walk has been at the command: a start or a faster command is the
    // integral's (acting in starts to 1.5 m/s, it made walks at t_r 100 ms fall sooner).
    if (!st.stopping && st.at_speed)
      st.lean_step += (1.0 - fade) * p.speed_recovery_gain_rad_per_m_s *
                      std::max(deficit - p.speed_recovery_deadband_m_s, 0.0);
    if (std::abs(deficit) <= p.speed_recovery_deadband_m_s) st.at_speed = true;
    const double sideways =
        -sh * (com_now.x() - st.com_at_strike.x()) + ch * (com_now.y() - st.com_at_strike.y());
    // The drift integral counts a step's sideways travel up to a drift's size (a push's is
    // the balance feedback's); 0: the whole travel.
    const double drift = within_step_limit(sideways, p.lateral_integral_step_limit_m);
    st.roll_integral = std::clamp(st.roll_integral + p.lateral_integral_rad_per_m * drift,
                                  -p.speed_lean_limit_rad, p.speed_lean_limit_rad);
    if (!st.stopping) {
      st.walk_step_speed_m_s = v_step;
      ++st.walk_steps;
    }
  }
  if (std::isnan(st.swing_target_m) && st.strikes > 0)
    st.free_step_s = d.time - st.last_strike.time_s;
  st.com_at_strike = com_now;
  st.last_strike = {d.time,
                    swing,
                    ch * delta.x() + sh * delta.y(),
                    std::abs(-sh * delta.x() + ch * delta.y()),
                    -sh * delta.x() + ch * delta.y(),
                    st.swing_target_m,
                    st.swing_width_m,
                    !std::isnan(st.swing_target_m) && st.swing_out_of_reach};
  st.swing_out_of_reach = false;
  st.swing_width_m = std::numeric_limits<double>::quiet_NaN();
  st.swing_target_m = std::numeric_limits<double>::quiet_NaN();
  if (st.plan_next < static_cast<int>(st.plan.size())) {
    const auto k = static_cast<std::size_t>(st.plan_next++);
    st.swing_target_m = st.plan[k];
    if (k < st.plan_width.size()) st.swing_width_m = st.plan_width[k];
  }
  st.plan_speed_m_s = std::numeric_limits<double>::quiet_NaN();
  if (st.free_step_s > 0 && st.plan_next <= static_cast<int>(st.plan.size()) &&
      !std::isnan(st.swing_target_m) && !st.stopping) {
    // The plan's speed at the free gait's step time: this and the next two stones' mean length
    // (plan_speed_gain).
    double sum = 0;
    int n = 0;
    for (std::size_t j = static_cast<std::size_t>(st.plan_next) - 1; j < st.plan.size() && n < 3;
         ++j, ++n)
      sum += st.plan[j];
    st.plan_speed_m_s = sum / n / st.free_step_s;
  }
  ++st.strikes;
  if (base_polygon_rule_active()) ++st.rule_steps;
  st.rule_length_m = st.rule_width_m = std::numeric_limits<double>::quiet_NaN();
  st.rule_bound = false;
  if (st.stopping) {
    if (!std::isnan(st.last_strike.target_length_m) && st.last_strike.target_length_m == 0.0) {
      st.stopped = true;  // the feet are side by side: no more steps
    } else if (std::isnan(st.swing_target_m) && st.plan_next >= static_cast<int>(st.plan.size())) {
      // Braking until the CoM is slow, then one step that brings the feet side by side.
      const double v = ch * com.velocity_W.x() + sh * com.velocity_W.y();
      const double stop_speed =
          p.stop_speed_m_s -
          p.stop_speed_per_m_s * std::max(p.reference_speed_m_s - st.stop_from_m_s, 0.0);
      if (v < stop_speed) {
        st.plan.assign(1, 0.0);
        st.plan_width.clear();
        st.plan_next = 0;
        st.swing_target_m = st.plan[static_cast<std::size_t>(st.plan_next++)];
      }
    }
  }
  st.stance = swing;
  st.phase = 0;
  st.strike.start_swing();
  st.phase_start_s = d.time;
}

Vector3d TorqueWalker::hold_upper_body(ControlFrame* f, const mjModel& m, const mjData& d) const {
  // The lumbar's torque on the pelvis is minus its torque on the upper body (about its hinge
  // axes): the stance hip takes it.
  Vector3d tau_lumbar = Vector3d::Zero();
  const std::vector<JointGroup>& groups = rig_->groups();
  for (std::size_t g = 0; g < groups.size(); ++g) {
    const JointGroup& jg = groups[g];
    if (leg_[g]) continue;
    if (actuation_ == WalkerActuation::kVelocity) {
      // The standing pose (zero angles) with the walker's optimal time.
      f->set_joint_angles(static_cast<int>(g), Vector3d::Zero(), d.time + params_.damping_time_s);
      continue;
    }
    if (!jg.ball) {
      for (int k = 0; k < jg.dof_count; ++k) {
        const double tau = hinge_pd(f, m, d, jg.dof_begin + k, 0.0, kp_[g]);
        if (static_cast<int>(g) == lumbar_)
          tau_lumbar += tau * sim::vec3_at(d.xaxis + 3 * m.dof_jntid[jg.dof_begin + k]);
      }
      continue;
    }
    const Vector3d e = rotation_vector(sim::relative_orientation(m, d, jg.body).conjugate());
    const double kp = kp_[g] * gain_scale_;
    for (int k = 0; k < 3; ++k) {
      const int dof = jg.dof_begin + k;
      f->set_torque(dof, kp * e[k] - kp * params_.damping_time_s * d.qvel[dof]);
    }
  }
  return tau_lumbar;
}

LegTriangle TorqueWalker::placed_step_ik(const mjData& d, const TorqueWalkerPhase& ph) {
  // Constrained stepping (paper §4.2): the ankle goes to its target by the 2D IK triangle in the
  // heading frame's sagittal plane: above it by the clearance in the time phases (early swing),
  // onto the floor (1 cm into it, so it strikes) in the phase that ends at the strike.
  const TorqueWalkerParams& p = params_;
  TorqueWalkerState& st = state_;
  const int swing = 1 - st.stance;
  const models::RigLeg& leg = rig_->leg(swing);
  const double target = st.swing_target_m;
  const bool landing = ph.ends_at_strike;
  const Vector3d stance_ankle =
      st.heading.to_heading(sim::vec3_at(d.xpos + 3 * rig_->leg(st.stance).foot));
  const Vector3d hip = st.heading.to_heading(sim::vec3_at(d.xpos + 3 * leg.thigh));
  const double reach = kPlacedReachFraction * (leg.thigh_length_m + leg.shank_length_m);
  const auto reach_ahead = [reach](double dz) {
    return reach > std::abs(dz) ? std::sqrt(reach * reach - dz * dz) : 0.0;
  };
  double dx = stance_ankle.x() + target - hip.x();
  double lift = landing ? -0.01 : p.step_clearance_m;
  // Out of reach on the floor early in late swing: wait in the air for the hip.
  if (landing && d.time - st.phase_start_s < p.placed_wait_s &&
      dx > reach_ahead(st.ankle_height_m + lift - hip.z()))
    lift = p.step_clearance_m;
  const double dz = st.ankle_height_m + lift - hip.z();
  {
    // Outer loop on the ankle's place (the PD lags): aim short of the target by
    // placement_gain x the overshoot, and in late swing by the shortfall too.
    const Vector3d ankle = st.heading.to_heading(sim::vec3_at(d.xpos + 3 * leg.foot));
    const double overshoot = ankle.x() - (stance_ankle.x() + target);
    if (landing || overshoot > 0) dx -= p.placement_gain * overshoot;
  }
  if (landing) {
    // Out of reach on the floor (after placed_wait_s): the closest reachable point instead
    // (paper §4.2), so the foot comes down rather than waiting longer for the hip; a strike
    // while the stone is beyond reach says so.
    const double reachable = reach_ahead(dz);
    st.swing_out_of_reach = std::abs(stance_ankle.x() + target - hip.x()) > reachable;
    dx = std::clamp(dx, -reachable, reachable);
  }
  const LegTriangle ik = solve_leg_triangle(leg.thigh_length_m, leg.shank_length_m,
                                            Vector3d(dx, 0, dz), 1.0, 0.0, kMaxSwingKnee_rad);
  // The target is fixed on the floor while the hip moves: the IK angles' rates (by finite
  // difference within one phase) are the PD's velocity targets, so the leg does not lag.
  const double h = d.time - st.ik_time_s;
  if (st.ik_valid && st.ik_phase == st.phase && h > 0 &&
      h < 0.05) {  // a strike goes back to phase 0
    st.ik_pitch_rate = (ik.hip_flexion_rad - st.ik_pitch) / h;
    st.ik_knee_rate = (ik.knee_flexion_rad - st.ik_knee) / h;
  } else {
    st.ik_pitch_rate = st.ik_knee_rate = 0;
  }
  st.ik_valid = true;
  st.ik_phase = st.phase;
  st.ik_time_s = d.time;
  st.ik_pitch = ik.hip_flexion_rad;
  st.ik_knee = ik.knee_flexion_rad;
  LegTriangle tucked = ik;
  {
    // Until the swing ankle has passed the stance ankle, the knee stays at least as flexed as
    // the free gait's (the phase's swing knee): a far target's IK leg is nearly straight and
    // its toes would scuff the floor at mid-swing.
    const Vector3d ankle = st.heading.to_heading(sim::vec3_at(d.xpos + 3 * leg.foot));
    if (!landing && ankle.x() - stance_ankle.x() < p.placed_tuck_m &&
        ik.knee_flexion_rad < ph.swing_knee_rad) {
      tucked.knee_flexion_rad = ph.swing_knee_rad;
      st.ik_knee_rate = 0;
    }
  }
  return tucked;
}

double TorqueWalker::knee_weight_support(const mjModel& m, const mjData& d, int side,
                                         double share) const {
  if (params_.stance_weight_support <= 0 || share <= 0) return 0;
  const models::RigLeg& leg = rig_->leg(side);
  const std::vector<JointGroup>& groups = rig_->groups();
  const int knee = m.dof_jntid[groups[static_cast<std::size_t>(leg.knee)].dof_begin];
  const int ankle = m.dof_jntid[groups[static_cast<std::size_t>(leg.ankle)].dof_begin];
  // The knee torque that makes the foot press the floor with `share` of the supported weight:
  // tau = J' f for the ankle point, f the force the foot exerts (Coros et al. 2010's virtual
  // force, vertical). A joint torque only: the floor's reaction carries the body.
  const Vector3d f =
      share * params_.stance_weight_support * body_mass_kg_ * sim::vec3_at(m.opt.gravity);
  const Vector3d lever = sim::vec3_at(d.xanchor + 3 * ankle) - sim::vec3_at(d.xanchor + 3 * knee);
  return sim::vec3_at(d.xaxis + 3 * knee).dot(lever.cross(f));
}

void TorqueWalker::leg_joints(ControlFrame* f, const mjModel& m, const mjData& d,
                              const TorqueWalkerPhase& ph, bool placed,
                              const LegTriangle& ik) const {
  const TorqueWalkerParams& p = params_;
  const std::vector<JointGroup>& groups = rig_->groups();
  for (int s = 0; s < 2; ++s) {
    const bool stance = s == state_.stance;
    // A foot on the floor: the stance foot, and the trailing foot in a double support.
    const bool foot_down = stance || ph.swing_foot_down;
    const models::RigLeg& leg = rig_->leg(s);
    const JointGroup& knee = groups[static_cast<std::size_t>(leg.knee)];
    const JointGroup& ankle = groups[static_cast<std::size_t>(leg.ankle)];
    double swing_knee = placed ? ik.knee_flexion_rad : ph.swing_knee_rad;
    // The base-polygon rule's step back (paper §4.3) with the landing knee: the foot behind the
    // hip lands near the rule's step, not folded further back (back_step_landing_knee).
    if (p.back_step_landing_knee && !placed && base_polygon_rule_active() &&
        state_.rule_length_m < 0)
      swing_knee = std::min(swing_knee, p.phases.back().swing_knee_rad);
    const double share = !foot_down ? 0.0 : (ph.swing_foot_down ? 0.5 : 1.0);
    if (actuation_ == WalkerActuation::kVelocity) {
      hinge_target(f, d, leg.knee, stance ? ph.stance_knee_rad : swing_knee,
                   stance ? p.stance_knee_kp : p.knee_kp, foot_down);
      double dorsiflexion = stance ? ph.stance_ankle_rad : ph.swing_ankle_rad;
      if (!stance && !ph.swing_foot_down) {
        dorsiflexion =
            level_sole_dorsiflexion(state_.heading, sim::quat_at(d.xquat + 4 * leg.shank),
                                    ph.swing_ankle_rad, p.toe_up_rad);
      }
      hinge_target(f, d, leg.ankle, dorsiflexion, foot_down ? p.stance_ankle_kp : p.ankle_kp,
                   foot_down);
      if (leg.toe >= 0) hinge_target(f, d, leg.toe, 0.0, p.toe_kp, foot_down);
      continue;
    }
    hinge_pd(f, m, d, knee.dof_begin, stance ? ph.stance_knee_rad : swing_knee,
             stance ? p.stance_knee_kp : p.knee_kp, !stance && placed ? state_.ik_knee_rate : 0.0,
             knee_weight_support(m, d, s, share));
    double dorsiflexion = stance ? ph.stance_ankle_rad : ph.swing_ankle_rad;
    if (!stance && !ph.swing_foot_down) {
      dorsiflexion = level_sole_dorsiflexion(state_.heading, sim::quat_at(d.xquat + 4 * leg.shank),
                                             ph.swing_ankle_rad, p.toe_up_rad);
    }
    hinge_pd(f, m, d, ankle.dof_begin, dorsiflexion, foot_down ? p.stance_ankle_kp : p.ankle_kp);
    for (int k = 1; k < ankle.dof_count; ++k)
      hinge_pd(f, m, d, ankle.dof_begin + k, 0.0, p.ankle_kp);
    if (leg.toe >= 0)
      hinge_pd(f, m, d, groups[static_cast<std::size_t>(leg.toe)].dof_begin, 0.0, p.toe_kp);
  }
}

Vector2d TorqueWalker::swing_thigh_angles(const mjData& d, const TorqueWalkerPhase& ph, bool placed,
                                          const LegTriangle& ik, const Vector3d& rel,
                                          const Vector3d& vel) {
  const TorqueWalkerParams& p = params_;
  TorqueWalkerState& st = state_;
  const int swing = 1 - st.stance;
  const double out = swing == 0 ? 1.0 : -1.0;  // +y is outwards for the left leg
  // Stopping: the swing foot lands further ahead per m/s of forward speed (braking).
  const double brake = st.stopping ? p.stop_brake_rad_per_m_s * vel.x() : 0.0;
  double pitch = placed
                     ? ik.hip_flexion_rad
                     : brake + ph.swing_hip_rad + p.sagittal_cd * rel.x() + p.sagittal_cv * vel.x();
  // The roll outwards is bounded (max_swing_roll_rad) for the balance feedback and the
  // base-polygon rule, not for a width the plan or the stop sets.
  const auto bounded = [&p, out](double r) {
    return out > 0 ? std::min(r, p.max_swing_roll_rad) : std::max(r, -p.max_swing_roll_rad);
  };
  double roll = bounded(out * p.swing_hip_out_rad + p.frontal_cd * rel.y() +
                        p.frontal_cv * vel.y() + st.roll_integral);
  // The thigh angle that puts the nearly straight leg's ankle `offset` (m, heading frame) from
  // the hip, along or across the heading.
  const models::RigLeg& leg = rig_->leg(swing);
  const double leg_length = kPlacedReachFraction * (leg.thigh_length_m + leg.shank_length_m);
  const auto straight_leg_angle = [leg_length](double offset) {
    return std::asin(std::clamp(offset / leg_length, -0.9, 0.9));
  };
  const bool rule_moves =
      !placed && (!std::isnan(st.rule_length_m) || !std::isnan(st.rule_width_m));
  const Vector3d hip = st.heading.to_heading(Vector3d(
      sim::vec3_at(d.xpos + 3 * leg.thigh) - sim::vec3_at(d.xpos + 3 * rig_->leg(st.stance).foot)));
  if (placed && !std::isnan(st.swing_width_m)) {
    // A planned width: the thigh rolled so that the leg below the hip puts the ankle that far
    // across from the stance ankle (in late swing aiming past it by placement_gain x the miss).
    const Vector3d ankle =
        st.heading.to_heading(Vector3d(sim::vec3_at(d.xpos + 3 * leg.foot) -
                                       sim::vec3_at(d.xpos + 3 * rig_->leg(st.stance).foot)));
    double across = out * st.swing_width_m;
    if (ph.ends_at_strike) across -= p.placement_gain * (ankle.y() - across);
    roll = std::atan2(across - hip.y(), std::max(hip.z(), 0.3));
  }
  if (placed && closing_step()) {
    // The closing step of a stop puts the feet side by side at the standing width (the hips'
    // spacing), where the standing controller's pose expects them; the balance feedback's
    // width is narrower (measured: 6 cm, and the standing character fell sideways).
    roll = straight_leg_angle(out * rig_->hip_spacing_m() - hip.y());
  }
  if (rule_moves) {
    // The base-polygon rule's step (paper §4.3): the thigh pitched (rolled) at least so far that
    // the leg, nearly straight, puts the ankle at the rule's length (width) from the stance
    // ankle, from where the hip is now.
    if (!std::isnan(st.rule_length_m)) {
      const double pitch_rule = straight_leg_angle(st.rule_length_m - hip.x());
      const double bound =
          st.rule_length_m > 0 ? std::max(pitch, pitch_rule) : std::min(pitch, pitch_rule);
      if (bound != pitch) st.rule_bound = true;
      pitch = bound;
    }
    if (!std::isnan(st.rule_width_m)) {
      const double roll_rule = bounded(straight_leg_angle(out * st.rule_width_m - hip.y()));
      const double bound = out > 0 ? std::max(roll, roll_rule) : std::min(roll, roll_rule);
      if (bound != roll) st.rule_bound = true;
      roll = bound;
    }
  }
  return {pitch, roll};
}

void TorqueWalker::apply_base_polygon_rule(const mjModel& m, const mjData& d, const Vector3d& com_W,
                                           const Vector3d& com_velocity_H) {
  const TorqueWalkerParams& p = params_;
  TorqueWalkerState& st = state_;
  polygons_.update(m, d, *rig_, p.tolerance_fraction);
  st.support = polygons_.support();
  st.tolerance = polygons_.tolerance();
  const int stance_foot = rig_->leg(st.stance).foot;
  const Vector2d ankle(d.xpos[3 * stance_foot], d.xpos[3 * stance_foot + 1]);
  const models::Sole& sole = rig_->leg(models::kLeft).sole;
  // back_step_capture_point: omega0 from the CoM's height above the floor under the stance foot.
  double omega0 = 0;
  if (p.back_step_capture_point) {
    const double floor_z = d.xpos[3 * stance_foot + 2] - st.ankle_height_m;
    omega0 = std::sqrt(-m.opt.gravity[2] / std::max(com_W.z() - floor_z, 0.3));
  }
  const BasePolygonStep step =
      base_polygon_rule(st.support, st.tolerance, p.tolerance_fraction, com_W, com_velocity_H,
                        ankle, st.heading, 1 - st.stance, sole.length_m(), sole.width_m(), omega0);
  if (!std::isnan(step.length_m)) {
    if (step.length_m > 0) {
      st.rule_length_m =
          std::isnan(st.rule_length_m) ? step.length_m : std::max(st.rule_length_m, step.length_m);
    } else {
      st.rule_length_m =
          std::isnan(st.rule_length_m) ? step.length_m : std::min(st.rule_length_m, step.length_m);
    }
  }
  if (!std::isnan(step.width_m))
    st.rule_width_m =
        std::isnan(st.rule_width_m) ? step.width_m : std::max(st.rule_width_m, step.width_m);
}

}  // namespace biodyn::controllers
