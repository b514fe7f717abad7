#include "biodyn/sim/hybrid_dynamics.h"

#include <algorithm>
#include <cmath>

#include "biodyn/sim/queries.h"

namespace biodyn::sim {
namespace {

enum Mode : std::uint8_t { kPrescribedAcc, kZeroForce, kAtMin, kAtMax };

// In-place Cholesky of the n x n row-major SPD matrix A (lower triangle). False if not SPD.
bool cholesky(mjtNum* A, int n) {
  for (int j = 0; j < n; ++j) {
    mjtNum d = A[j * n + j];
    for (int k = 0; k < j; ++k) d -= A[j * n + k] * A[j * n + k];
    if (!(d > 0)) return false;
    const mjtNum l = std::sqrt(d);
    A[j * n + j] = l;
    for (int i = j + 1; i < n; ++i) {
      mjtNum s = A[i * n + j];
      for (int k = 0; k < j; ++k) s -= A[i * n + k] * A[j * n + k];
      A[i * n + j] = s / l;
    }
  }
  return true;
}

// Solves L L' x = rhs in place (x overwrites rhs).
void cholesky_solve(const mjtNum* L, int n, mjtNum* x) {
  for (int i = 0; i < n; ++i) {
    mjtNum s = x[i];
    for (int k = 0; k < i; ++k) s -= L[i * n + k] * x[k];
    x[i] = s / L[i * n + i];
  }
  for (int i = n - 1; i >= 0; --i) {
    mjtNum s = x[i];
    for (int k = i + 1; k < n; ++k) s -= L[k * n + i] * x[k];
    x[i] = s / L[i * n + i];
  }
}

}  // namespace

HybridDynamics::HybridDynamics(const mjModel& m, HybridDynamicsOptions options)
    : options_(options), nv_(m.nv) {
  const auto nv = static_cast<std::size_t>(m.nv);
  // Sparse rows are expanded once per solve: the Hessian reads rows restricted to the
  // unknowns, which is simplest on dense rows (nefc x nv, small next to the solve).
  if (mj_isSparse(&m)) J_dense_.resize(static_cast<std::size_t>(std::max(m.njmax, 1)) * nv);
  M_.resize(nv * nv);
  b_.resize(nv);
  a_.resize(nv);
  trial_.resize(nv);
  Ma_.resize(nv);
  jar_.resize(static_cast<std::size_t>(std::max(m.njmax, 1)));
  fixed_.resize(nv);
  unknown_.reserve(nv);
  mode_.resize(nv);
  H_.resize(nv * nv);
  g_.resize(nv);
  step_.resize(nv);
  row_.resize(nv);
  cone_rows_.resize(static_cast<std::size_t>(6 * nv));
  desired_.resize(nv);
  const auto ne_max = static_cast<std::size_t>(6 * std::max(m.neq, 1));
  eq_lhs_.resize(ne_max * ne_max);
  eq_rhs_.resize(ne_max);
  eq_rows_.reserve(ne_max);
}

void HybridDynamics::project_on_equalities(const mjData& d, const std::uint8_t* actuated,
                                           const mjtNum* qacc_desired) {
  // Root DOFs are nearly free to change: inverse weight 1e6 against 1 for actuated DOFs.
  constexpr double kRootInverseWeight = 1e6;
  eq_rows_.clear();
  for (int r = 0; r < d.nefc && eq_rows_.size() < eq_rhs_.size(); ++r)
    if (d.efc_type[r] == mjCNSTR_EQUALITY) eq_rows_.push_back(r);
  for (int i = 0; i < nv_; ++i)
    desired_[static_cast<std::size_t>(i)] = actuated[i] ? qacc_desired[i] : d.qacc_warmstart[i];
  const int n = static_cast<int>(eq_rows_.size());
  if (n == 0) return;
  const auto inv_w = [&](int i) { return actuated[i] ? 1.0 : kRootInverseWeight; };
  // (E W^-1 E') lambda = E a0 - aref;  a = a0 - W^-1 E' lambda.
  for (int r = 0; r < n; ++r) {
    const mjtNum* Er =
        J_ + static_cast<std::ptrdiff_t>(eq_rows_[static_cast<std::size_t>(r)]) * nv_;
    mjtNum rhs = -d.efc_aref[eq_rows_[static_cast<std::size_t>(r)]];
    for (int i = 0; i < nv_; ++i) rhs += Er[i] * desired_[static_cast<std::size_t>(i)];
    eq_rhs_[static_cast<std::size_t>(r)] = rhs;
    for (int c = 0; c <= r; ++c) {
      const mjtNum* Ec =
          J_ + static_cast<std::ptrdiff_t>(eq_rows_[static_cast<std::size_t>(c)]) * nv_;
      mjtNum v = 0;
      for (int i = 0; i < nv_; ++i) v += Er[i] * inv_w(i) * Ec[i];
      eq_lhs_[static_cast<std::size_t>(r * n + c)] = v;
    }
  }
  // Regularise (a weld's rows are independent, but keep the factorisation safe).
  for (int r = 0; r < n; ++r) eq_lhs_[static_cast<std::size_t>(r * n + r)] *= 1.0 + 1e-12;
  if (!cholesky(eq_lhs_.data(), n)) return;  // degenerate: keep the wish as it is
  cholesky_solve(eq_lhs_.data(), n, eq_rhs_.data());
  for (int r = 0; r < n; ++r) {
    const mjtNum* Er =
        J_ + static_cast<std::ptrdiff_t>(eq_rows_[static_cast<std::size_t>(r)]) * nv_;
    const mjtNum lambda = eq_rhs_[static_cast<std::size_t>(r)];
    for (int i = 0; i < nv_; ++i)
      desired_[static_cast<std::size_t>(i)] -= inv_w(i) * Er[i] * lambda;
  }
}

double HybridDynamics::evaluate(const mjModel& m, mjData& d, const mjtNum* a) {
  mj_mulM(&m, &d, Ma_.data(), a);
  mj_mulJacVec(&m, &d, jar_.data(), a);
  for (int r = 0; r < d.nefc; ++r) jar_[static_cast<std::size_t>(r)] -= d.efc_aref[r];
  mjtNum constraint_cost = 0;
  // With the cone Hessians: the last point evaluated is the one Newton builds its next step at.
  mj_constraintUpdate(&m, &d, jar_.data(), &constraint_cost, 1);
  mjtNum cost = constraint_cost;
  for (int i = 0; i < nv_; ++i) {
    const auto k = static_cast<std::size_t>(i);
    cost += 0.5 * a[i] * Ma_[k] - b_[k] * a[i];
    if (mode_[k] != kPrescribedAcc) cost -= fixed_[k] * a[i];
  }
  return cost;
}

int HybridDynamics::minimize(const mjModel& m, mjData& d, bool* converged) {
  const int n = static_cast<int>(unknown_.size());
  double cost = evaluate(m, d, a_.data());
  for (int iter = 0; iter < options_.max_newton_iterations; ++iter) {
    // Gradient on the unknowns: M a - b - J' f - fixed.
    mjtNum gmax = 0;
    for (int u = 0; u < n; ++u) {
      const auto i = static_cast<std::size_t>(unknown_[static_cast<std::size_t>(u)]);
      g_[static_cast<std::size_t>(u)] = Ma_[i] - b_[i] - d.qfrc_constraint[i] - fixed_[i];
      gmax = std::max(gmax, std::abs(g_[static_cast<std::size_t>(u)]));
    }
    if (gmax < options_.gradient_tolerance || n == 0) return iter;

    // Hessian block: M_UU + sum over force-carrying rows of D J_rU' J_rU.
    for (int r = 0; r < n; ++r)
      for (int c = 0; c < n; ++c)
        H_[static_cast<std::size_t>(r * n + c)] = M_[static_cast<std::size_t>(
            unknown_[static_cast<std::size_t>(r)] * nv_ + unknown_[static_cast<std::size_t>(c)])];
    // The cone zone's exact Hessian (MuJoCo's, per contact: J_c' H_c J_c, set by evaluate at
    // a_); with the quadratic zone's D J'J in its place Newton converged only linearly
    // (hundreds of N of residual after 20 iterations with the feet on an edge).
    for (int e = 0; e < d.nefc; ++e) {
      const int state = d.efc_state[e];
      if (state == mjCNSTRSTATE_CONE) {
        const mjContact& con = d.contact[d.efc_id[e]];
        const int dim = con.dim;
        for (int k = 0; k < dim; ++k) {
          const mjtNum* J = J_ + static_cast<std::ptrdiff_t>(e + k) * nv_;
          for (int u = 0; u < n; ++u)
            cone_rows_[static_cast<std::size_t>(k * n + u)] =
                J[unknown_[static_cast<std::size_t>(u)]];
        }
        for (int k = 0; k < dim; ++k) {
          for (int l = 0; l < dim; ++l) {
            const mjtNum h = con.H[k * dim + l];
            if (h == 0) continue;
            const mjtNum* rk = cone_rows_.data() + static_cast<std::ptrdiff_t>(k * n);
            const mjtNum* rl = cone_rows_.data() + static_cast<std::ptrdiff_t>(l * n);
            for (int r = 0; r < n; ++r) {
              const mjtNum wr = h * rk[r];
              if (wr == 0) continue;
              for (int c = 0; c <= r; ++c) H_[static_cast<std::size_t>(r * n + c)] += wr * rl[c];
            }
          }
        }
        e += dim - 1;  // the contact's other rows are in H_c
        continue;
      }
      if (state != mjCNSTRSTATE_QUADRATIC) continue;
      const mjtNum* J = J_ + static_cast<std::ptrdiff_t>(e) * nv_;
      bool any = false;
      for (int u = 0; u < n; ++u) {
        row_[static_cast<std::size_t>(u)] = J[unknown_[static_cast<std::size_t>(u)]];
        any = any || row_[static_cast<std::size_t>(u)] != 0;
      }
      if (!any) continue;
      const mjtNum De = d.efc_D[e];
      for (int r = 0; r < n; ++r) {
        const mjtNum wr = De * row_[static_cast<std::size_t>(r)];
        if (wr == 0) continue;
        for (int c = 0; c <= r; ++c)
          H_[static_cast<std::size_t>(r * n + c)] += wr * row_[static_cast<std::size_t>(c)];
      }
    }
    for (int u = 0; u < n; ++u)
      step_[static_cast<std::size_t>(u)] = -g_[static_cast<std::size_t>(u)];
    if (!cholesky(H_.data(), n)) {
      *converged = false;
      return iter;
    }
    cholesky_solve(H_.data(), n, step_.data());

    // Backtracking line search on the convex cost (exact for quadratic zones: alpha = 1).
    mjtNum slope = 0;
    for (int u = 0; u < n; ++u)
      slope += g_[static_cast<std::size_t>(u)] * step_[static_cast<std::size_t>(u)];
    double alpha = 1.0;
    double trial_cost = cost;
    for (int ls = 0; ls < 30; ++ls) {
      std::copy(a_.begin(), a_.end(), trial_.begin());
      for (int u = 0; u < n; ++u)
        trial_[static_cast<std::size_t>(unknown_[static_cast<std::size_t>(u)])] +=
            alpha * step_[static_cast<std::size_t>(u)];
      trial_cost = evaluate(m, d, trial_.data());
      if (trial_cost <= cost + 1e-4 * alpha * slope) break;
      alpha *= 0.5;
    }
    std::swap(a_, trial_);
    const double decrease = cost - trial_cost;
    cost = trial_cost;
    if (decrease <= 1e-15 * (1.0 + std::abs(cost))) {
      return iter + 1;  // no further progress possible in floating point
    }
  }
  *converged = false;
  return options_.max_newton_iterations;
}

HybridDynamicsResult HybridDynamics::solve(const mjModel& m, mjData& d,
                                           const std::uint8_t* actuated, const mjtNum* qacc_desired,
                                           const mjtNum* force_min, const mjtNum* force_max,
                                           const mjtNum* qfrc_other, mjtNum* force, mjtNum* qacc) {
  HybridDynamicsResult result;
  if (J_dense_.empty()) {
    J_ = d.efc_J;
  } else {
    for (int r = 0; r < d.nefc; ++r)
      efc_jacobian_row(m, d, r, J_dense_.data() + static_cast<std::ptrdiff_t>(r) * nv_);
    J_ = J_dense_.data();
  }
  mj_fullM(&m, M_.data(), d.qM);
  project_on_equalities(d, actuated, qacc_desired);
  qacc_desired = desired_.data();
  for (int i = 0; i < nv_; ++i) {
    const auto k = static_cast<std::size_t>(i);
    b_[k] = d.qfrc_passive[i] - d.qfrc_bias[i] + qfrc_other[i];
    mode_[k] = actuated[i] ? kPrescribedAcc : kZeroForce;
    fixed_[k] = 0;
    // A DOF whose bounds meet is torque-specified: held there from the start, never
    // released (its acceleration wish means nothing, and testing it would cycle).
    if (actuated[i] && force_min[i] >= force_max[i]) {
      mode_[k] = kAtMin;
      fixed_[k] = force_min[i];
    }
    // Warm start: MuJoCo's last accelerations for the unknowns, the wish for the others.
    a_[k] = actuated[i] ? qacc_desired[i] : d.qacc_warmstart[i];
  }

  for (int pass = 0; pass < options_.max_active_set_iterations; ++pass) {
    result.active_set_iterations = pass + 1;
    unknown_.clear();
    for (int i = 0; i < nv_; ++i) {
      const auto k = static_cast<std::size_t>(i);
      if (mode_[k] == kPrescribedAcc) {
        a_[k] = qacc_desired[i];
      } else {
        unknown_.push_back(i);
      }
    }
    bool converged = true;
    result.newton_iterations += minimize(m, d, &converged);
    result.converged = converged;

    // Forces the prescribed DOFs need: tau = M a - b - J' f.
    bool changed = false;
    for (int i = 0; i < nv_; ++i) {
      const auto k = static_cast<std::size_t>(i);
      const mjtNum needed = Ma_[k] - b_[k] - d.qfrc_constraint[i];
      switch (mode_[k]) {
        case kPrescribedAcc:
          force[i] = needed;
          if (needed > force_max[i]) {
            mode_[k] = kAtMax;
            changed = true;
          } else if (needed < force_min[i]) {
            mode_[k] = kAtMin;
            changed = true;
          }
          break;
        case kAtMax:  // released when the bound overshoots the wish
          force[i] = force_max[i];
          if (a_[k] > qacc_desired[i]) {
            mode_[k] = kPrescribedAcc;
            changed = true;
          }
          break;
        case kAtMin:
          force[i] = force_min[i];
          if (force_min[i] < force_max[i] && a_[k] < qacc_desired[i]) {
            mode_[k] = kPrescribedAcc;
            changed = true;
          }
          break;
        default:
          force[i] = 0;
      }
      if (mode_[k] == kAtMax) fixed_[k] = force_max[i];
      if (mode_[k] == kAtMin) fixed_[k] = force_min[i];
    }
    if (!changed) break;
    if (pass + 1 == options_.max_active_set_iterations) result.converged = false;
  }

  result.saturated_dofs = 0;
  for (int i = 0; i < nv_; ++i) {
    const auto k = static_cast<std::size_t>(i);
    if (!actuated[i]) {
      force[i] = 0;
    } else {
      force[i] = std::clamp(force[i], force_min[i], force_max[i]);  // always within bounds
      if (mode_[k] == kAtMax || mode_[k] == kAtMin) ++result.saturated_dofs;
    }
    qacc[i] = a_[k];
  }
  return result;
}

}  // namespace biodyn::sim
