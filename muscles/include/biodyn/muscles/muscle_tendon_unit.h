#pragma once
/// One Hill-type muscle-tendon unit (MTU): first-order activation dynamics, a contractile element
/// (active force-length x force-velocity, Thelen 2003 curves: hill_curves.h), a parallel elastic
/// element, a series elastic tendon (rigid or compliant) and pennation at constant fibre
/// thickness (Zajac 1989): the fibre's height h = l_opt sin(alpha_opt) stays constant, so
/// sin(alpha) = h / l_M.
///
/// Forces act along the MTU's path; what the path is (MuJoCo spatial tendon, moment arms) is the
/// muscle set's business (muscle_set.h). Everything here is a pure function of its arguments: no
/// allocation, no exception (validate() throws, once, before a run).

#include <string>

#include "biodyn/muscles/hill_curves.h"

namespace biodyn::muscles {

/// How the tendon is modelled.
enum class TendonModel {
  /// Inextensible: l_T = l_slack, fibre kinematics follow the path's. Exact and cheap; fine when
  /// the tendon is short next to the fibres (l_slack / l_opt small).
  kRigid,
  /// Elastic (Thelen 2003 tendon curve), the fibre length a state integrated by backward Euler
  /// at the simulation step, so it is stable at any step (no step-size tweaks). Where it matters:
  /// long tendons (soleus, gastrocnemius: l_slack / l_opt 6-8).
  kCompliant,
};
const char* to_string(TendonModel model);
/// Parses "rigid" / "compliant"; throws sim::InvalidArgument naming `field` and the value.
TendonModel parse_tendon_model(const std::string& text, const std::string& field);

/// A muscle's parameters. Defaults where a published model gives one (OpenSim Thelen2003Muscle).
struct MuscleParams {
  std::string name;                     ///< e.g. "soleus_r"
  double max_isometric_force_N = 0;     ///< F_max, N, > 0
  double optimal_fiber_length_m = 0;    ///< l_opt, m, > 0
  double tendon_slack_length_m = 0;     ///< l_slack, m, > 0
  double pennation_at_optimal_rad = 0;  ///< alpha_opt, rad, in [0, 1.2]
  /// v_max in optimal fibre lengths per second; Thelen 2003: 10 (young adults). In (0, 30].
  double max_contraction_velocity_lopt_per_s = 10.0;
  /// s, activation time constant; Thelen 2003 / references.md: 15 ms. In (0, 1].
  double activation_time_constant_s = 0.015;
  /// s, deactivation time constant; Thelen 2003 / references.md: 50 ms. In (0, 1].
  double deactivation_time_constant_s = 0.050;
  /// Lowest activation (and excitation). OpenSim Thelen2003Muscle uses 0.01 to avoid its
  /// equilibrium solve's singularity at zero activation; the damped backward-Euler fibre step here
  /// has none, and a floor would pull every muscle at once. In [0, 0.5].
  double min_activation = 0.0;
  /// Fibre damping beta (force per unit normalised velocity, x F_max) in the compliant-tendon
  /// fibre balance: Millard 2012's damped equilibrium model (0.1) keeps the fibre velocity
  /// defined when the fibre is inactive and slack. Rigid tendons do not use it. In [0, 1].
  double fiber_damping = 0.1;
  TendonModel tendon = TendonModel::kRigid;
  HillCurveParams curves;

  /// Throws sim::InvalidArgument naming the muscle, the field, the rule and the value.
  void validate() const;
  /// m, fibre height l_opt sin(alpha_opt) (constant-thickness pennation).
  double fiber_height_m() const;
  /// m, the shortest fibre allowed: pennation at most acos(0.1) (OpenSim's pennation models),
  /// and at least 1% of l_opt.
  double min_fiber_length_m() const;
};

/// What a muscle is doing at one instant (forces along the path, N; lengths m; velocities m/s).
struct MuscleKinematics {
  double fiber_length_m = 0;
  double fiber_velocity_m_s = 0;  ///< negative when shortening
  double cos_pennation = 1;
  double tendon_length_m = 0;
  double active_fl = 0;       ///< f_L(l~)
  double fv = 1;              ///< f_V(v~)
  double passive_fl = 0;      ///< f_PE(l~)
  double tendon_force_N = 0;  ///< tension along the path (>= 0)
  int iterations = 0;         ///< compliant solve: Newton/bisection iterations
  bool converged = true;      ///< compliant solve: met its tolerance
};

/// Exact step of first-order activation dynamics da/dt = (u - a) / tau, tau = the activation
/// time constant when u > a, the deactivation one otherwise (OpenSim
/// FirstOrderMuscleActivationDynamics): a' = u + (a - u) exp(-dt / tau). Stable for any dt.
double activation_step(double activation, double excitation, double dt_s, const MuscleParams& p);

/// The activations reachable in one step of dt from `activation` (excitation min_activation or
/// 1): [lo, hi].
struct ActivationRange {
  double lo = 0, hi = 1;
};
ActivationRange reachable_activation(double activation, double dt_s, const MuscleParams& p);

/// The excitation that takes `activation` to `next` in one step of dt (inverse of
/// activation_step), clamped to [min_activation, 1].
double excitation_for(double activation, double next, double dt_s, const MuscleParams& p);

/// Rigid tendon: the fibre state and force at activation `a` for path length `l_mtu_m` and path
/// velocity `v_mtu_m_s` (F = F_max cos(alpha) (a f_L f_V + f_PE), >= 0).
MuscleKinematics rigid_tendon_state(const MuscleParams& p, double activation, double l_mtu_m,
                                    double v_mtu_m_s);

/// Rigid tendon, the force's affine dependence on activation at this state:
/// F(a) = active_N * a + passive_N.
struct ForceAffine {
  double active_N = 0, passive_N = 0;
};
ForceAffine rigid_tendon_affine(const MuscleParams& p, double l_mtu_m, double v_mtu_m_s);

/// Compliant tendon, one backward-Euler step of the fibre length: finds l_M at the end of the
/// step such that tendon force = fibre force along the tendon, with the fibre velocity
/// (l_M - l_M_prev) / dt, the activation `activation` and the path length `l_mtu_m` at the end of
/// the step. Safeguarded Newton on a bracket (no exception, at most kMaxFiberIterations).
/// `fiber_length_guess_m` (optional, > 0): where the solve starts (default: the previous length).
MuscleKinematics compliant_tendon_step(const MuscleParams& p, double activation,
                                       double fiber_length_prev_m, double l_mtu_m, double dt_s,
                                       double fiber_length_guess_m = 0);

/// Compliant tendon at rest: the fibre length where tendon and fibre forces balance with no
/// fibre velocity (to start a run).
double equilibrium_fiber_length(const MuscleParams& p, double activation, double l_mtu_m);

inline constexpr int kMaxFiberIterations = 60;
/// Relative force tolerance of the compliant fibre solve (x F_max).
inline constexpr double kFiberForceTolerance = 1e-10;
/// Largest pennation angle's cosine (OpenSim's pennation models: 0.1).
inline constexpr double kMinCosPennation = 0.1;

}  // namespace biodyn::muscles
