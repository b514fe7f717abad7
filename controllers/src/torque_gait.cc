#include "biodyn/controllers/torque_gait.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>

#include "biodyn/controllers/foot_contact.h"
#include "biodyn/controllers/gait_controller.h"
#include "biodyn/controllers/support_polygon.h"
#include "biodyn/sim/errors.h"
#include "json_fields.h"
#include "biodyn/sim/queries.h"

namespace biodyn::controllers {
namespace {

using Eigen::AngleAxisd;
using Eigen::Quaterniond;
using Eigen::Vector3d;

constexpr double kReferenceMass_kg = 80.0;
constexpr double kMaxSwingKnee_rad = 2.0;
// A placed step leaves early swing once its ankle is this close behind the target, m.
constexpr double kPlacedLandingReach_m = 0.02;
// The longest leg a placed step lands with, as a fraction of thigh + shank.
constexpr double kPlacedReachFraction = 0.97;  // the IK's most flexed knee (the joint allows 2.36)
const char* const kSide[2] = {"_l", "_r"};

Vector3d vec_at(const mjtNum* p) { return {p[0], p[1], p[2]}; }
Quaterniond quat_at(const mjtNum* q) { return {q[0], q[1], q[2], q[3]}; }

int require_body(const mjModel& m, const std::string& name) {
  const int id = mj_name2id(&m, mjOBJ_BODY, name.c_str());
  if (id < 0) throw sim::InvalidArgument("torque gait: the model has no body '" + name + "'");
  return id;
}

int require_group(const std::vector<JointGroup>& groups, const std::string& name) {
  const int g = find_group(groups, name);
  if (g < 0) throw sim::InvalidArgument("torque gait: the model has no joint group '" + name + "'");
  return g;
}

using json_fields::check;

// Every parameter by its JSON name (the member's name).
struct NamedField {
  const char* name;
  double TorqueGaitParams::*member;
};
#define BIODYN_FIELD(n) NamedField{#n, &TorqueGaitParams::n}
constexpr NamedField kFields[] = {
    BIODYN_FIELD(sagittal_cd),         BIODYN_FIELD(sagittal_cv),          BIODYN_FIELD(frontal_cd),
    BIODYN_FIELD(frontal_cv),          BIODYN_FIELD(swing_hip_out_rad),
    BIODYN_FIELD(toe_up_rad),          BIODYN_FIELD(pelvis_pitch_rad),
    BIODYN_FIELD(start_pitch_rad),     BIODYN_FIELD(start_time_s),         BIODYN_FIELD(torso_kp),
    BIODYN_FIELD(hip_kp),              BIODYN_FIELD(knee_kp),              BIODYN_FIELD(ankle_kp),
    BIODYN_FIELD(toe_kp),              BIODYN_FIELD(trunk_kp),             BIODYN_FIELD(arm_kp),
    BIODYN_FIELD(distal_kp),           BIODYN_FIELD(damping_time_s),       BIODYN_FIELD(reference_speed_m_s),
    BIODYN_FIELD(speed_lean_rad_per_m_s), BIODYN_FIELD(speed_integral_rad_per_m), BIODYN_FIELD(speed_lean_limit_rad),
    BIODYN_FIELD(lateral_integral_rad_per_m), BIODYN_FIELD(step_clearance_m), BIODYN_FIELD(placement_gain), BIODYN_FIELD(placed_wait_s),
    BIODYN_FIELD(stop_brake_rad_per_m_s), BIODYN_FIELD(stop_speed_m_s), BIODYN_FIELD(tolerance_fraction)};
#undef BIODYN_FIELD

// A state's numbers by their JSON names.
struct StateField {
  const char* name;
  double TorqueGaitState::*member;
};
#define BIODYN_STATE_FIELD(n) StateField{#n, &TorqueGaitState::n}
constexpr StateField kStateFields[] = {BIODYN_STATE_FIELD(duration_s),      BIODYN_STATE_FIELD(duration_per_m_s),
                                       BIODYN_STATE_FIELD(swing_hip_rad),   BIODYN_STATE_FIELD(swing_knee_rad),
                                       BIODYN_STATE_FIELD(swing_ankle_rad), BIODYN_STATE_FIELD(stance_knee_rad),
                                       BIODYN_STATE_FIELD(stance_ankle_rad)};
#undef BIODYN_STATE_FIELD

constexpr std::size_t kMaxStates = 16;

TorqueGaitState read_state(const nlohmann::json& j, const std::string& where) {
  TorqueGaitState st;
  st.name.clear();
  std::map<std::string, std::function<void(const nlohmann::json&, const std::string&)>> keys;
  for (const StateField& f : kStateFields)
    keys[f.name] = [&st, f](const nlohmann::json& v, const std::string& w) { st.*(f.member) = json_fields::read_number(v, w); };
  keys["name"] = [&st](const nlohmann::json& v, const std::string& w) {
    if (!v.is_string()) json_fields::fail(w, "must be a string", v.dump());
    st.name = v.get<std::string>();
  };
  keys["end"] = [&st](const nlohmann::json& v, const std::string& w) {
    if (!v.is_string() || (v != "time" && v != "strike")) json_fields::fail(w, "must be \"time\" or \"strike\"", v.dump());
    st.ends_at_strike = v == "strike";
  };
  keys["swing_foot_down"] = [&st](const nlohmann::json& v, const std::string& w) { st.swing_foot_down = json_fields::boolean(v, w); };
  json_fields::read_object(j, where, keys);
  return st;
}

}  // namespace

std::vector<TorqueGaitState> default_torque_gait_states() {
  // SIMBICON's two states per step; the numbers from the cross-entropy search (README).
  TorqueGaitState early;
  early.name = "early swing";
  early.duration_s = 0.471;
  early.duration_per_m_s = 0.011;
  early.swing_hip_rad = 0.698;
  early.swing_knee_rad = 1.323;
  early.swing_ankle_rad = -0.019;
  early.stance_knee_rad = 0.207;
  early.stance_ankle_rad = -0.047;
  TorqueGaitState late = early;
  late.name = "late swing";
  late.ends_at_strike = true;
  late.duration_s = 0.3;  // not used: the state ends at the strike
  late.duration_per_m_s = 0;
  late.swing_hip_rad = 0.095;
  late.swing_knee_rad = 0.186;
  late.swing_ankle_rad = 0;
  return {early, late};
}

void apply_torque_gait_json(const std::string& json_text, const std::string& source, TorqueGaitParams* params) {
  nlohmann::json root;
  try {
    root = nlohmann::json::parse(json_text);
  } catch (const nlohmann::json::parse_error& e) {
    throw sim::InvalidArgument(source + ": not valid JSON (" + std::string(e.what()) + ")");
  }
  TorqueGaitParams p = *params;
  std::map<std::string, std::function<void(const nlohmann::json&, const std::string&)>> keys;
  for (const NamedField& f : kFields) {
    keys[f.name] = [&p, f](const nlohmann::json& v, const std::string& w) { p.*(f.member) = json_fields::read_number(v, w); };
  }
  keys["base_polygon_rule"] = [&p](const nlohmann::json& v, const std::string& w) { p.base_polygon_rule = json_fields::boolean(v, w); };
  keys["states"] = [&p](const nlohmann::json& v, const std::string& w) {
    if (!v.is_array()) json_fields::fail(w, "must be an array of states", v.dump());
    p.states.clear();
    for (std::size_t i = 0; i < v.size(); ++i) p.states.push_back(read_state(v[i], w + "[" + std::to_string(i) + "]"));
  };
  json_fields::read_object(root, source, keys);
  try {
    p.validate();
  } catch (const sim::InvalidArgument& e) {
    throw sim::InvalidArgument(source + ": " + e.what());
  }
  *params = p;
}

std::string torque_gait_json(const TorqueGaitParams& params) {
  nlohmann::ordered_json j;
  nlohmann::ordered_json states = nlohmann::ordered_json::array();
  for (const TorqueGaitState& st : params.states) {
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
  return j.dump(2) + "\n";
}

void TorqueGaitParams::validate() const {
  const std::string w = "torque gait.";
  if (states.empty()) json_fields::fail(w + "states", "needs at least one state", "none");
  if (states.size() > kMaxStates)
    json_fields::fail(w + "states", "has at most " + std::to_string(kMaxStates) + " states", std::to_string(states.size()));
  for (std::size_t i = 0; i < states.size(); ++i) {
    const TorqueGaitState& st = states[i];
    const std::string ws = w + "states[" + std::to_string(i) + "]";
    if (st.name.empty()) json_fields::fail(ws + ".name", "must be a non-empty string", "\"\"");
    for (std::size_t k = 0; k < i; ++k)
      if (states[k].name == st.name) json_fields::fail(ws + ".name", "must differ from the other states' names", "\"" + st.name + "\"");
    const bool last = i + 1 == states.size();
    if (st.ends_at_strike != last)
      json_fields::fail(ws + ".end", last ? "the last state of a step must end at the strike" : "only the last state ends at the strike",
                        st.ends_at_strike ? "\"strike\"" : "\"time\"");
    if (last && st.swing_foot_down)
      json_fields::fail(ws + ".swing_foot_down", "the state that ends at the strike must lift the swing foot", "true");
    check(st.duration_s > 0.05 && st.duration_s <= 2, ws + ".duration_s", "must be in (0.05, 2] s", st.duration_s);
    check(st.duration_per_m_s >= 0 && st.duration_per_m_s <= 1, ws + ".duration_per_m_s", "must be in [0, 1] s per m/s",
          st.duration_per_m_s);
    for (const StateField& f : kStateFields) {
      const std::string n = f.name;
      if (n.size() > 4 && n.compare(n.size() - 4, 4, "_rad") == 0)
        check(std::abs(st.*(f.member)) <= M_PI, ws + "." + n, "must be within +-pi rad", st.*(f.member));
    }
  }
  check(start_time_s >= 0 && start_time_s <= 10, w + "start_time_s", "must be in [0, 10] s", start_time_s);
  check(damping_time_s >= 0 && damping_time_s <= 1, w + "damping_time_s", "must be in [0, 1] s", damping_time_s);
  const std::pair<const char*, double> angles[] = {{"swing_hip_out_rad", swing_hip_out_rad},
                                                   {"toe_up_rad", toe_up_rad},
                                                   {"pelvis_pitch_rad", pelvis_pitch_rad},
                                                   {"start_pitch_rad", start_pitch_rad}};
  for (const auto& [name, a] : angles) check(std::abs(a) <= M_PI, w + name, "must be within +-pi rad", a);
  const std::pair<const char*, double> gains[] = {{"torso_kp", torso_kp}, {"hip_kp", hip_kp},
                                                  {"knee_kp", knee_kp},   {"ankle_kp", ankle_kp},
                                                  {"toe_kp", toe_kp},     {"trunk_kp", trunk_kp},
                                                  {"arm_kp", arm_kp},     {"distal_kp", distal_kp}};
  for (const auto& [name, k] : gains) check(k >= 0 && k <= 1e5, w + name, "must be in [0, 1e5] N m/rad", k);
  const std::pair<const char*, double> feedback[] = {{"sagittal_cd", sagittal_cd}, {"sagittal_cv", sagittal_cv},
                                                     {"frontal_cd", frontal_cd},   {"frontal_cv", frontal_cv}};
  for (const auto& [name, c] : feedback) check(std::abs(c) <= 10, w + name, "must be within +-10", c);
  check(reference_speed_m_s > 0 && reference_speed_m_s <= 3, w + "reference_speed_m_s", "must be in (0, 3] m/s",
        reference_speed_m_s);
  check(std::abs(speed_lean_rad_per_m_s) <= 1, w + "speed_lean_rad_per_m_s", "must be within +-1", speed_lean_rad_per_m_s);
  check(speed_integral_rad_per_m >= 0 && speed_integral_rad_per_m <= 2, w + "speed_integral_rad_per_m",
        "must be in [0, 2]", speed_integral_rad_per_m);
  check(lateral_integral_rad_per_m >= 0 && lateral_integral_rad_per_m <= 2, w + "lateral_integral_rad_per_m",
        "must be in [0, 2]", lateral_integral_rad_per_m);
  check(step_clearance_m >= 0 && step_clearance_m <= 0.5, w + "step_clearance_m", "must be in [0, 0.5] m",
        step_clearance_m);
  check(std::abs(stop_brake_rad_per_m_s) <= 2, w + "stop_brake_rad_per_m_s", "must be within +-2",
        stop_brake_rad_per_m_s);
  check(stop_speed_m_s > 0 && stop_speed_m_s <= 1, w + "stop_speed_m_s", "must be in (0, 1] m/s", stop_speed_m_s);
  check(tolerance_fraction > 0 && tolerance_fraction <= 0.5, w + "tolerance_fraction", "must be in (0, 0.5]",
        tolerance_fraction);
  check(placement_gain >= 0 && placement_gain <= 10, w + "placement_gain", "must be in [0, 10]", placement_gain);
  check(placed_wait_s >= 0 && placed_wait_s <= 0.5, w + "placed_wait_s", "must be in [0, 0.5] s", placed_wait_s);
  check(speed_lean_limit_rad >= 0 && speed_lean_limit_rad <= 0.5, w + "speed_lean_limit_rad", "must be in [0, 0.5] rad",
        speed_lean_limit_rad);
}

void TorqueGait::set_params(const TorqueGaitParams& params) {
  params.validate();
  params_ = params;
  const int last = static_cast<int>(params_.states.size()) - 1;
  state_ = std::min(state_, last);
}

TorqueGait::TorqueGait(const mjModel& m, const std::vector<JointGroup>& groups, TorqueGaitParams params)
    : params_(params), groups_(groups) {
  params_.validate();
  pelvis_ = require_body(m, "pelvis");
  floor_geom_ = mj_name2id(&m, mjOBJ_GEOM, "floor");
  for (int s = 0; s < 2; ++s) {
    thigh_[s] = require_body(m, std::string("thigh") + kSide[s]);
    shank_[s] = require_body(m, std::string("shank") + kSide[s]);
    foot_[s] = require_body(m, std::string("foot") + kSide[s]);
    toes_[s] = mj_name2id(&m, mjOBJ_BODY, (std::string("toes") + kSide[s]).c_str());
    hip_[s] = require_group(groups_, std::string("hip") + kSide[s]);
    knee_[s] = require_group(groups_, std::string("knee") + kSide[s]);
    ankle_[s] = require_group(groups_, std::string("ankle") + kSide[s]);
    toe_[s] = find_group(groups_, std::string("toe") + kSide[s]);
  }
  lumbar_ = require_group(groups_, "lumbar");
  plan_.reserve(8);  // the stop plan is made inside drive(): no allocation there
  contacts_.reserve(64);  // the base-polygon rule's buffers, filled inside drive()
  points_.reserve(64);
  hull_.reserve(128);
  tolerance_.reserve(128);
  hip_spacing_ = std::abs(m.body_pos[3 * thigh_[0] + 1] - m.body_pos[3 * thigh_[1] + 1]);
  const Sole sole = find_sole(m, foot_[0]);
  foot_length_ = sole.x_max - sole.x_min;
  foot_width_ = sole.y_max - sole.y_min;
  for (int s = 0; s < 2; ++s) {
    thigh_length_[s] = vec_at(m.body_pos + 3 * shank_[s]).norm();  // hip to knee
    shank_length_[s] = vec_at(m.body_pos + 3 * foot_[s]).norm();   // knee to ankle
  }
  double mass = 0;
  for (int b = 1; b < m.nbody; ++b) mass += m.body_mass[b];
  gain_scale_ = mass / kReferenceMass_kg;
  // Non-leg groups hold the standing pose (zero angles) by PD.
  kp_.assign(groups_.size(), 0.0);
  leg_.assign(groups_.size(), false);
  for (int s = 0; s < 2; ++s)
    for (int g : {hip_[s], knee_[s], ankle_[s], toe_[s]})
      if (g >= 0) leg_[static_cast<std::size_t>(g)] = true;
  for (std::size_t g = 0; g < groups_.size(); ++g) {
    const std::string& n = groups_[g].name;
    const auto starts = [&](const char* p) { return n.rfind(p, 0) == 0; };
    if (starts("lumbar") || starts("thorax")) kp_[g] = params_.trunk_kp;
    else if (starts("shoulder") || starts("clavicle")) kp_[g] = params_.arm_kp;
    else kp_[g] = params_.distal_kp;
  }
}

void TorqueGait::reset(const mjData& d) {
  stance_ = 0;
  strikes_ = 0;
  // From standing the first step starts with its first state that lifts the swing foot (a
  // double support's push-off has nothing to push off from yet).
  state_ = 0;
  while (params_.states[static_cast<std::size_t>(state_)].swing_foot_down) ++state_;
  lifted_ = false;
  ik_valid_ = false;
  state_start_s_ = start_s_ = last_time_s_ = d.time;
  const Vector3d forward = quat_at(d.xquat + 4 * pelvis_) * Vector3d::UnitX();
  heading_ = std::atan2(forward.y(), forward.x());
  last_strike_ = TorqueGaitStrike{};
  lean_integral_ = roll_integral_ = 0;
  com_at_strike_ = Vector3d::Zero();
  // Ankle height above the floor with the sole flat (the character starts standing).
  ankle_height_ = std::min(d.xpos[3 * foot_[0] + 2], d.xpos[3 * foot_[1] + 2]);
  plan_.clear();
  plan_next_ = 0;
  swing_target_ = std::numeric_limits<double>::quiet_NaN();
  rule_length_ = rule_width_ = std::numeric_limits<double>::quiet_NaN();
  rule_steps_ = 0;
  rule_bound_ = false;
  hull_.clear();
  tolerance_.clear();
  stopping_ = stopped_ = false;
}

void TorqueGait::request_stop() {
  if (stopping_) return;
  stopping_ = true;  // braking first: see drive()
  speed_ = 0;
}

void TorqueGait::validate_plan(const std::vector<double>& lengths_m) {
  for (std::size_t i = 0; i < lengths_m.size(); ++i)
    check(lengths_m[i] >= 0 && lengths_m[i] <= 1.5, "planned step " + std::to_string(i + 1), "must be in [0, 1.5] m",
          lengths_m[i]);
}

void TorqueGait::plan_steps(const std::vector<double>& lengths_m) {
  validate_plan(lengths_m);
  plan_ = lengths_m;
  plan_next_ = 0;
}

double TorqueGait::speed_lean_rad() const {
  const TorqueGaitParams& p = params_;
  return std::clamp(p.speed_lean_rad_per_m_s * (speed_ - p.reference_speed_m_s) + lean_integral_,
                    -p.speed_lean_limit_rad, p.speed_lean_limit_rad);
}

double TorqueGait::state_duration_s(int state) const {
  const TorqueGaitState& st = params_.states[static_cast<std::size_t>(state)];
  return std::max(st.duration_s - st.duration_per_m_s * (speed_ - params_.reference_speed_m_s), 0.05);
}

double TorqueGait::hinge_pd(CharacterController& c, const mjModel& m, const mjData& d, int dof, double target,
                            double kp, double target_rate) const {
  const double k = kp * gain_scale_;
  const double tau = k * (target - d.qpos[m.jnt_qposadr[m.dof_jntid[dof]]]) +
                     k * params_.damping_time_s * (target_rate - d.qvel[dof]);
  c.limit_torque_once(dof, tau, tau);
  return tau;
}

void TorqueGait::hip_torque(CharacterController& c, const mjData& d, int side, const Vector3d& torque_W) const {
  // Ball-joint DOFs act in the child's (thigh's) frame.
  const Vector3d t_B = quat_at(d.xquat + 4 * thigh_[side]).conjugate() * torque_W;
  const int dof = groups_[static_cast<std::size_t>(hip_[side])].dof_begin;
  for (int k = 0; k < 3; ++k) c.limit_torque_once(dof + k, t_B[k], t_B[k]);
}

void TorqueGait::drive(CharacterController& c, const mjModel& m, const mjData& d) {
  const TorqueGaitParams& p = params_;
  heading_ += heading_rate_ * std::max(d.time - last_time_s_, 0.0);
  last_time_s_ = d.time;
  const sim::CenterOfMass com = sim::center_of_mass(m, d);  // for the speed regulation and placement
  // State machine (params.states): time states in order, then the last state until the swing
  // foot touches the floor after having left it.
  int swing = 1 - stance_;
  const bool touches = sim::foot_touches_floor(m, d, floor_geom_, foot_[swing], toes_[swing]);
  if (!touches) lifted_ = true;
  if (!p.states[static_cast<std::size_t>(state_)].ends_at_strike) {
    bool done = d.time - state_start_s_ >= state_duration_s(state_);
    // (Not the closing step of a stop: it starts beside its target and needs the time to
    // move the foot out to the standing width.)
    if (!done && !closing_step() && !std::isnan(swing_target_) && !p.states[static_cast<std::size_t>(state_)].swing_foot_down) {
      // A placed step comes down as soon as its ankle is over the target (a short step would
      // otherwise be overtaken by the hip).
      const double ch = std::cos(heading_), sh = std::sin(heading_);
      const Vector3d delta = vec_at(d.xpos + 3 * foot_[swing]) - vec_at(d.xpos + 3 * foot_[stance_]);
      done = ch * delta.x() + sh * delta.y() >= swing_target_ - kPlacedLandingReach_m;
    }
    if (done) {
      ++state_;
      state_start_s_ = d.time;
    }
  }
  if (!stopped_ && p.states[static_cast<std::size_t>(state_)].ends_at_strike && touches && lifted_) {
    const Vector3d delta = vec_at(d.xpos + 3 * foot_[swing]) - vec_at(d.xpos + 3 * foot_[stance_]);
    const double ch = std::cos(heading_), sh = std::sin(heading_);
    // Speed regulation: the step's mean CoM speed along the heading against the command
    // (not during the start from standing, and not before there was a step).
    const Vector3d& com_now = com.position_W;
    // Planned steps and steps the base-polygon rule moved are not the gait's own.
    if (strikes_ > 0 && d.time - start_s_ >= p.start_time_s && std::isnan(swing_target_) && !base_polygon_rule_active()) {
      const double t_step = d.time - last_strike_.time_s;
      const double v_step = (ch * (com_now.x() - com_at_strike_.x()) + sh * (com_now.y() - com_at_strike_.y())) /
                            std::max(t_step, 1e-3);
      const double limit = p.speed_lean_limit_rad;
      lean_integral_ = std::clamp(lean_integral_ + p.speed_integral_rad_per_m * (speed_ - v_step) * t_step, -limit, limit);
      const double sideways = -sh * (com_now.x() - com_at_strike_.x()) + ch * (com_now.y() - com_at_strike_.y());
      roll_integral_ = std::clamp(roll_integral_ + p.lateral_integral_rad_per_m * sideways, -limit, limit);
    }
    com_at_strike_ = com_now;
    last_strike_ = {d.time, swing, ch * delta.x() + sh * delta.y(), std::abs(-sh * delta.x() + ch * delta.y()),
                    swing_target_};
    swing_target_ = plan_next_ < static_cast<int>(plan_.size()) ? plan_[static_cast<std::size_t>(plan_next_++)]
                                                                 : std::numeric_limits<double>::quiet_NaN();
    ++strikes_;
    if (base_polygon_rule_active()) ++rule_steps_;
    rule_length_ = rule_width_ = std::numeric_limits<double>::quiet_NaN();
    rule_bound_ = false;
    if (stopping_) {
      if (!std::isnan(last_strike_.target_length_m) && last_strike_.target_length_m == 0.0) {
        stopped_ = true;  // the feet are side by side: no more steps
      } else if (std::isnan(swing_target_) && plan_next_ >= static_cast<int>(plan_.size())) {
        // Braking until the CoM is slow, then one step that brings the feet side by side.
        const double v = ch * com.velocity_W.x() + sh * com.velocity_W.y();
        if (v < p.stop_speed_m_s) {
          plan_.assign(1, 0.0);
          plan_next_ = 0;
          swing_target_ = plan_[static_cast<std::size_t>(plan_next_++)];
        }
      }
    }
    stance_ = swing;
    swing = 1 - stance_;
    state_ = 0;
    lifted_ = false;
    state_start_s_ = d.time;
  }
  const TorqueGaitState& st = p.states[static_cast<std::size_t>(state_)];
  c.set_stance(stance_, true);
  c.set_stance(swing, st.swing_foot_down);

  // Everything but the legs holds the standing pose. The lumbar's torque on the pelvis is
  // minus its torque on the upper body (about its hinge axes): the stance hip takes it below.
  Vector3d tau_lumbar = Vector3d::Zero();
  for (std::size_t g = 0; g < groups_.size(); ++g) {
    const JointGroup& jg = groups_[g];
    if (leg_[g]) continue;
    if (!jg.ball) {
      for (int k = 0; k < jg.dof_count; ++k) {
        const double tau = hinge_pd(c, m, d, jg.dof_begin + k, 0.0, kp_[g]);
        if (static_cast<int>(g) == lumbar_) tau_lumbar += tau * vec_at(d.xaxis + 3 * m.dof_jntid[jg.dof_begin + k]);
      }
      continue;
    }
    const Vector3d e = rotation_vector(sim::relative_orientation(m, d, jg.body).conjugate());
    const double kp = kp_[g] * gain_scale_;
    for (int k = 0; k < 3; ++k) {
      const int dof = jg.dof_begin + k;
      const double tau = kp * e[k] - kp * p.damping_time_s * d.qvel[dof];
      c.limit_torque_once(dof, tau, tau);
    }
  }

  const Quaterniond q_heading(AngleAxisd(heading_, Vector3d::UnitZ()));
  // The balance feedback's inputs (SIMBICON): CoM relative to the stance ankle, and its
  // velocity, in the heading frame.
  const Vector3d rel = q_heading.conjugate() * (com.position_W - vec_at(d.xpos + 3 * foot_[stance_]));
  const Vector3d vel = q_heading.conjugate() * com.velocity_W;
  const double out = swing == 0 ? 1.0 : -1.0;  // +y is outwards for the left leg
  // Stopping: the swing foot lands further ahead per m/s of forward speed (braking).
  const double brake = stopping_ ? p.stop_brake_rad_per_m_s * vel.x() : 0.0;
  const double free_roll = out * p.swing_hip_out_rad + p.frontal_cd * rel.y() + p.frontal_cv * vel.y() + roll_integral_;
  if (p.base_polygon_rule && !stopped_ && !st.swing_foot_down && std::isnan(swing_target_))
    apply_base_polygon_rule(m, d, com.position_W, vel);
  // Constrained stepping (paper §4.2): the ankle goes to its target by the 2D IK triangle in the
  // heading frame's sagittal plane: above it by the clearance in the time states (early swing),
  // onto the floor (1 cm into it, so it strikes) in the state that ends at the strike.
  const double target = swing_target_;
  const bool placed = !std::isnan(target) && !st.swing_foot_down;
  const bool landing = st.ends_at_strike;
  LegTriangle ik;
  if (placed) {
    const Vector3d stance_ankle = q_heading.conjugate() * vec_at(d.xpos + 3 * foot_[stance_]);
    const Vector3d hip = q_heading.conjugate() * vec_at(d.xpos + 3 * thigh_[swing]);
    const double reach = kPlacedReachFraction * (thigh_length_[swing] + shank_length_[swing]);
    const auto reach_ahead = [reach](double dz) { return reach > std::abs(dz) ? std::sqrt(reach * reach - dz * dz) : 0.0; };
    double dx = stance_ankle.x() + target - hip.x();
    double lift = landing ? -0.01 : p.step_clearance_m;
    // Out of reach on the floor early in late swing: wait in the air for the hip.
    if (landing && d.time - state_start_s_ < p.placed_wait_s && dx > reach_ahead(ankle_height_ + lift - hip.z()))
      lift = p.step_clearance_m;
    const double dz = ankle_height_ + lift - hip.z();
    {
      // Outer loop on the ankle's place (the PD lags): aim short of the target by
      // placement_gain x the overshoot, and in late swing by the shortfall too.
      const Vector3d ankle = q_heading.conjugate() * vec_at(d.xpos + 3 * foot_[swing]);
      const double overshoot = ankle.x() - (stance_ankle.x() + target);
      if (landing || overshoot > 0) dx -= p.placement_gain * overshoot;
    }
    if (landing) {
      // Out of reach on the floor (after placed_wait_s): the closest reachable point instead
      // (paper §4.2), so the foot comes down rather than waiting longer for the hip.
      dx = std::clamp(dx, -reach_ahead(dz), reach_ahead(dz));
    }
    ik = solve_leg_triangle(thigh_length_[swing], shank_length_[swing], Vector3d(dx, 0, dz), 1.0, 0.0,
                            kMaxSwingKnee_rad);
    // The target is fixed on the floor while the hip moves: the IK angles' rates (by finite
    // difference within one state) are the PD's velocity targets, so the leg does not lag.
    const double h = d.time - ik_time_s_;
    if (ik_valid_ && ik_state_ == state_ && h > 0 && h < 0.05) {  // a strike goes back to state 0
      ik_pitch_rate_ = (ik.hip_flexion_rad - ik_pitch_) / h;
      ik_knee_rate_ = (ik.knee_flexion_rad - ik_knee_) / h;
    } else {
      ik_pitch_rate_ = ik_knee_rate_ = 0;
    }
    ik_valid_ = true;
    ik_state_ = state_;
    ik_time_s_ = d.time;
    ik_pitch_ = ik.hip_flexion_rad;
    ik_knee_ = ik.knee_flexion_rad;
  } else {
    ik_valid_ = false;
  }

  // Knees, ankles, toes.
  for (int s = 0; s < 2; ++s) {
    const bool stance = s == stance_;
    const JointGroup& knee = groups_[static_cast<std::size_t>(knee_[s])];
    const JointGroup& ankle = groups_[static_cast<std::size_t>(ankle_[s])];
    const double swing_knee = placed ? ik.knee_flexion_rad : st.swing_knee_rad;
    hinge_pd(c, m, d, knee.dof_begin, stance ? st.stance_knee_rad : swing_knee, p.knee_kp,
             !stance && placed ? ik_knee_rate_ : 0.0);
    double dorsiflexion = stance ? st.stance_ankle_rad : st.swing_ankle_rad;
    if (!stance && !st.swing_foot_down) {
      // The sole level in the heading frame (toes up by toe_up): the shank's pitch undone.
      // Pitch about the heading frame's +y (toes down positive); dorsiflexion turns the foot
      // about -y, so the foot's pitch is shank_pitch - dorsiflexion.
      const Vector3d shank_x = q_heading.conjugate() * (quat_at(d.xquat + 4 * shank_[s]) * Vector3d::UnitX());
      const double shank_pitch = std::atan2(-shank_x.z(), shank_x.x());
      dorsiflexion = st.swing_ankle_rad + shank_pitch + p.toe_up_rad;
    }
    hinge_pd(c, m, d, ankle.dof_begin, dorsiflexion, p.ankle_kp);
    for (int k = 1; k < ankle.dof_count; ++k) hinge_pd(c, m, d, ankle.dof_begin + k, 0.0, p.ankle_kp);
    if (toe_[s] >= 0) hinge_pd(c, m, d, groups_[static_cast<std::size_t>(toe_[s])].dof_begin, 0.0, p.toe_kp);
  }

  // Swing thigh in the heading frame, placed by the balance feedback (SIMBICON), or by the IK.
  double pitch = placed ? ik.hip_flexion_rad
                        : brake + st.swing_hip_rad + p.sagittal_cd * rel.x() + p.sagittal_cv * vel.x();
  double roll = free_roll;
  // The thigh angle that puts the nearly straight leg's ankle `offset` (m, heading frame) from
  // the hip, along or across the heading.
  const double leg = kPlacedReachFraction * (thigh_length_[swing] + shank_length_[swing]);
  const auto straight_leg_angle = [leg](double offset) { return std::asin(std::clamp(offset / leg, -0.9, 0.9)); };
  const bool rule_moves = !placed && (!std::isnan(rule_length_) || !std::isnan(rule_width_));
  const Vector3d hip = q_heading.conjugate() * (vec_at(d.xpos + 3 * thigh_[swing]) - vec_at(d.xpos + 3 * foot_[stance_]));
  if (placed && closing_step()) {
    // The closing step of a stop puts the feet side by side at the standing width (the hips'
    // spacing), where the standing controller's pose expects them; the balance feedback's
    // width is narrower (measured: 6 cm, and the standing character fell sideways).
    roll = straight_leg_angle(out * hip_spacing_ - hip.y());
  }
  if (rule_moves) {
    // The base-polygon rule's step (paper §4.3): the thigh pitched (rolled) at least so far that
    // the leg, nearly straight, puts the ankle at the rule's length (width) from the stance
    // ankle, from where the hip is now.
    if (!std::isnan(rule_length_)) {
      const double pitch_rule = straight_leg_angle(rule_length_ - hip.x());
      const double bound = rule_length_ > 0 ? std::max(pitch, pitch_rule) : std::min(pitch, pitch_rule);
      if (bound != pitch) rule_bound_ = true;
      pitch = bound;
    }
    if (!std::isnan(rule_width_)) {
      const double roll_rule = straight_leg_angle(out * rule_width_ - hip.y());
      const double bound = out > 0 ? std::max(roll, roll_rule) : std::min(roll, roll_rule);
      if (bound != roll) rule_bound_ = true;
      roll = bound;
    }
  }
  const Quaterniond q_thigh_goal =
      q_heading * Quaterniond(AngleAxisd(-pitch, Vector3d::UnitY())) * Quaterniond(AngleAxisd(roll, Vector3d::UnitX()));
  const Vector3d w_pelvis = vec_at(d.cvel + 6 * pelvis_);
  const Vector3d w_thigh = vec_at(d.cvel + 6 * thigh_[swing]);
  const double k_hip = p.hip_kp * gain_scale_;
  // A placed step's thigh follows the IK pitch's rate in the world; a free one is damped
  // relative to the pelvis (SIMBICON).
  const Vector3d w_damped = placed ? Vector3d(w_thigh - q_heading * Vector3d(0, -ik_pitch_rate_, 0))
                                   : Vector3d(w_thigh - w_pelvis);
  const Vector3d tau_swing =
      k_hip * rotation_vector(q_thigh_goal * quat_at(d.xquat + 4 * thigh_[swing]).conjugate()) -
      k_hip * p.damping_time_s * w_damped;

  // Pelvis in the world by the virtual torso torque; the stance hip makes it (Coros 2010).
  const double lean = p.pelvis_pitch_rad + (d.time - start_s_ < p.start_time_s ? p.start_pitch_rad : 0.0) + speed_lean_rad();
  const Quaterniond q_pelvis_goal = q_heading * Quaterniond(AngleAxisd(lean, Vector3d::UnitY()));
  const double k_torso = p.torso_kp * gain_scale_;
  const Vector3d tau_torso = k_torso * rotation_vector(q_pelvis_goal * quat_at(d.xquat + 4 * pelvis_).conjugate()) -
                             k_torso * p.damping_time_s * w_pelvis;
  hip_torque(c, d, swing, tau_swing);
  hip_torque(c, d, stance_, -tau_torso - tau_swing - tau_lumbar);
}

void TorqueGait::apply_base_polygon_rule(const mjModel& m, const mjData& d, const Vector3d& com_W,
                                         const Vector3d& com_velocity_H) {
  const TorqueGaitParams& p = params_;
  const int swing = 1 - stance_;
  // Support polygon from the feet's actual floor contacts; the tolerance polygon is it scaled by
  // 2 tolerance_fraction about its centre (edges at that fraction of its extent from the centre).
  sim::floor_contacts(m, d, floor_geom_, &contacts_);
  const int feet[4] = {foot_[0], foot_[1], toes_[0], toes_[1]};
  contact_support_polygon(contacts_, feet, 4, &points_, &hull_);
  tolerance_.clear();
  if (hull_.size() < 3) return;
  controllers::tolerance_polygon(hull_, p.tolerance_fraction, &tolerance_);
  if (inside_convex(tolerance_, com_W.head<2>())) return;

  // Heading frame, from the stance ankle.
  const double ch = std::cos(heading_), sh = std::sin(heading_);
  const Eigen::Vector2d ankle(d.xpos[3 * foot_[stance_]], d.xpos[3 * foot_[stance_] + 1]);
  const auto local = [&](const Eigen::Vector2d& w) {
    const Eigen::Vector2d r = w - ankle;
    return Eigen::Vector2d(ch * r.x() + sh * r.y(), -sh * r.x() + ch * r.y());
  };
  double rear = 1e9, front = -1e9, right = 1e9, left = -1e9, cx = 0, cy = 0;
  for (const Eigen::Vector2d& w : hull_) {
    const Eigen::Vector2d q = local(w);
    rear = std::min(rear, q.x());
    front = std::max(front, q.x());
    right = std::min(right, q.y());
    left = std::max(left, q.y());
    cx += q.x();
    cy += q.y();
  }
  cx /= static_cast<double>(hull_.size());
  cy /= static_cast<double>(hull_.size());
  const Eigen::Vector2d c = local(com_W.head<2>());
  const double sagittal_tol = p.tolerance_fraction * (front - rear);
  if (c.x() > cx + sagittal_tol) {
    // Ahead: b_P the polygon's rear edge; the step (ankle to ankle, as heel to heel) at least
    // base_polygon_step. In normal walking the gait's own step is longer: it binds only when
    // the CoM has run further ahead.
    const double length = base_polygon_step(c.x() - rear, foot_length_);
    if (length > 0) rule_length_ = std::isnan(rule_length_) ? length : std::max(rule_length_, length);
  } else if (c.x() < cx - sagittal_tol && com_velocity_H.x() < 0) {
    // Behind and moving backwards: the mirror image from the front edge (a step back). Behind
    // but moving forwards is every step's start: the CoM comes over the foot by itself.
    const double length = -base_polygon_step(front - c.x(), foot_length_);
    if (length < 0) rule_length_ = std::isnan(rule_length_) ? length : std::min(rule_length_, length);
  }
  // Frontal counterpart (step width): the CoM beyond the tolerance band towards the swing side
  // and moving that way (every stance starts with the CoM on the swing side, coming back);
  // b_P the stance foot's outer edge, the foot width for the foot length. Towards the stance
  // side the rule would need a cross-over step: not taken (the legs would collide).
  const double side = swing == 0 ? 1.0 : -1.0;  // +1: the swing foot is the left one (+y)
  const double frontal_tol = p.tolerance_fraction * (left - right);
  if (side * (c.y() - cy) > frontal_tol && side * com_velocity_H.y() > 0) {
    const double outer = side > 0 ? right : left;
    const double width = base_polygon_step(side * (c.y() - outer), foot_width_);
    if (width > 0) rule_width_ = std::isnan(rule_width_) ? width : std::max(rule_width_, width);
  }
}

}  // namespace biodyn::controllers
