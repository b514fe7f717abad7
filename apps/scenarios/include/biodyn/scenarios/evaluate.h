#pragma once
/// `biodyn evaluate`: can this body do this motion? A captured motion put on a list of bodies
/// (height, mass, sex, mass distribution, tau_max rule); per body: the motion retargeted to it,
/// ground forces estimated from its kinematics, inverse-dynamics torques and root residuals,
/// static-optimisation muscle activations, physics tracking (SAMCON, samcon.h), peak |tau| over
/// tau_max per joint and the first joint to saturate, and mechanical work and power per joint.

#include <Eigen/Core>
#include <array>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "biodyn/models/character.h"
#include "biodyn/scenarios/samcon.h"

namespace biodyn::scenarios {

/// How a body's tau_max is set.
enum class TauMaxRule {
  kScaled,  ///< the generator's: tau_ref x (mass / 82.2 kg) x (height / 1.799 m) (paper §5.1)
  kFixed    ///< the reference body's (the motion's own), whatever this body weighs
};

/// One body of the list (bodies.json).
struct EvaluationBody {
  std::string name;
  models::CharacterSpec spec;        ///< height, mass, sex (detail: full)
  std::string profile = "standard";  ///< "standard" or "heavy_trunk_thighs" (+25% trunk, thighs)
  TauMaxRule tau_rule = TauMaxRule::kScaled;
};

/// Reads bodies.json: {"bodies": [{"name": "heavy", "height_m": 1.8, "mass_kg": 120,
/// "sex": "male", "profile": "standard", "tau_max": "scaled"}, ...]}. Throws
/// sim::InvalidArgument naming the file, the body and the field.
std::vector<EvaluationBody> parse_bodies(const std::string& json_text, const std::string& source);

struct EvaluateOptions {
  bool tracking = true;  ///< SAMCON per body (the costly part)
  SamconParams samcon;   ///< its search
  double tracking_lookahead_s = 0.05;
  int threads = 0;  ///< bodies evaluated in parallel (0: every core)
};

/// Per joint group of one body.
struct JointEvaluation {
  std::string joint;          ///< "hip_l", "knee_r", ...
  double peak_torque_Nm = 0;  ///< max over frames of the group's |tau| (vector norm)
  double tau_max_Nm = 0;      ///< the smallest of its DOFs' tau_max
  double peak_ratio = 0;      ///< max over frames and DOFs of |tau| / tau_max
  /// s, start of the first stretch of >= 50 ms with |tau| > tau_max on a DOF, -1: never
  double first_saturation_s = -1;
  double positive_work_J = 0, negative_work_J = 0;  ///< of the group's power tau . qdot
  double peak_power_W = 0;                          ///< max |power|
};

struct BodyEvaluation {
  EvaluationBody body;
  std::string error;  ///< non-empty: this body could not be evaluated (why)
  double weight_N = 0;
  std::vector<double> times_s;
  std::vector<std::string> dof_names;
  Eigen::MatrixXd torque_Nm;  ///< frames x nv (root rows: the residual)
  Eigen::MatrixXd power_W;    ///< frames x nv
  Eigen::MatrixXd grf_N;      ///< frames x 6: left fx fy fz, right fx fy fz
  std::vector<JointEvaluation> joints;
  /// "" when none saturates; the toes are not judged (their tau_max is an estimate)
  std::string first_saturating_joint;
  double residual_force_rms_N = 0, residual_force_peak_N = 0;
  double residual_moment_rms_Nm = 0, residual_moment_peak_Nm = 0;
  double grf_peak_bw = 0;
  /// Static optimisation: muscle names, peak activations, and the reserves' share of the
  /// torques they replace (peak |reserve| / peak |tau|, over the covered DOFs).
  std::vector<std::string> muscles;
  std::vector<double> muscle_peak_activation;
  double reserve_share = 0;
  /// Physics tracking (SAMCON).
  bool tracked = false, kept_up = false;
  double fell_at_s = -1, joint_rms_deg = 0, root_max_m = 0, tracking_wall_s = 0;
  double tracking_realtime_factor = 0, peak_torque_ratio_tracked = 0;
  JointLoadReport joint_load_tracked;  ///< the tracking's joint stops beside its motors
  /// Dorsiflexion added to a foot's first pose that swings with its toes on the floor, left
  /// and right, deg (TrackedMotion::start_swing_lift_rad).
  std::array<double, 2> start_swing_lift_deg{0.0, 0.0};
  double wall_s = 0;
  /// Can this body do the motion: no joint past tau_max in ID and, if tracked, kept up without
  /// some judged joint's load (motor + range stop) above its tau_max through 50 ms or more.
  bool feasible = false;
  std::string verdict;  ///< a sentence: who can do it, what fails first
};

/// Sets `e`'s feasible flag and verdict sentence from its figures: it cannot do the motion when a
/// judged joint saturates in inverse dynamics, its tracking falls, or its tracking keeps up only
/// with some judged joint's load (motor + range stop) over tau_max through 50 ms or more.
void judge(BodyEvaluation* e);

/// Evaluates the motion at `motion_path` (a qpos CSV with its body in the header, or a BVH) on
/// every body. `work_dir` receives each body's retargeted motion (<name>/motion.csv) for the
/// tracking. Deterministic whatever the thread count. `progress(done, total)` after each body.
std::vector<BodyEvaluation> evaluate_motion(const std::string& motion_path,
                                            const std::vector<EvaluationBody>& bodies,
                                            const EvaluateOptions& options,
                                            const std::string& work_dir,
                                            const std::function<void(int, int)>& progress = {});

}  // namespace biodyn::scenarios
