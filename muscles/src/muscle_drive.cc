#include "biodyn/muscles/muscle_drive.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "biodyn/sim/errors.h"
#include "biodyn/sim/model.h"

namespace biodyn::muscles {

void MuscleDriveParams::validate() const {
  if (!(backup_weight_per_Nm2 > 0 && std::isfinite(backup_weight_per_Nm2))) {
    throw sim::InvalidArgument("muscle drive: backup_weight_per_Nm2 must be > 0, got " +
                               std::to_string(backup_weight_per_Nm2));
  }
  if (!(min_backup_share >= 0 && min_backup_share <= 1)) {
    throw sim::InvalidArgument("muscle drive: min_backup_share must be in [0, 1], got " +
                               std::to_string(min_backup_share));
  }
}

MuscleDrive::MuscleDrive(const mjModel& m, MuscleSet set, const std::vector<double>& tau_max_Nm,
                         MuscleDriveParams params)
    : set_(std::move(set)), params_(params), qp_(set_.size()) {
  params_.validate();
  const int n = set_.size(), k = static_cast<int>(set_.covered_dofs().size());
  R_.setZero(k, n);
  B_.setZero(k, n);
  H_.setZero(n, n);
  A_.setZero(n);
  P_.setZero(n);
  lo_.setZero(n);
  hi_.setZero(n);
  g_.setZero(n);
  c_.setZero(k);
  x_.setZero(n);
  tension_.setZero(n);
  MuscleDriveState& s = state_;
  for (auto* v :
       {&s.activation, &s.excitation, &s.fiber_length_m, &s.fiber_velocity_m_s, &s.tension_N})
    v->assign(static_cast<std::size_t>(n), 0.0);
  for (auto* v : {&s.muscle_torque_Nm, &s.backup_torque_Nm, &s.wanted_torque_Nm,
                  &s.muscle_impulse_Nms, &s.backup_impulse_Nms, &s.missing_impulse_Nms})
    v->assign(static_cast<std::size_t>(k), 0.0);
  pending_ = state_;

  // The backups' ranges from the muscles' capacity in the standing pose (the model's qpos0).
  sim::Data standing(m);
  mj_forward(&m, standing.get());
  set_.moment_arms(m, *standing, &R_);
  backup_lo_.assign(static_cast<std::size_t>(k), 0.0);
  backup_hi_.assign(static_cast<std::size_t>(k), 0.0);
  for (int row = 0; row < k; ++row) {
    double up = 0, down = 0;
    for (int i = 0; i < n; ++i) {
      const double f = set_.params(i).max_isometric_force_N;
      up += f * std::max(0.0, R_(row, i));
      down += f * std::max(0.0, -R_(row, i));
    }
    const double tau_max = tau_max_Nm[static_cast<std::size_t>(set_.covered_dofs()[row])];
    const auto range = [&](double capacity) {
      return tau_max * std::max(params_.min_backup_share, 1.0 - std::min(1.0, capacity / tau_max));
    };
    backup_hi_[static_cast<std::size_t>(row)] = tau_max > 0 ? range(up) : 0.0;
    backup_lo_[static_cast<std::size_t>(row)] = tau_max > 0 ? range(down) : 0.0;
  }
}

void MuscleDrive::share(const double* tau_wanted_Nm, const Eigen::VectorXd& lo,
                        const Eigen::VectorXd& hi) {
  // minimise sum a^2 + w |c - B a|^2 with B = R diag(A), c = tau_w - R P (forces F = A a + P).
  const int n = set_.size(), k = static_cast<int>(set_.covered_dofs().size());
  const double w = params_.backup_weight_per_Nm2;
  for (int row = 0; row < k; ++row) {
    double c = tau_wanted_Nm[set_.covered_dofs()[static_cast<std::size_t>(row)]];
    for (int i = 0; i < n; ++i) c -= R_(row, i) * P_(i);
    c_(row) = c;
  }
  B_.noalias() = R_ * A_.asDiagonal();
  H_.noalias() = w * B_.transpose() * B_;
  H_.diagonal().array() += 1.0;
  g_.noalias() = -w * B_.transpose() * c_;
  for (int i = 0; i < n; ++i) x_(i) = state_.activation[static_cast<std::size_t>(i)];
  const BoxQpResult r = qp_.solve(H_, g_, lo, hi, &x_);
  if (!r.converged) ++pending_.qp_failures;
}

void MuscleDrive::reset(const mjModel& m, const mjData& d, const double* tau_hold_Nm) {
  const int n = set_.size();
  state_.steps = 0;
  set_.moment_arms(m, d, &R_);
  for (int i = 0; i < n; ++i) {
    const MuscleParams& p = set_.params(i);
    const ForceAffine f = rigid_tendon_affine(p, set_.length(d, i), 0.0);
    A_(i) = f.active_N;
    P_(i) = f.passive_N;
    lo_(i) = p.min_activation;
    hi_(i) = 1.0;
    state_.activation[static_cast<std::size_t>(i)] = p.min_activation;
  }
  pending_ = state_;
  share(tau_hold_Nm, lo_, hi_);
  for (int i = 0; i < n; ++i) {
    const MuscleParams& p = set_.params(i);
    const auto ii = static_cast<std::size_t>(i);
    state_.activation[ii] = state_.excitation[ii] = x_(i);
    const double l = set_.length(d, i);
    state_.fiber_length_m[ii] = p.tendon == TendonModel::kCompliant
                                    ? equilibrium_fiber_length(p, x_(i), l)
                                    : rigid_tendon_state(p, x_(i), l, 0.0).fiber_length_m;
  }
  for (auto* v :
       {&state_.muscle_impulse_Nms, &state_.backup_impulse_Nms, &state_.missing_impulse_Nms})
    std::fill(v->begin(), v->end(), 0.0);
  state_.qp_failures = state_.fiber_failures = 0;
  pending_ = state_;
}

void MuscleDrive::compute(const mjModel& m, const mjData& d, const double* tau_wanted_Nm,
                          double* qfrc) {
  const int n = set_.size(), k = static_cast<int>(set_.covered_dofs().size());
  const double dt = m.opt.timestep;
  pending_ = state_;
  set_.moment_arms(m, d, &R_);
  // The force each muscle would give at either end of the activations it can reach this step.
  for (int i = 0; i < n; ++i) {
    const MuscleParams& p = set_.params(i);
    const auto ii = static_cast<std::size_t>(i);
    const ActivationRange reach = reachable_activation(state_.activation[ii], dt, p);
    lo_(i) = reach.lo;
    hi_(i) = reach.hi;
    if (p.tendon == TendonModel::kRigid) {
      const ForceAffine f = rigid_tendon_affine(p, set_.length(d, i), set_.velocity(d, i));
      A_(i) = f.active_N;
      P_(i) = f.passive_N;
    } else {
      // The backward-Euler fibre step at both ends of the reachable activations, interpolated:
      // the tendon force this step can give (CMC's one-step look-ahead).
      const double l_next = set_.length(d, i) + dt * set_.velocity(d, i);
      const double f_lo =
          compliant_tendon_step(p, reach.lo, state_.fiber_length_m[ii], l_next, dt).tendon_force_N;
      const double f_hi =
          compliant_tendon_step(p, reach.hi, state_.fiber_length_m[ii], l_next, dt).tendon_force_N;
      A_(i) = reach.hi > reach.lo ? (f_hi - f_lo) / (reach.hi - reach.lo) : 0.0;
      P_(i) = f_lo - A_(i) * reach.lo;
    }
  }
  share(tau_wanted_Nm, lo_, hi_);
  // The Hill forces at the chosen activations act.
  for (int i = 0; i < n; ++i) {
    const MuscleParams& p = set_.params(i);
    const auto ii = static_cast<std::size_t>(i);
    const double a = x_(i);
    pending_.excitation[ii] = excitation_for(state_.activation[ii], a, dt, p);
    pending_.activation[ii] = a;
    if (p.tendon == TendonModel::kRigid) {
      const MuscleKinematics kin = rigid_tendon_state(p, a, set_.length(d, i), set_.velocity(d, i));
      tension_(i) = kin.tendon_force_N;
      pending_.fiber_length_m[ii] = kin.fiber_length_m;
      pending_.fiber_velocity_m_s[ii] = kin.fiber_velocity_m_s;
    } else {
      // Backward Euler to the path's length at the end of the step (l + dt v).
      const double l_next = set_.length(d, i) + dt * set_.velocity(d, i);
      const MuscleKinematics kin =
          compliant_tendon_step(p, a, state_.fiber_length_m[ii], l_next, dt);
      if (!kin.converged) ++pending_.fiber_failures;
      tension_(i) = kin.tendon_force_N;
      pending_.fiber_length_m[ii] = kin.fiber_length_m;
      pending_.fiber_velocity_m_s[ii] = kin.fiber_velocity_m_s;
    }
    pending_.tension_N[ii] = tension_(i);
  }
  // Muscle torques through the tendons, then the backups within their range.
  for (int row = 0; row < k; ++row) qfrc[set_.covered_dofs()[static_cast<std::size_t>(row)]] = 0;
  set_.add_generalized_force(R_, tension_.data(), qfrc);
  for (int row = 0; row < k; ++row) {
    const auto r = static_cast<std::size_t>(row);
    const int dof = set_.covered_dofs()[r];
    const double wanted = tau_wanted_Nm[dof], muscle = qfrc[dof];
    const double backup = std::clamp(wanted - muscle, -backup_lo_[r], backup_hi_[r]);
    qfrc[dof] = muscle + backup;
    pending_.wanted_torque_Nm[r] = wanted;
    pending_.muscle_torque_Nm[r] = muscle;
    pending_.backup_torque_Nm[r] = backup;
    pending_.muscle_impulse_Nms[r] += std::abs(muscle) * dt;
    pending_.backup_impulse_Nms[r] += std::abs(backup) * dt;
    pending_.missing_impulse_Nms[r] += std::abs(wanted - muscle - backup) * dt;
  }
  ++pending_.steps;
}

}  // namespace biodyn::muscles
