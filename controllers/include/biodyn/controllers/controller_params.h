#pragma once
/// Parameters of the joint controllers, per joint group: the paper's two muscle parameters
/// (tau_max per axis and reaction time t_r, §3.2 and Table 2), the default reach ("optimal")
/// time of a target, PD gains as natural frequency and damping ratio, and the anatomical
/// swing-twist limits of ball joints. Read from and written to JSON (`--params p.json`).
///
/// JSON layout (every field optional; keys without _l/_r apply to both sides, "all" to every
/// joint; more specific keys win):
///   {"controller": {"velocity_horizon_s": 0.03, "min_time_to_go_s": 0.05},
///    "joints": {"all": {"reaction_time_s": 0.1},
///               "hip": {"tau_max_Nm": [480, 480, 480], "reach_time_s": 0.3,
///                       "pd": {"natural_frequency_hz": 15, "damping_ratio": 1},
///                       "swing_twist_deg": {"flexion": 120, "extension": 30,
///                                           "abduction": 45, "adduction": 30,
///                                           "internal_rotation": 45,
///                                           "external_rotation": 45}}}}

#include <mujoco/mujoco.h>

#include <Eigen/Core>
#include <nlohmann/json_fwd.hpp>
#include <optional>
#include <string>
#include <vector>

#include "biodyn/controllers/joint_groups.h"

namespace biodyn::controllers {

/// Anatomical limits of a ball joint as a swing cone plus a twist range (Baerlocher & Boulic
/// 2001): the swing (rotation of the bone axis) must stay inside an ellipse whose half-axes
/// depend on the quadrant; the twist about the bone axis inside [-external, internal].
struct SwingTwistLimits {
  double flexion_rad = 0, extension_rad = 0;    ///< swing half-axes forward / backward, rad
  double abduction_rad = 0, adduction_rad = 0;  ///< swing half-axes outward / inward, rad
  double internal_rotation_rad = 0, external_rotation_rad = 0;  ///< twist range, rad
};

/// One joint group's parameters.
struct JointParams {
  /// N m, muscle torque limit per DOF of the group (first dof_count entries used; ball: body
  /// x, y, z). Default: the model's motor ctrlrange (the paper's Table 2 scaled to the body).
  Eigen::Vector3d tau_max_Nm = Eigen::Vector3d::Zero();
  /// s, muscle reaction time t_r: |tau - tau_prev| <= tau_max * dt / t_r (paper §3.2: 20 ms).
  double reaction_time_s = 0.02;
  /// s, default reach ("optimal") time of a target that does not give its own.
  double reach_time_s = 0.3;
  double pd_natural_frequency_hz = 5.0;         ///< Hz, PD controller only
  double pd_damping_ratio = 1.0;                ///< 1 = critical, PD controller only
  std::optional<SwingTwistLimits> swing_twist;  ///< ball joints of the hips and shoulders
};

/// Everything the joint controllers need, aligned with a list of joint groups.
struct ControllerParams {
  std::vector<std::string> names;  ///< group names, same order as the groups
  std::vector<JointParams> joints;
  /// s, the velocity-based controller reaches the desired velocity w over this horizon
  /// (desired acceleration (w - omega) / horizon). walking-notes.md: a one-step horizon
  /// falls; >= 10-20 ms is needed.
  double velocity_horizon_s = 0.03;
  /// s, lower bound of the time to go towards a target (w = theta v / t_go); keeps w finite
  /// as the reach time arrives and holds the target afterwards.
  double min_time_to_go_s = 0.05;

  /// Throws sim::InvalidArgument naming the joint, field, rule and value. `timestep_s` is
  /// the model's: the horizon must be at least two steps.
  void validate(double timestep_s) const;
  /// Parameters of the group called `name`; throws InvalidArgument if there is none.
  const JointParams& at(const std::string& name) const;
  JointParams& at(const std::string& name);
};

/// Defaults for the groups of `m`: tau_max from each DOF's motor ctrlrange (throws
/// InvalidArgument naming a DOF that has no motor), t_r 20 ms, reach time 0.3 s, PD gains by
/// joint kind, swing-twist limits for hips and shoulders (AAOS 1965 ranges).
ControllerParams default_params(const mjModel& m, const std::vector<JointGroup>& groups);

/// Applies the JSON text (layout above) on top of `params`. `source` names the file in
/// errors. Throws InvalidArgument for malformed JSON, unknown keys or joints, wrong array
/// lengths, non-numbers and out-of-range values (naming source, key path and value).
void apply_params_json(const std::string& json_text, const std::string& source,
                       const std::vector<JointGroup>& groups, ControllerParams* params);

/// apply_params_json, then validate(timestep_s) with errors prefixed by `source`: what every
/// scenario does with a user's controller file.
void apply_params_file_json(const std::string& json_text, const std::string& source,
                            const std::vector<JointGroup>& groups, double timestep_s,
                            ControllerParams* params);

/// The full parameter set as JSON (every joint spelled out, angles in degrees); reading it
/// back with apply_params_json gives the same parameters.
nlohmann::json params_to_json(const ControllerParams& params,
                              const std::vector<JointGroup>& groups);

}  // namespace biodyn::controllers
