#include "biodyn/controllers/velocity_walker_params.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <nlohmann/json.hpp>

#include "biodyn/sim/errors.h"
#include "biodyn/sim/units.h"
#include "json_fields.h"

namespace biodyn::controllers {
namespace {

using Json = nlohmann::json;
using sim::InvalidArgument;

using json_fields::fail;

using json_fields::check;

const auto number = json_fields::read_number;

using json_fields::boolean;
using json_fields::numbers;
using json_fields::read_object;

// A [start, end] pair of fractions in [0, 1].
Eigen::Vector2d pair(const Json& j, const std::string& where) {
  const std::vector<double> v = numbers(j, where);
  if (v.size() != 2) fail(where, "must be [start, end]", j.dump());
  for (double x : v)
    if (!(x >= 0 && x <= 1)) fail(where, "fractions must be in [0, 1]", j.dump());
  return {v[0], v[1]};
}

VelocityWalkerPhase read_phase(const Json& j, const std::string& where) {
  VelocityWalkerPhase s;
  bool have_name = false;
  read_object(
      j, where,
      {{"name",
        [&](const Json& v, const std::string& w) {
          if (!v.is_string()) fail(w, "must be a string", v.dump());
          s.name = v.get<std::string>();
          have_name = true;
        }},
       {"duration_s", [&](const Json& v, const std::string& w) { s.duration_s = number(v, w); }},
       {"end",
        [&](const Json& v, const std::string& w) {
          if (v == "time")
            s.ends_at_strike = false;
          else if (v == "strike")
            s.ends_at_strike = true;
          else
            fail(w, "must be \"time\" or \"strike\"", v.dump());
        }},
       {"reach_fraction",
        [&](const Json& v, const std::string& w) { s.reach_fraction = number(v, w); }},
       {"foot_placement",
        [&](const Json& v, const std::string& w) { s.foot_placement = boolean(v, w); }},
       {"swing_foot_down",
        [&](const Json& v, const std::string& w) { s.swing_foot_down = boolean(v, w); }},
       {"stance_cop", [&](const Json& v, const std::string& w) { s.stance_cop = pair(v, w); }},
       {"trailing_cop", [&](const Json& v, const std::string& w) { s.trailing_cop = pair(v, w); }},
       {"targets_deg", [&](const Json& v, const std::string& w) {
          if (!v.is_object()) fail(w, "must be an object of role: [angles]", v.dump());
          for (auto it = v.begin(); it != v.end(); ++it) {
            const std::vector<double> a = numbers(it.value(), w + "." + it.key());
            if (a.empty() || a.size() > 3)
              fail(w + "." + it.key(), "must have 1 to 3 angles", it.value().dump());
            Eigen::Vector3d r = Eigen::Vector3d::Zero();
            for (std::size_t k = 0; k < a.size(); ++k)
              r[static_cast<Eigen::Index>(k)] = a[k] * kRadPerDeg;
            s.targets_rad[it.key()] = r;
          }
        }}});
  if (!have_name) fail(where + ".name", "is required", "nothing");
  return s;
}

Json state_json(const VelocityWalkerPhase& s) {
  Json t = Json::object();
  for (const auto& [role, a] : s.targets_rad)
    t[role] = {a[0] / kRadPerDeg, a[1] / kRadPerDeg, a[2] / kRadPerDeg};
  return {{"name", s.name},
          {"duration_s", s.duration_s},
          {"end", s.ends_at_strike ? "strike" : "time"},
          {"reach_fraction", s.reach_fraction},
          {"foot_placement", s.foot_placement},
          {"swing_foot_down", s.swing_foot_down},
          {"stance_cop", {s.stance_cop[0], s.stance_cop[1]}},
          {"trailing_cop", {s.trailing_cop[0], s.trailing_cop[1]}},
          {"targets_deg", t}};
}

VelocityWalkerPhase state(const std::string& name, double duration_s, bool at_strike,
                          double reach_fraction, bool placement,
                          std::map<std::string, Eigen::Vector3d> deg) {
  VelocityWalkerPhase s;
  s.name = name;
  s.duration_s = duration_s;
  s.ends_at_strike = at_strike;
  s.reach_fraction = reach_fraction;
  s.foot_placement = placement;
  for (auto& [role, a] : deg) s.targets_rad[role] = a * kRadPerDeg;
  return s;
}

}  // namespace

VelocityWalkerParams default_velocity_walker_params() {
  using V = Eigen::Vector3d;
  VelocityWalkerParams p;
  // One step at the reference cadence of 108 steps/min (0.556 s): double support 0.1 s
  // (~18% of the step, as in human walking at 1.2 m/s, Perry 1992), lift 0.16 s, swing to
  // the strike ~0.3 s. Angles after Winter's (2009) normal-gait averages, simplified:
  // swing knee flexes to ~60 deg just after toe-off and extends to ~5 deg at strike; the
  // trailing ankle plantarflexes and the toes dorsiflex in push-off; the stance knee stays
  // a little bent (~10 deg); arms swing opposite the legs.
  const std::map<std::string, V> arms = {{"stance_shoulder", V(12, 0, 0)},
                                         {"swing_shoulder", V(-12, 0, 0)},
                                         {"stance_elbow", V(20, 0, 0)},
                                         {"swing_elbow", V(15, 0, 0)}};
  auto with_arms = [&](std::map<std::string, V> t) {
    for (const auto& kv : arms) t.insert(kv);
    return t;
  };
  p.phases = {
      state("double_support", 0.10, false, 1.0, false,
            with_arms({{"swing_hip", V(-15, 0, 0)},
                       {"swing_knee", V(30, 0, 0)},
                       {"swing_ankle", V(-15, 0, 0)},
                       {"swing_toe", V(25, 0, 0)},
                       {"stance_knee", V(10, 0, 0)},
                       {"stance_ankle", V(0, 0, 0)}})),
      state("lift", 0.16, false, 1.0, false,
            with_arms({{"swing_hip", V(20, 0, 0)},
                       {"swing_knee", V(62, 0, 0)},
                       {"swing_ankle", V(5, 0, 0)},
                       {"swing_toe", V(0, 0, 0)},
                       {"stance_knee", V(8, 0, 0)},
                       {"stance_ankle", V(4, 0, 0)}})),
      state("swing", 0.30, true, 1.0, true,
            with_arms({{"swing_ankle", V(5, 0, 0)},
                       {"swing_toe", V(0, 0, 0)},
                       {"stance_knee", V(8, 0, 0)},
                       {"stance_ankle", V(10, 0, 0)}})),
  };
  p.phases[0].swing_foot_down = true;
  p.phases[0].stance_cop = {0.1, 0.3};
  p.phases[0].trailing_cop = {0.85, 0.95};
  p.phases[1].stance_cop = {0.3, 0.45};
  p.phases[2].stance_cop = {0.45, 0.8};
  return p;
}

double VelocityWalkerParams::cadence(double speed_m_s) const {
  const auto& xs = posture.cadence_speeds_m_s;
  const auto& ys = posture.cadence_steps_per_min;
  if (speed_m_s <= xs.front()) return ys.front();
  for (std::size_t i = 1; i < xs.size(); ++i) {
    if (speed_m_s <= xs[i]) {
      const double f = (speed_m_s - xs[i - 1]) / (xs[i] - xs[i - 1]);
      return ys[i - 1] + f * (ys[i] - ys[i - 1]);
    }
  }
  return ys.back();
}

void VelocityWalkerParams::validate() const {
  if (phases.empty()) fail("gait.states", "needs at least one state", "none");
  if (!phases.back().ends_at_strike)
    fail("gait.states[" + std::to_string(phases.size() - 1) + "].end",
         "the last state of a step must end at the strike", "\"time\"");
  for (std::size_t i = 0; i < phases.size(); ++i) {
    const VelocityWalkerPhase& s = phases[i];
    const std::string w = "gait.states[" + std::to_string(i) + "] (" + s.name + ")";
    check(s.duration_s > 0 && s.duration_s <= 10, w + ".duration_s", "must be in (0, 10] s",
          s.duration_s);
    check(s.reach_fraction > 0 && s.reach_fraction <= 5, w + ".reach_fraction", "must be in (0, 5]",
          s.reach_fraction);
    for (const auto& [role, a] : s.targets_rad) {
      if (role == "stance_hip")
        fail(w + ".targets_deg.stance_hip",
             "the stance hip holds the pelvis posture, it takes no target", "an entry");
      for (int k = 0; k < 3; ++k)
        check(std::abs(a[k]) <= M_PI, w + ".targets_deg." + role, "angles must be within +-180 deg",
              a[k] / kRadPerDeg);
    }
  }
  const FootPlacementParams& f = placement;
  check(f.capture_gain >= 0 && f.capture_gain <= 5, "gait.placement.capture_gain",
        "must be in [0, 5]", f.capture_gain);
  check(f.step_width_fraction >= 0 && f.step_width_fraction <= 4,
        "gait.placement.step_width_fraction", "must be in [0, 4]", f.step_width_fraction);
  check(f.min_width_fraction >= 0 && f.min_width_fraction <= f.step_width_fraction + 1e-12,
        "gait.placement.min_width_fraction", "must be in [0, step_width_fraction]",
        f.min_width_fraction);
  check(f.strike_knee_deg >= 0 && f.strike_knee_deg <= 90, "gait.placement.strike_knee_deg",
        "must be in [0, 90]", f.strike_knee_deg);
  check(f.tolerance_fraction > 0 && f.tolerance_fraction <= 0.5,
        "gait.placement.tolerance_fraction", "must be in (0, 0.5]", f.tolerance_fraction);
  check(f.min_swing_fraction >= 0 && f.min_swing_fraction < 1, "gait.placement.min_swing_fraction",
        "must be in [0, 1)", f.min_swing_fraction);
  check(f.max_swing_factor >= 1 && f.max_swing_factor <= 10, "gait.placement.max_swing_factor",
        "must be in [1, 10]", f.max_swing_factor);
  check(f.swing_clearance_m >= 0 && f.swing_clearance_m <= 0.3, "gait.placement.swing_clearance_m",
        "must be in [0, 0.3] m", f.swing_clearance_m);
  check(std::abs(f.swing_toe_up_deg) <= 45, "gait.placement.swing_toe_up_deg",
        "must be within +-45", f.swing_toe_up_deg);
  const LegComplianceParams& c = compliance;
  for (const auto& [name, v] : {std::pair<const char*, double>{"stance_knee", c.stance_knee},
                                {"stance_ankle", c.stance_ankle},
                                {"trailing_leg", c.trailing_leg}})
    check(v >= 0 && v <= 50, std::string("gait.compliance.") + name, "must be in [0, 50]", v);
  check(c.damping_time_s >= 0 && c.damping_time_s <= 1, "gait.compliance.damping_time_s",
        "must be in [0, 1] s", c.damping_time_s);
  const GaitPostureParams& p = posture;
  if (p.cadence_speeds_m_s.size() != p.cadence_steps_per_min.size() || p.cadence_speeds_m_s.empty())
    fail("gait.posture.cadence_steps_per_min", "needs one cadence per speed in cadence_speeds_m_s",
         std::to_string(p.cadence_steps_per_min.size()) + " for " +
             std::to_string(p.cadence_speeds_m_s.size()));
  for (std::size_t i = 0; i < p.cadence_speeds_m_s.size(); ++i) {
    if (i > 0)
      check(p.cadence_speeds_m_s[i] > p.cadence_speeds_m_s[i - 1],
            "gait.posture.cadence_speeds_m_s", "must increase", p.cadence_speeds_m_s[i]);
    check(p.cadence_steps_per_min[i] >= 30 && p.cadence_steps_per_min[i] <= 240,
          "gait.posture.cadence_steps_per_min", "must be in [30, 240]", p.cadence_steps_per_min[i]);
  }
  check(p.reference_cadence_steps_per_min >= 30 && p.reference_cadence_steps_per_min <= 240,
        "gait.posture.reference_cadence_steps_per_min", "must be in [30, 240]",
        p.reference_cadence_steps_per_min);
  check(std::abs(p.pelvis_pitch_deg) <= 45, "gait.posture.pelvis_pitch_deg", "must be within +-45",
        p.pelvis_pitch_deg);
  check(std::abs(p.pelvis_pitch_deg_per_m_s) <= 30, "gait.posture.pelvis_pitch_deg_per_m_s",
        "must be within +-30", p.pelvis_pitch_deg_per_m_s);
  check(p.world_tracking_time_s >= 0.01 && p.world_tracking_time_s <= 2,
        "gait.posture.world_tracking_time_s", "must be in [0.01, 2] s", p.world_tracking_time_s);
  check(p.speed_ramp_m_s2 > 0 && p.speed_ramp_m_s2 <= 20, "gait.posture.speed_ramp_m_s2",
        "must be in (0, 20]", p.speed_ramp_m_s2);
  check(p.cop_margin > 0 && p.cop_margin <= 1, "gait.posture.cop_margin", "must be in (0, 1]",
        p.cop_margin);
}

void apply_velocity_walker_json(const std::string& json_text, const std::string& source,
                                VelocityWalkerParams* params) {
  Json root;
  try {
    root = Json::parse(json_text);
  } catch (const Json::exception& e) {  // parse_error, or out_of_range for 1e400
    throw InvalidArgument(source + ": not valid JSON (" + std::string(e.what()) + ")");
  }
  VelocityWalkerParams p = *params;
  FootPlacementParams& f = p.placement;
  GaitPostureParams& q = p.posture;
  const auto num = [](double* out) {
    return [out](const Json& v, const std::string& w) { *out = number(v, w); };
  };
  read_object(root, source,
              {{"states",
                [&](const Json& v, const std::string& w) {
                  if (!v.is_array()) fail(w, "must be an array of states", v.dump());
                  p.phases.clear();
                  for (std::size_t i = 0; i < v.size(); ++i)
                    p.phases.push_back(read_phase(v[i], w + "[" + std::to_string(i) + "]"));
                }},
               {"placement",
                [&](const Json& v, const std::string& w) {
                  read_object(v, w,
                              {{"capture_gain", num(&f.capture_gain)},
                               {"step_width_fraction", num(&f.step_width_fraction)},
                               {"min_width_fraction", num(&f.min_width_fraction)},
                               {"strike_knee_deg", num(&f.strike_knee_deg)},
                               {"tolerance_fraction", num(&f.tolerance_fraction)},
                               {"base_polygon_rule",
                                [&](const Json& b, const std::string& wb) {
                                  f.base_polygon_rule = boolean(b, wb);
                                }},
                               {"min_swing_fraction", num(&f.min_swing_fraction)},
                               {"max_swing_factor", num(&f.max_swing_factor)},
                               {"swing_clearance_m", num(&f.swing_clearance_m)},
                               {"swing_toe_up_deg", num(&f.swing_toe_up_deg)}});
                }},
               {"compliance",
                [&](const Json& v, const std::string& w) {
                  LegComplianceParams& c = p.compliance;
                  read_object(v, w,
                              {{"stance_knee", num(&c.stance_knee)},
                               {"stance_ankle", num(&c.stance_ankle)},
                               {"trailing_leg", num(&c.trailing_leg)},
                               {"damping_time_s", num(&c.damping_time_s)}});
                }},
               {"posture", [&](const Json& v, const std::string& w) {
                  read_object(
                      v, w,
                      {{"cadence_speeds_m_s",
                        [&](const Json& a, const std::string& wa) {
                          q.cadence_speeds_m_s = numbers(a, wa);
                        }},
                       {"cadence_steps_per_min",
                        [&](const Json& a, const std::string& wa) {
                          q.cadence_steps_per_min = numbers(a, wa);
                        }},
                       {"reference_cadence_steps_per_min", num(&q.reference_cadence_steps_per_min)},
                       {"pelvis_pitch_deg", num(&q.pelvis_pitch_deg)},
                       {"pelvis_pitch_deg_per_m_s", num(&q.pelvis_pitch_deg_per_m_s)},
                       {"world_tracking_time_s", num(&q.world_tracking_time_s)},
                       {"speed_ramp_m_s2", num(&q.speed_ramp_m_s2)},
                       {"cop_margin", num(&q.cop_margin)},
                       {"cop_torque", [&](const Json& b, const std::string& wb) {
                          q.cop_torque = boolean(b, wb);
                        }}});
                }}});
  p.validate();
  *params = p;
}

Json velocity_walker_json(const VelocityWalkerParams& p) {
  Json phases = Json::array();
  for (const VelocityWalkerPhase& s : p.phases) phases.push_back(state_json(s));
  const FootPlacementParams& f = p.placement;
  const GaitPostureParams& q = p.posture;
  return {{"states", phases},
          {"placement",
           {{"capture_gain", f.capture_gain},
            {"step_width_fraction", f.step_width_fraction},
            {"min_width_fraction", f.min_width_fraction},
            {"strike_knee_deg", f.strike_knee_deg},
            {"tolerance_fraction", f.tolerance_fraction},
            {"base_polygon_rule", f.base_polygon_rule},
            {"min_swing_fraction", f.min_swing_fraction},
            {"max_swing_factor", f.max_swing_factor},
            {"swing_clearance_m", f.swing_clearance_m},
            {"swing_toe_up_deg", f.swing_toe_up_deg}}},
          {"compliance",
           {{"stance_knee", p.compliance.stance_knee},
            {"stance_ankle", p.compliance.stance_ankle},
            {"trailing_leg", p.compliance.trailing_leg},
            {"damping_time_s", p.compliance.damping_time_s}}},
          {"posture",
           {{"cadence_speeds_m_s", q.cadence_speeds_m_s},
            {"cadence_steps_per_min", q.cadence_steps_per_min},
            {"reference_cadence_steps_per_min", q.reference_cadence_steps_per_min},
            {"pelvis_pitch_deg", q.pelvis_pitch_deg},
            {"pelvis_pitch_deg_per_m_s", q.pelvis_pitch_deg_per_m_s},
            {"world_tracking_time_s", q.world_tracking_time_s},
            {"speed_ramp_m_s2", q.speed_ramp_m_s2},
            {"cop_margin", q.cop_margin},
            {"cop_torque", q.cop_torque}}}};
}

}  // namespace biodyn::controllers
