#include "biodyn/muscles/muscle_tendon_unit.h"

#include <algorithm>
#include <cmath>

#include "biodyn/sim/errors.h"

namespace biodyn::muscles {
namespace {

void check_param(const MuscleParams& p, const char* field, double value, bool ok,
                 const char* rule) {
  if (!ok) {
    throw sim::InvalidArgument("muscle " + p.name + ": " + field + " must be " + rule + ", got " +
                               std::to_string(value));
  }
}

// The compliant fibre balance g(x) = F_T(strain) - cos(alpha) * fibre force (x F_max) and its
// slope in the fibre length x (m), for backward Euler (velocity from x) or rest (velocity 0).
struct FiberBalance {
  const MuscleParams& p;
  double activation, x_prev, l_mtu,
      velocity_scale;  // velocity_scale: 1/(dt v_max l_opt), 0 at rest
  double h, l_opt, l_slack;

  struct Value {
    double g, slope;
    MuscleKinematics k;
  };

  Value operator()(double x) const {
    Value out{};
    MuscleKinematics& k = out.k;
    const double along = std::sqrt(std::max(x * x - h * h, 0.0));  // fibre projected on the path
    k.fiber_length_m = x;
    k.cos_pennation = along / x;
    k.tendon_length_m = l_mtu - along;
    const double strain = (k.tendon_length_m - l_slack) / l_slack;
    const double v_norm = (x - x_prev) * velocity_scale;
    const double l_norm = x / l_opt;
    const HillCurveParams& c = p.curves;
    k.active_fl = active_force_length(l_norm, c);
    k.fv = force_velocity(v_norm, c);
    k.passive_fl = passive_force_length(l_norm, c);
    const double fibre = activation * k.active_fl * k.fv + k.passive_fl + p.fiber_damping * v_norm;
    const double tendon = tendon_force_strain(strain, c);
    k.tendon_force_N = tendon * p.max_isometric_force_N;
    out.g = tendon - k.cos_pennation * fibre;
    const double d_tendon = -tendon_force_strain_slope(strain, c) / (k.cos_pennation * l_slack);
    const double d_cos = h * h / (x * x * x) / k.cos_pennation;
    const double d_fibre =
        activation * (active_force_length_slope(l_norm, c) / l_opt * k.fv +
                      k.active_fl * force_velocity_slope(v_norm, c) * velocity_scale) +
        passive_force_length_slope(l_norm, c) / l_opt + p.fiber_damping * velocity_scale;
    out.slope = d_tendon - d_cos * fibre - k.cos_pennation * d_fibre;
    return out;
  }
};

// Root of the balance on [l_min, max(x_prev, slack fibre length)]: g > 0 below the root (tendon
// stretched or fibre shortening too fast), g <= 0 at the top (tendon slack, fibre not shortening).
MuscleKinematics solve_fiber(const FiberBalance& balance, double x_start) {
  const MuscleParams& p = balance.p;
  const double slack_along = std::max(balance.l_mtu - balance.l_slack, 0.0);
  const double l_min = p.min_fiber_length_m();
  double lo = l_min;
  double hi =
      std::max({std::sqrt(slack_along * slack_along + balance.h * balance.h), balance.x_prev, lo}) *
      (1.0 + 1e-12);
  double x = std::clamp(x_start, lo, hi);
  FiberBalance::Value v = balance(x);
  // g decreases with x: the root lies above x if g(x) > 0; below it only if g(l_min) > 0, else
  // the fibre sits at its minimum length (checked only when the root is below the start).
  if (v.g <= 0.0 && x > l_min) {
    FiberBalance::Value at_lo = balance(l_min);
    if (at_lo.g <= 0.0) {
      at_lo.k.iterations = 2;
      return at_lo.k;
    }
  }
  int it = 1;
  for (; it < kMaxFiberIterations; ++it) {
    if (std::abs(v.g) <= kFiberForceTolerance) break;
    (v.g > 0.0 ? lo : hi) = x;
    if (hi - lo <= 1e-14 * p.optimal_fiber_length_m) break;
    double next = v.slope < 0.0 ? x - v.g / v.slope : 0.5 * (lo + hi);
    if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);  // Newton left the bracket: bisect
    x = next;
    v = balance(x);
  }
  v.k.iterations = it;
  v.k.converged =
      std::abs(v.g) <= kFiberForceTolerance || hi - lo <= 1e-12 * p.optimal_fiber_length_m;
  return v.k;
}

}  // namespace

const char* to_string(TendonModel model) {
  return model == TendonModel::kRigid ? "rigid" : "compliant";
}

TendonModel parse_tendon_model(const std::string& text, const std::string& field) {
  if (text == "rigid") return TendonModel::kRigid;
  if (text == "compliant") return TendonModel::kCompliant;
  throw sim::InvalidArgument(field + ": must be rigid or compliant, got '" + text + "'");
}

void MuscleParams::validate() const {
  check_param(*this, "max_isometric_force_N", max_isometric_force_N,
              max_isometric_force_N > 0 && std::isfinite(max_isometric_force_N), "finite and > 0");
  check_param(*this, "optimal_fiber_length_m", optimal_fiber_length_m,
              optimal_fiber_length_m > 0 && optimal_fiber_length_m < 1, "in (0, 1)");
  check_param(*this, "tendon_slack_length_m", tendon_slack_length_m,
              tendon_slack_length_m > 0 && tendon_slack_length_m < 2, "in (0, 2)");
  check_param(*this, "pennation_at_optimal_rad", pennation_at_optimal_rad,
              pennation_at_optimal_rad >= 0 && pennation_at_optimal_rad <= 1.2, "in [0, 1.2]");
  check_param(*this, "max_contraction_velocity_lopt_per_s", max_contraction_velocity_lopt_per_s,
              max_contraction_velocity_lopt_per_s > 0 && max_contraction_velocity_lopt_per_s <= 30,
              "in (0, 30]");
  check_param(*this, "activation_time_constant_s", activation_time_constant_s,
              activation_time_constant_s > 0 && activation_time_constant_s <= 1, "in (0, 1]");
  check_param(*this, "deactivation_time_constant_s", deactivation_time_constant_s,
              deactivation_time_constant_s > 0 && deactivation_time_constant_s <= 1, "in (0, 1]");
  check_param(*this, "min_activation", min_activation, min_activation >= 0 && min_activation <= 0.5,
              "in [0, 0.5]");
  check_param(*this, "fiber_damping", fiber_damping, fiber_damping >= 0 && fiber_damping <= 1,
              "in [0, 1]");
  curves.validate(("muscle " + name).c_str());
}

double MuscleParams::fiber_height_m() const {
  return optimal_fiber_length_m * std::sin(pennation_at_optimal_rad);
}

double MuscleParams::min_fiber_length_m() const {
  const double h = fiber_height_m();
  return std::max(h / std::sqrt(1.0 - kMinCosPennation * kMinCosPennation),
                  0.01 * optimal_fiber_length_m);
}

double activation_step(double activation, double excitation, double dt_s, const MuscleParams& p) {
  const double u = std::clamp(excitation, p.min_activation, 1.0);
  const double tau = u > activation ? p.activation_time_constant_s : p.deactivation_time_constant_s;
  return u + (activation - u) * std::exp(-dt_s / tau);
}

ActivationRange reachable_activation(double activation, double dt_s, const MuscleParams& p) {
  return {activation_step(activation, p.min_activation, dt_s, p),
          activation_step(activation, 1.0, dt_s, p)};
}

double excitation_for(double activation, double next, double dt_s, const MuscleParams& p) {
  const double tau =
      next > activation ? p.activation_time_constant_s : p.deactivation_time_constant_s;
  const double decay = std::exp(-dt_s / tau);
  return std::clamp((next - activation * decay) / (1.0 - decay), p.min_activation, 1.0);
}

MuscleKinematics rigid_tendon_state(const MuscleParams& p, double activation, double l_mtu_m,
                                    double v_mtu_m_s) {
  MuscleKinematics k;
  const double h = p.fiber_height_m();
  const double l_min = p.min_fiber_length_m();
  const double along =
      std::max(l_mtu_m - p.tendon_slack_length_m, std::sqrt(std::max(l_min * l_min - h * h, 0.0)));
  k.fiber_length_m = std::sqrt(along * along + h * h);
  k.cos_pennation = along / k.fiber_length_m;
  k.tendon_length_m = p.tendon_slack_length_m;
  k.fiber_velocity_m_s = v_mtu_m_s * k.cos_pennation;
  const double l_norm = k.fiber_length_m / p.optimal_fiber_length_m;
  const double v_norm =
      k.fiber_velocity_m_s / (p.max_contraction_velocity_lopt_per_s * p.optimal_fiber_length_m);
  k.active_fl = active_force_length(l_norm, p.curves);
  k.fv = force_velocity(v_norm, p.curves);
  k.passive_fl = passive_force_length(l_norm, p.curves);
  k.tendon_force_N =
      p.max_isometric_force_N * k.cos_pennation * (activation * k.active_fl * k.fv + k.passive_fl);
  return k;
}

ForceAffine rigid_tendon_affine(const MuscleParams& p, double l_mtu_m, double v_mtu_m_s) {
  const MuscleKinematics k = rigid_tendon_state(p, 1.0, l_mtu_m, v_mtu_m_s);
  const double scale = p.max_isometric_force_N * k.cos_pennation;
  return {scale * k.active_fl * k.fv, scale * k.passive_fl};
}

MuscleKinematics compliant_tendon_step(const MuscleParams& p, double activation,
                                       double fiber_length_prev_m, double l_mtu_m, double dt_s,
                                       double fiber_length_guess_m) {
  const FiberBalance balance{
      p,
      activation,
      fiber_length_prev_m,
      l_mtu_m,
      1.0 / (dt_s * p.max_contraction_velocity_lopt_per_s * p.optimal_fiber_length_m),
      p.fiber_height_m(),
      p.optimal_fiber_length_m,
      p.tendon_slack_length_m};
  MuscleKinematics k =
      solve_fiber(balance, fiber_length_guess_m > 0 ? fiber_length_guess_m : fiber_length_prev_m);
  k.fiber_velocity_m_s = (k.fiber_length_m - fiber_length_prev_m) / dt_s;
  return k;
}

double equilibrium_fiber_length(const MuscleParams& p, double activation, double l_mtu_m) {
  const double h = p.fiber_height_m();
  const FiberBalance balance{p,   activation, p.min_fiber_length_m(),   l_mtu_m,
                             0.0, h,          p.optimal_fiber_length_m, p.tendon_slack_length_m};
  const double along = std::max(l_mtu_m - p.tendon_slack_length_m, 0.0);
  return solve_fiber(balance, std::sqrt(along * along + h * h)).fiber_length_m;
}

}  // namespace biodyn::muscles
