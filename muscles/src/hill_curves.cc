#include "biodyn/muscles/hill_curves.h"

#include <cmath>
#include <string>

#include "biodyn/sim/errors.h"

namespace biodyn::muscles {
namespace {

void check_range(const char* where, const char* field, double value, double lo, double hi) {
  if (!(value > lo && value <= hi)) {
    throw sim::InvalidArgument(std::string(where) + ": " + field + " must be in (" +
                               std::to_string(lo) + ", " + std::to_string(hi) + "], got " +
                               std::to_string(value));
  }
}

double toe_strain(const HillCurveParams& p) {
  return kTendonToeStrainShare * p.tendon_strain_at_fmax;
}

}  // namespace

void HillCurveParams::validate(const char* where) const {
  check_range(where, "fl_width_gamma", fl_width_gamma, 0.0, 2.0);
  check_range(where, "passive_shape_kPE", passive_shape_kPE, 0.0, 20.0);
  check_range(where, "passive_strain_at_fmax", passive_strain_at_fmax, 0.0, 2.0);
  check_range(where, "tendon_strain_at_fmax", tendon_strain_at_fmax, 0.0, 0.2);
  check_range(where, "fv_shape_Af", fv_shape_Af, 0.0, 2.0);
  check_range(where, "fv_eccentric_plateau", fv_eccentric_plateau, 1.0, 2.0);
}

double active_force_length(double l_norm, const HillCurveParams& p) {
  const double x = l_norm - 1.0;
  return std::exp(-x * x / p.fl_width_gamma);
}

double active_force_length_slope(double l_norm, const HillCurveParams& p) {
  const double x = l_norm - 1.0;
  return -2.0 * x / p.fl_width_gamma * std::exp(-x * x / p.fl_width_gamma);
}

double passive_force_length(double l_norm, const HillCurveParams& p) {
  if (l_norm <= 1.0) return 0.0;
  const double k = p.passive_shape_kPE;
  return std::expm1(k * (l_norm - 1.0) / p.passive_strain_at_fmax) / std::expm1(k);
}

double passive_force_length_slope(double l_norm, const HillCurveParams& p) {
  if (l_norm <= 1.0) return 0.0;
  const double k = p.passive_shape_kPE, e0 = p.passive_strain_at_fmax;
  return k / e0 * std::exp(k * (l_norm - 1.0) / e0) / std::expm1(k);
}

double force_velocity(double v_norm, const HillCurveParams& p) {
  if (v_norm <= -1.0) return 0.0;
  if (v_norm <= 0.0) return (1.0 + v_norm) / (1.0 - v_norm / p.fv_shape_Af);
  const double c = v_norm * (2.0 + 2.0 / p.fv_shape_Af), f_len = p.fv_eccentric_plateau;
  return (c * f_len + f_len - 1.0) / (c + f_len - 1.0);
}

double force_velocity_slope(double v_norm, const HillCurveParams& p) {
  if (v_norm < -1.0) return 0.0;
  const double af = p.fv_shape_Af;
  if (v_norm < 0.0) {
    const double den = 1.0 - v_norm / af;
    return (den + (1.0 + v_norm) / af) / (den * den);
  }
  const double k = 2.0 + 2.0 / af, f_len = p.fv_eccentric_plateau;
  const double den = v_norm * k + f_len - 1.0;
  return k * (f_len - 1.0) * (f_len - 1.0) / (den * den);
}

double tendon_force_strain(double strain, const HillCurveParams& p) {
  if (strain <= 0.0) return 0.0;
  const double e_toe = toe_strain(p);
  if (strain <= e_toe) {
    return kTendonToeForce / std::expm1(kTendonToeShape) *
           std::expm1(kTendonToeShape * strain / e_toe);
  }
  return kTendonLinearStiffnessTimesEps0 / p.tendon_strain_at_fmax * (strain - e_toe) +
         kTendonToeForce;
}

double tendon_force_strain_slope(double strain, const HillCurveParams& p) {
  if (strain <= 0.0) return 0.0;
  const double e_toe = toe_strain(p);
  if (strain <= e_toe) {
    return kTendonToeForce / std::expm1(kTendonToeShape) * kTendonToeShape / e_toe *
           std::exp(kTendonToeShape * strain / e_toe);
  }
  return kTendonLinearStiffnessTimesEps0 / p.tendon_strain_at_fmax;
}

}  // namespace biodyn::muscles
