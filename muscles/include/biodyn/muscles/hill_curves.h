#pragma once
/// The Hill-type muscle curves of Thelen (2003), "Adjustment of muscle mechanics model parameters
/// to simulate dynamic contractions in older adults", J Biomech Eng 125:70-77 (OpenSim's
/// Thelen2003Muscle), as pure functions of normalised quantities.
///
/// Why Thelen 2003 (and not Millard 2012 or De Groote 2016): its shortening force-velocity curve
/// is Hill's hyperbola exactly, zero at -v_max; its eccentric branch rises to a plateau (F_len);
/// its active force-length curve is exactly 1 at the optimal length; every curve has a closed
/// form with published defaults (references.md), so a test can recompute them independently.
/// Millard's curves are quintic Béziers fitted to the same data, and De Groote's are smooth fits
/// whose force-length peak is 0.9993 and whose force-velocity is 0.012 at -v_max.
///
/// Normalised quantities: fibre length l~ = l_M / l_opt (1 = optimal), fibre velocity
/// v~ = v_M / v_max (v_max in l_opt/s; negative = shortening), tendon strain
/// eps = (l_T - l_slack) / l_slack, forces in units of F_max.

namespace biodyn::muscles {

/// Curve parameters, Thelen 2003 (OpenSim Thelen2003Muscle defaults, references.md).
struct HillCurveParams {
  /// Width of the active force-length Gaussian exp(-(l~-1)^2 / gamma); Thelen 2003: 0.45
  /// (force 0.5 at l~ = 1 +- 0.56). Bounds (0, 2].
  double fl_width_gamma = 0.45;
  /// Passive exponential shape factor k_PE; Thelen 2003: 5 (older adults 4). Bounds (0, 20].
  double passive_shape_kPE = 5.0;
  /// Passive fibre strain at which the passive force is F_max; Thelen 2003: 0.6 (young).
  /// Bounds (0, 2].
  double passive_strain_at_fmax = 0.6;
  /// Tendon strain at F_max; Thelen 2003 / OpenSim: 0.04 (Zajac 1989: 0.033). Bounds (0, 0.2].
  double tendon_strain_at_fmax = 0.04;
  /// Force-velocity shape factor A_f (Hill's a/F_max); Thelen 2003: 0.25. Bounds (0, 2].
  double fv_shape_Af = 0.25;
  /// Eccentric plateau F_len, force at large lengthening velocity; Thelen 2003: 1.4 (1.8 in
  /// some later models). Bounds (1, 2].
  double fv_eccentric_plateau = 1.4;

  /// Throws sim::InvalidArgument naming the field, the bounds and the value; `where` prefixes
  /// the message (e.g. "muscle soleus_l").
  void validate(const char* where = "muscle curves") const;
};

/// Active force-length multiplier f_L(l~) = exp(-(l~-1)^2/gamma), Thelen 2003 eq. 3. In (0, 1],
/// 1 at l~ = 1. l~ dimensionless (> 0).
double active_force_length(double l_norm, const HillCurveParams& p);
/// d f_L / d l~.
double active_force_length_slope(double l_norm, const HillCurveParams& p);

/// Passive force-length f_PE(l~) = (exp(kPE (l~-1)/eps0) - 1) / (exp(kPE) - 1) for l~ > 1,
/// 0 for a slack fibre (l~ <= 1; Thelen's formula would go negative: a fibre does not push),
/// Thelen 2003 eq. 2. 1 at l~ = 1 + eps0.
double passive_force_length(double l_norm, const HillCurveParams& p);
/// d f_PE / d l~.
double passive_force_length_slope(double l_norm, const HillCurveParams& p);

/// Force-velocity multiplier f_V(v~), Thelen 2003 eq. 6 solved for force (v_max fixed; the
/// paper's activation-dependent v_max is left out so the curve is a pure function of v~):
///   v~ <= -1: 0 (faster than v_max, no force);
///   -1 < v~ <= 0 (shortening): Hill's hyperbola (1 + v~) / (1 - v~/A_f);
///   v~ > 0 (lengthening): (c F_len + F_len - 1) / (c + F_len - 1), c = v~ (2 + 2/A_f),
///   rising from 1 with twice the shortening slope at 0 to the plateau F_len.
double force_velocity(double v_norm, const HillCurveParams& p);
/// d f_V / d v~ (one-sided at 0 and -1: the lengthening side at 0).
double force_velocity_slope(double v_norm, const HillCurveParams& p);

/// Tendon force-strain F_T(eps), Thelen 2003 eq. 4: exponential toe region up to
/// eps_toe = 0.609 eps0 (F_toe = 0.33, k_toe = 3), then linear with stiffness 1.712/eps0; 0 for
/// a slack tendon (eps <= 0). F_T(eps0) = 0.9994.
double tendon_force_strain(double strain, const HillCurveParams& p);
/// d F_T / d eps.
double tendon_force_strain_slope(double strain, const HillCurveParams& p);

/// Thelen 2003 tendon constants (eq. 4).
inline constexpr double kTendonToeForce = 0.33;
inline constexpr double kTendonToeShape = 3.0;
inline constexpr double kTendonToeStrainShare = 0.609;  ///< eps_toe / eps0
inline constexpr double kTendonLinearStiffnessTimesEps0 = 1.712;

}  // namespace biodyn::muscles
