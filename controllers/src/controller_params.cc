#include "biodyn/controllers/controller_params.h"

#include <cmath>
#include <nlohmann/json.hpp>
#include <sstream>

#include "biodyn/sim/errors.h"
#include "biodyn/sim/units.h"
#include "json_fields.h"

namespace biodyn::controllers {
namespace {

using sim::InvalidArgument;
using Json = nlohmann::json;

// Paper §3.2 / §5.1: every muscle group reacts in 20 ms.
constexpr double kPaperReactionTime_s = 0.02;
// Default PD natural frequencies. A stance-leg joint turns the rest of the body (I ~ 80 kg m^2
// about the ankle): 2 Hz gives kp = I w^2 ~ 12 kN m/rad, well above the m g h ~ 0.8 kN m/rad
// that toppling needs, and kd dt / I << 1 keeps the explicitly applied damping stable.
constexpr double kPdLegFrequency_hz = 2.0;
constexpr double kPdUpperBodyFrequency_hz = 5.0;

// Bounds checked by validate().
constexpr double kMinReactionTime_s = 0.001, kMaxReactionTime_s = 2.0;
constexpr double kMinReachTime_s = 0.01, kMaxReachTime_s = 600.0;
constexpr double kMaxPdFrequency_hz = 100.0, kMaxDampingRatio = 10.0;
constexpr double kMaxHorizon_s = 1.0;

// Anatomical ranges of the ball joints, deg (American Academy of Orthopaedic Surgeons 1965,
// as tabulated in Greene & Heckman 1994): hip flexion 120, extension 30, abduction 45,
// adduction 30, internal 45, external 45; shoulder flexion 180 (limited to 170 here to stay
// clear of the swing singularity), extension 60, abduction 170, adduction 30 (across the
// body), internal 70, external 90.
const SwingTwistLimits kHipLimits{120 * kRadPerDeg, 30 * kRadPerDeg, 45 * kRadPerDeg,
                                  30 * kRadPerDeg,  45 * kRadPerDeg, 45 * kRadPerDeg};
const SwingTwistLimits kShoulderLimits{170 * kRadPerDeg, 60 * kRadPerDeg, 170 * kRadPerDeg,
                                       30 * kRadPerDeg,  70 * kRadPerDeg, 90 * kRadPerDeg};

bool starts_with(const std::string& s, const char* prefix) { return s.rfind(prefix, 0) == 0; }

bool is_leg(const std::string& group) {
  return starts_with(group, "hip") || starts_with(group, "knee") || starts_with(group, "ankle") ||
         starts_with(group, "toe");
}

using json_fields::fail;
using json_fields::number_text;
using json_fields::read_number;

void check_range(double v, double lo, double hi, const std::string& where, const char* unit) {
  if (!(v >= lo && v <= hi)) {
    fail(where, "must be in [" + number_text(lo) + ", " + number_text(hi) + "] " + unit,
         number_text(v));
  }
}

void apply_joint(const Json& j, const std::string& where, const JointGroup& group, JointParams* p) {
  if (!j.is_object()) fail(where, "must be an object", j.dump());
  for (auto it = j.begin(); it != j.end(); ++it) {
    const std::string key = it.key();
    const std::string at = where + "." + key;
    const Json& v = it.value();
    if (key == "tau_max_Nm") {
      if (v.is_number()) {
        const double tau = read_number(v, at);
        for (int k = 0; k < group.dof_count; ++k) p->tau_max_Nm[k] = tau;
      } else if (v.is_array()) {
        if (static_cast<int>(v.size()) != group.dof_count) {
          fail(at,
               "must have " + std::to_string(group.dof_count) + " entries (one per DOF of " +
                   group.name + ")",
               std::to_string(v.size()) + " entries");
        }
        for (int k = 0; k < group.dof_count; ++k)
          p->tau_max_Nm[k] = read_number(v[static_cast<std::size_t>(k)], at);
      } else {
        fail(at, "must be a number or an array of numbers", v.dump());
      }
    } else if (key == "reaction_time_s") {
      p->reaction_time_s = read_number(v, at);
    } else if (key == "reach_time_s") {
      p->reach_time_s = read_number(v, at);
    } else if (key == "pd") {
      if (!v.is_object()) fail(at, "must be an object", v.dump());
      for (auto pit = v.begin(); pit != v.end(); ++pit) {
        if (pit.key() == "natural_frequency_hz") {
          p->pd_natural_frequency_hz = read_number(pit.value(), at + "." + pit.key());
        } else if (pit.key() == "damping_ratio") {
          p->pd_damping_ratio = read_number(pit.value(), at + "." + pit.key());
        } else {
          fail(at + "." + pit.key(), "unknown key (expected natural_frequency_hz, damping_ratio)",
               "'" + pit.key() + "'");
        }
      }
    } else if (key == "swing_twist_deg") {
      if (!group.ball) fail(at, "only ball joints have swing-twist limits", group.name);
      if (!v.is_object()) fail(at, "must be an object", v.dump());
      SwingTwistLimits lim = p->swing_twist.value_or(SwingTwistLimits{});
      const std::pair<const char*, double*> fields[] = {
          {"flexion", &lim.flexion_rad},
          {"extension", &lim.extension_rad},
          {"abduction", &lim.abduction_rad},
          {"adduction", &lim.adduction_rad},
          {"internal_rotation", &lim.internal_rotation_rad},
          {"external_rotation", &lim.external_rotation_rad}};
      for (auto sit = v.begin(); sit != v.end(); ++sit) {
        bool known = false;
        for (const auto& [name, field] : fields) {
          if (sit.key() == name) {
            const double deg = read_number(sit.value(), at + "." + name);
            check_range(deg, 1, 179, at + "." + name, "deg");
            *field = deg * kRadPerDeg;
            known = true;
          }
        }
        if (!known) {
          fail(at + "." + sit.key(),
               "unknown key (expected flexion, extension, abduction, adduction, "
               "internal_rotation, external_rotation)",
               "'" + sit.key() + "'");
        }
      }
      p->swing_twist = lim;
    } else {
      fail(at,
           "unknown key (expected tau_max_Nm, reaction_time_s, reach_time_s, pd, swing_twist_deg)",
           "'" + key + "'");
    }
  }
}

}  // namespace

void ControllerParams::validate(double timestep_s) const {
  check_range(velocity_horizon_s, 2 * timestep_s, kMaxHorizon_s, "controller.velocity_horizon_s",
              "s (at least two timesteps)");
  check_range(min_time_to_go_s, timestep_s, kMaxHorizon_s, "controller.min_time_to_go_s",
              "s (at least one timestep)");
  for (std::size_t i = 0; i < joints.size(); ++i) {
    const JointParams& p = joints[i];
    const std::string w = "joints." + names[i];
    for (int k = 0; k < 3; ++k) {
      if (!(p.tau_max_Nm[k] >= 0) || !std::isfinite(p.tau_max_Nm[k]))
        fail(w + ".tau_max_Nm", "must be finite and >= 0 N m", number_text(p.tau_max_Nm[k]));
    }
    check_range(p.reaction_time_s, kMinReactionTime_s, kMaxReactionTime_s, w + ".reaction_time_s",
                "s");
    check_range(p.reach_time_s, kMinReachTime_s, kMaxReachTime_s, w + ".reach_time_s", "s");
    if (!(p.pd_natural_frequency_hz > 0 && p.pd_natural_frequency_hz <= kMaxPdFrequency_hz))
      fail(w + ".pd.natural_frequency_hz", "must be in (0, 100] Hz",
           number_text(p.pd_natural_frequency_hz));
    check_range(p.pd_damping_ratio, 0, kMaxDampingRatio, w + ".pd.damping_ratio", "");
  }
}

const JointParams& ControllerParams::at(const std::string& name) const {
  for (std::size_t i = 0; i < names.size(); ++i)
    if (names[i] == name) return joints[i];
  std::string known;
  for (const std::string& n : names) known += (known.empty() ? "" : ", ") + n;
  throw InvalidArgument("controller params: no joint named '" + name + "' (joints: " + known + ")");
}

JointParams& ControllerParams::at(const std::string& name) {
  return const_cast<JointParams&>(static_cast<const ControllerParams&>(*this).at(name));
}

ControllerParams default_params(const mjModel& m, const std::vector<JointGroup>& groups) {
  const std::vector<double> dof_tau = sim::motor_limits_per_dof(m);  // from the generated motors
  ControllerParams p;
  for (const JointGroup& g : groups) {
    JointParams jp;
    jp.reaction_time_s = kPaperReactionTime_s;
    for (int k = 0; k < g.dof_count; ++k) {
      const double t = dof_tau[static_cast<std::size_t>(g.dof_begin + k)];
      if (!(t > 0)) {
        throw InvalidArgument(
            "controller params: DOF '" + g.dof_names[static_cast<std::size_t>(k)] +
            "' has no limited motor; give joints." + g.name + ".tau_max_Nm in the params file");
      }
      jp.tau_max_Nm[k] = t;
    }
    jp.pd_natural_frequency_hz = is_leg(g.name) ? kPdLegFrequency_hz : kPdUpperBodyFrequency_hz;
    if (g.ball && starts_with(g.name, "hip")) jp.swing_twist = kHipLimits;
    if (g.ball && starts_with(g.name, "shoulder")) jp.swing_twist = kShoulderLimits;
    p.names.push_back(g.name);
    p.joints.push_back(jp);
  }
  return p;
}

void apply_params_json(const std::string& json_text, const std::string& source,
                       const std::vector<JointGroup>& groups, ControllerParams* params) {
  Json root;
  try {
    root = Json::parse(json_text);
  } catch (const Json::exception& e) {  // parse_error, or out_of_range for 1e400
    throw InvalidArgument(source + ": not valid JSON (" + std::string(e.what()) + ")");
  }
  if (!root.is_object()) fail(source, "must hold a JSON object", root.type_name());
  for (auto it = root.begin(); it != root.end(); ++it) {
    const std::string& key = it.key();
    const Json& v = it.value();
    if (key == "controller") {
      if (!v.is_object()) fail(source + ": controller", "must be an object", v.dump());
      for (auto cit = v.begin(); cit != v.end(); ++cit) {
        const std::string at = source + ": controller." + cit.key();
        if (cit.key() == "velocity_horizon_s") {
          params->velocity_horizon_s = read_number(cit.value(), at);
        } else if (cit.key() == "min_time_to_go_s") {
          params->min_time_to_go_s = read_number(cit.value(), at);
        } else {
          fail(at, "unknown key (expected velocity_horizon_s, min_time_to_go_s)",
               "'" + cit.key() + "'");
        }
      }
    } else if (key == "joints") {
      if (!v.is_object()) fail(source + ": joints", "must be an object", v.dump());
      // Apply "all", then names without side, then exact names: the most specific wins.
      for (int pass = 0; pass < 3; ++pass) {
        for (auto jit = v.begin(); jit != v.end(); ++jit) {
          const std::string& name = jit.key();
          const bool all = name == "all";
          const bool exact = find_group(groups, name) >= 0;
          const bool sided =
              !all && !exact &&
              (find_group(groups, name + "_l") >= 0 || find_group(groups, name + "_r") >= 0);
          if (!all && !exact && !sided) {
            std::string known;
            for (const JointGroup& g : groups) known += (known.empty() ? "" : ", ") + g.name;
            fail(source + ": joints." + name, "no such joint (joints: all, " + known + ")",
                 "'" + name + "'");
          }
          if ((pass == 0 && !all) || (pass == 1 && !sided) || (pass == 2 && !exact)) continue;
          for (std::size_t g = 0; g < groups.size(); ++g) {
            const std::string& gn = groups[g].name;
            if (all || gn == name || gn == name + "_l" || gn == name + "_r") {
              if (all && jit.value().contains("tau_max_Nm") && jit.value()["tau_max_Nm"].is_array())
                fail(source + ": joints.all.tau_max_Nm", "must be one number for all joints",
                     jit.value()["tau_max_Nm"].dump());
              if (all && jit.value().contains("swing_twist_deg") && !groups[g].ball) continue;
              apply_joint(jit.value(), source + ": joints." + name, groups[g], &params->joints[g]);
            }
          }
        }
      }
    } else {
      fail(source + ": " + key, "unknown key (expected controller, joints)", "'" + key + "'");
    }
  }
}

Json params_to_json(const ControllerParams& params, const std::vector<JointGroup>& groups) {
  Json joints = Json::object();
  for (std::size_t g = 0; g < groups.size(); ++g) {
    const JointParams& p = params.joints[g];
    Json tau = Json::array();
    for (int k = 0; k < groups[g].dof_count; ++k) tau.push_back(p.tau_max_Nm[k]);
    Json j = {{"tau_max_Nm", tau},
              {"reaction_time_s", p.reaction_time_s},
              {"reach_time_s", p.reach_time_s},
              {"pd",
               {{"natural_frequency_hz", p.pd_natural_frequency_hz},
                {"damping_ratio", p.pd_damping_ratio}}}};
    if (p.swing_twist) {
      const SwingTwistLimits& s = *p.swing_twist;
      j["swing_twist_deg"] = {{"flexion", s.flexion_rad / kRadPerDeg},
                              {"extension", s.extension_rad / kRadPerDeg},
                              {"abduction", s.abduction_rad / kRadPerDeg},
                              {"adduction", s.adduction_rad / kRadPerDeg},
                              {"internal_rotation", s.internal_rotation_rad / kRadPerDeg},
                              {"external_rotation", s.external_rotation_rad / kRadPerDeg}};
    }
    joints[groups[g].name] = j;
  }
  return {{"controller",
           {{"velocity_horizon_s", params.velocity_horizon_s},
            {"min_time_to_go_s", params.min_time_to_go_s}}},
          {"joints", joints}};
}

void apply_params_file_json(const std::string& json_text, const std::string& source,
                            const std::vector<JointGroup>& groups, double timestep_s,
                            ControllerParams* params) {
  apply_params_json(json_text, source, groups, params);
  try {
    params->validate(timestep_s);
  } catch (const sim::InvalidArgument& e) {
    throw sim::InvalidArgument(source + ": " + e.what());
  }
}

}  // namespace biodyn::controllers
