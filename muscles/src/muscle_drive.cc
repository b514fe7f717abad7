#include "biodyn/muscles/muscle_drive.h"

#include <algorithm>
#include <cmath>
#include <iterator>
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

MuscleDrive::Group::Group(const MuscleSet& set, std::vector<int> muscle_ids,
                          std::vector<int> row_ids)
    : muscles(std::move(muscle_ids)),
      rows(std::move(row_ids)),
      rows_of_muscle(muscles.size()),
      qp(static_cast<int>(muscles.size())),
      B(Eigen::MatrixXd::Zero(static_cast<int>(rows.size()), static_cast<int>(muscles.size()))),
      H(Eigen::MatrixXd::Identity(static_cast<int>(muscles.size()),
                                  static_cast<int>(muscles.size()))),
      g(Eigen::VectorXd::Zero(static_cast<int>(muscles.size()))),
      c(Eigen::VectorXd::Zero(static_cast<int>(rows.size()))),
      x(Eigen::VectorXd::Zero(static_cast<int>(muscles.size()))),
      lo(Eigen::VectorXd::Zero(static_cast<int>(muscles.size()))),
      hi(Eigen::VectorXd::Zero(static_cast<int>(muscles.size()))),
      bounds(muscles.size(), 0) {
  for (std::size_t r = 0; r < rows.size(); ++r) {
    const std::vector<int>& on_row = set.muscles_of_dof()[static_cast<std::size_t>(rows[r])];
    for (std::size_t a = 0; a < muscles.size(); ++a) {
      if (std::find(on_row.begin(), on_row.end(), muscles[a]) != on_row.end())
        rows_of_muscle[a].push_back(static_cast<int>(r));
    }
  }
  for (std::size_t a = 0; a < muscles.size(); ++a) {
    for (std::size_t b = 0; b <= a; ++b) {
      const std::size_t begin = pair_rows.size();
      std::set_intersection(rows_of_muscle[a].begin(), rows_of_muscle[a].end(),
                            rows_of_muscle[b].begin(), rows_of_muscle[b].end(),
                            std::back_inserter(pair_rows));
      if (pair_rows.size() == begin) continue;
      pair_a.push_back(static_cast<int>(a));
      pair_b.push_back(static_cast<int>(b));
      pair_rows_begin.push_back(static_cast<int>(begin));
    }
  }
  pair_rows_begin.push_back(static_cast<int>(pair_rows.size()));
}

namespace {

// Connected components of the muscle-DOF graph: muscles that share a DOF share a QP.
std::vector<std::pair<std::vector<int>, std::vector<int>>> independent_groups(
    const MuscleSet& set) {
  const int n = set.size(), k = static_cast<int>(set.covered_dofs().size());
  std::vector<int> group_of_muscle(static_cast<std::size_t>(n), -1);
  std::vector<std::pair<std::vector<int>, std::vector<int>>> groups;
  for (int seed = 0; seed < n; ++seed) {
    if (group_of_muscle[static_cast<std::size_t>(seed)] >= 0) continue;
    const int id = static_cast<int>(groups.size());
    groups.emplace_back();
    std::vector<int> todo = {seed};
    group_of_muscle[static_cast<std::size_t>(seed)] = id;
    std::vector<char> row_taken(static_cast<std::size_t>(k), 0);
    while (!todo.empty()) {
      const int i = todo.back();
      todo.pop_back();
      groups.back().first.push_back(i);
      for (int row = 0; row < k; ++row) {
        const std::vector<int>& on_row = set.muscles_of_dof()[static_cast<std::size_t>(row)];
        if (std::find(on_row.begin(), on_row.end(), i) == on_row.end()) continue;
        if (!row_taken[static_cast<std::size_t>(row)]) {
          row_taken[static_cast<std::size_t>(row)] = 1;
          groups.back().second.push_back(row);
        }
        for (int j : on_row) {
          if (group_of_muscle[static_cast<std::size_t>(j)] < 0) {
            group_of_muscle[static_cast<std::size_t>(j)] = id;
            todo.push_back(j);
          }
        }
      }
    }
    std::sort(groups.back().first.begin(), groups.back().first.end());
    std::sort(groups.back().second.begin(), groups.back().second.end());
  }
  return groups;
}

}  // namespace

MuscleDrive::MuscleDrive(const mjModel& m, MuscleSet set, const std::vector<double>& tau_max_Nm,
                         MuscleDriveParams params)
    : set_(std::move(set)), params_(params) {
  params_.validate();
  const int n = set_.size(), k = static_cast<int>(set_.covered_dofs().size());
  for (auto& [muscle_ids, row_ids] : independent_groups(set_))
    groups_.emplace_back(set_, std::move(muscle_ids), std::move(row_ids));
  R_.setZero(k, n);
  A_.setZero(n);
  P_.setZero(n);
  lo_.setZero(n);
  hi_.setZero(n);
  x_.setZero(n);
  tension_.setZero(n);
  fiber_guess_.setZero(n);
  MuscleDriveState& s = state_;
  s.qp_bounds.assign(static_cast<std::size_t>(n), 0);
  s.fiber_slope_m.assign(static_cast<std::size_t>(n), 0.0);
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
  // Per group: minimise sum a^2 + w |c - B a|^2 with B = R diag(A), c = tau_w - R P (forces
  // F = A a + P), warm-started from the last step's active set.
  const double w = params_.backup_weight_per_Nm2;
  for (Group& grp : groups_) {
    const int n = static_cast<int>(grp.muscles.size()), k = static_cast<int>(grp.rows.size());
    for (int r = 0; r < k; ++r) {
      const int row = grp.rows[static_cast<std::size_t>(r)];
      grp.c(r) = tau_wanted_Nm[set_.covered_dofs()[static_cast<std::size_t>(row)]];
    }
    for (int a = 0; a < n; ++a) {
      const int i = grp.muscles[static_cast<std::size_t>(a)];
      for (int r : grp.rows_of_muscle[static_cast<std::size_t>(a)]) {
        const int row = grp.rows[static_cast<std::size_t>(r)];
        grp.c(r) -= R_(row, i) * P_(i);
        grp.B(r, a) = R_(row, i) * A_(i);
      }
    }
    // H = I + w B'B, g = -w B'c over B's structure (the other entries are exact zeros).
    for (std::size_t p = 0; p + 1 < grp.pair_rows_begin.size(); ++p) {
      const int a = grp.pair_a[p], b = grp.pair_b[p];
      double sum = 0;
      for (int q = grp.pair_rows_begin[p]; q < grp.pair_rows_begin[p + 1]; ++q) {
        const int r = grp.pair_rows[static_cast<std::size_t>(q)];
        sum += grp.B(r, a) * grp.B(r, b);
      }
      grp.H(a, b) = grp.H(b, a) = w * sum + (a == b ? 1.0 : 0.0);
    }
    for (int a = 0; a < n; ++a) {
      double sum = 0;
      for (int r : grp.rows_of_muscle[static_cast<std::size_t>(a)]) sum += grp.B(r, a) * grp.c(r);
      grp.g(a) = -w * sum;
    }
    for (int a = 0; a < n; ++a) {
      const auto i = static_cast<std::size_t>(grp.muscles[static_cast<std::size_t>(a)]);
      grp.x(a) = state_.activation[i];
      grp.lo(a) = lo(static_cast<int>(i));
      grp.hi(a) = hi(static_cast<int>(i));
      grp.bounds[static_cast<std::size_t>(a)] = state_.qp_bounds[i];
    }
    const BoxQpResult r = grp.qp.solve(grp.H, grp.g, grp.lo, grp.hi, &grp.x, grp.bounds.data());
    if (!r.converged) ++pending_.qp_failures;
    for (int a = 0; a < n; ++a) {
      const auto i = static_cast<std::size_t>(grp.muscles[static_cast<std::size_t>(a)]);
      x_(static_cast<int>(i)) = grp.x(a);
      pending_.qp_bounds[i] = grp.qp.bound(a);
    }
  }
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
  // Each muscle's force at the end of the step, affine in the activation it can reach.
  for (int i = 0; i < n; ++i) {
    const MuscleParams& p = set_.params(i);
    const auto ii = static_cast<std::size_t>(i);
    const ActivationRange reach = reachable_activation(state_.activation[ii], dt, p);
    lo_(i) = reach.lo;
    hi_(i) = reach.hi;
    if (p.tendon == TendonModel::kRigid) {
      // F = A a + P exactly at this state: the fibre's kinematics follow the path's.
      const MuscleKinematics kin =
          rigid_tendon_state(p, 0.0, set_.length(d, i), set_.velocity(d, i));
      const double scale = p.max_isometric_force_N * kin.cos_pennation;
      A_(i) = scale * kin.active_fl * kin.fv;
      P_(i) = scale * kin.passive_fl;
      pending_.fiber_length_m[ii] = kin.fiber_length_m;
      pending_.fiber_velocity_m_s[ii] = kin.fiber_velocity_m_s;
    } else {
      // The backward-Euler fibre step at both ends of the reachable activations, interpolated:
      // the tendon force this step can give (CMC's one-step look-ahead).
      const double l_next = set_.length(d, i) + dt * set_.velocity(d, i);
      // Both solves start where the last step's secant says the fibre goes at that activation.
      const double x_prev = state_.fiber_length_m[ii], slope = state_.fiber_slope_m[ii];
      const double a_prev = state_.activation[ii];
      const MuscleKinematics at_lo = compliant_tendon_step(p, reach.lo, x_prev, l_next, dt,
                                                           x_prev + slope * (reach.lo - a_prev));
      const MuscleKinematics at_hi = compliant_tendon_step(p, reach.hi, x_prev, l_next, dt,
                                                           x_prev + slope * (reach.hi - a_prev));
      const double span = reach.hi - reach.lo;
      A_(i) = span > 0 ? (at_hi.tendon_force_N - at_lo.tendon_force_N) / span : 0.0;
      P_(i) = at_lo.tendon_force_N - A_(i) * reach.lo;
      const double secant = span > 0 ? (at_hi.fiber_length_m - at_lo.fiber_length_m) / span : 0.0;
      pending_.fiber_slope_m[ii] = secant;
      fiber_guess_(i) = at_lo.fiber_length_m - secant * reach.lo;
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
      tension_(i) = A_(i) * a + P_(i);
    } else {
      // Backward Euler to the path's length at the end of the step (l + dt v), from the
      // tangent's prediction.
      const double l_next = set_.length(d, i) + dt * set_.velocity(d, i);
      const MuscleKinematics kin =
          compliant_tendon_step(p, a, state_.fiber_length_m[ii], l_next, dt,
                                fiber_guess_(i) + pending_.fiber_slope_m[ii] * a);
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
