#include "biodyn/muscles/box_qp.h"

#include <algorithm>
#include <cassert>
#include <cmath>

namespace biodyn::muscles {

BoxQp::BoxQp(int max_n)
    : max_n_(max_n),
      state_(static_cast<std::size_t>(max_n)),
      free_(static_cast<std::size_t>(max_n)),
      L_(max_n, max_n),
      rhs_(max_n),
      candidate_(max_n),
      grad_(max_n) {}

bool BoxQp::factor_free(const Eigen::MatrixXd& H, int n_free) {
  // Cholesky-Crout of H[free, free] into L_'s lower triangle.
  for (int j = 0; j < n_free; ++j) {
    const int fj = free_[static_cast<std::size_t>(j)];
    double d = H(fj, fj);
    for (int k = 0; k < j; ++k) d -= L_(j, k) * L_(j, k);
    if (!(d > 0.0)) return false;
    L_(j, j) = std::sqrt(d);
    for (int i = j + 1; i < n_free; ++i) {
      double s = H(free_[static_cast<std::size_t>(i)], fj);
      for (int k = 0; k < j; ++k) s -= L_(i, k) * L_(j, k);
      L_(i, j) = s / L_(j, j);
    }
  }
  return true;
}

void BoxQp::solve_free(int n_free) {
  for (int i = 0; i < n_free; ++i) {  // L y = rhs
    double s = rhs_(i);
    for (int k = 0; k < i; ++k) s -= L_(i, k) * rhs_(k);
    rhs_(i) = s / L_(i, i);
  }
  for (int i = n_free - 1; i >= 0; --i) {  // L^T z = y
    double s = rhs_(i);
    for (int k = i + 1; k < n_free; ++k) s -= L_(k, i) * rhs_(k);
    rhs_(i) = s / L_(i, i);
  }
}

BoxQpResult BoxQp::solve(const Eigen::MatrixXd& H, const Eigen::VectorXd& g,
                         const Eigen::VectorXd& lo, const Eigen::VectorXd& hi,
                         Eigen::VectorXd* x_out, const int* start_bounds) {
  const int n = static_cast<int>(g.size());
  assert(n <= max_n_);
  Eigen::VectorXd& x = *x_out;
  for (int i = 0; i < n; ++i) {
    assert(lo(i) <= hi(i));
    x(i) = std::clamp(x(i), lo(i), hi(i));
    int st = x(i) <= lo(i) ? -1 : (x(i) >= hi(i) ? 1 : 0);
    if (start_bounds != nullptr) {
      st = start_bounds[i];
      if (st != 0) x(i) = st < 0 ? lo(i) : hi(i);
    }
    state_[static_cast<std::size_t>(i)] = st;
  }
  BoxQpResult result;
  const int max_iterations = 4 * n + 20;
  for (result.iterations = 1; result.iterations <= max_iterations; ++result.iterations) {
    // Minimise over the free variables with the others fixed on their bounds.
    int n_free = 0;
    for (int i = 0; i < n; ++i)
      if (state_[static_cast<std::size_t>(i)] == 0) free_[static_cast<std::size_t>(n_free++)] = i;
    if (n_free > 0) {
      if (!factor_free(H, n_free)) return result;  // H not positive definite: caller's bug
      for (int a = 0; a < n_free; ++a) {
        const int i = free_[static_cast<std::size_t>(a)];
        double s = -g(i);
        for (int j = 0; j < n; ++j)
          if (state_[static_cast<std::size_t>(j)] != 0) s -= H(i, j) * x(j);
        rhs_(a) = s;
      }
      solve_free(n_free);
    }
    // Step towards the free minimiser as far as the box allows; a blocked variable joins its bound.
    double step = 1.0;
    int blocking = -1, blocking_bound = 0;  // the bound it meets: -1 lo, +1 hi
    for (int a = 0; a < n_free; ++a) {
      const int i = free_[static_cast<std::size_t>(a)];
      const double d = rhs_(a) - x(i);
      if (d < 0.0 && x(i) + d < lo(i)) {
        const double t = (lo(i) - x(i)) / d;
        if (t < step) step = t, blocking = i, blocking_bound = -1;
      } else if (d > 0.0 && x(i) + d > hi(i)) {
        const double t = (hi(i) - x(i)) / d;
        if (t < step) step = t, blocking = i, blocking_bound = 1;
      }
    }
    for (int a = 0; a < n_free; ++a) {
      const int i = free_[static_cast<std::size_t>(a)];
      x(i) = std::clamp(x(i) + step * (rhs_(a) - x(i)), lo(i), hi(i));
    }
    if (blocking >= 0) {
      // The bound the step met, not the one x is nearer after rounding: x + t d can stop a hair
      // inside lo, and reading that as "at hi" put the variable on the wrong bound (it cycled).
      state_[static_cast<std::size_t>(blocking)] = blocking_bound;
      x(blocking) = blocking_bound < 0 ? lo(blocking) : hi(blocking);
      continue;
    }
    // At the free minimiser: release the bound whose multiplier has the wrong sign the most.
    grad_.head(n).noalias() = H.topLeftCorner(n, n) * x.head(n) + g.head(n);
    int release = -1;
    double worst = kBoxQpTolerance * (1.0 + g.head(n).cwiseAbs().maxCoeff());
    for (int i = 0; i < n; ++i) {
      const int st = state_[static_cast<std::size_t>(i)];
      const double pull = st < 0 ? -grad_(i) : (st > 0 ? grad_(i) : 0.0);  // > 0: wants inside
      if (pull > worst && lo(i) < hi(i)) worst = pull, release = i;
    }
    if (release < 0) {
      result.converged = true;
      break;
    }
    state_[static_cast<std::size_t>(release)] = 0;
  }
  for (int i = 0; i < n; ++i) result.active += state_[static_cast<std::size_t>(i)] != 0;
  return result;
}

}  // namespace biodyn::muscles
