#pragma once
/// A small dense QP with box bounds, solved exactly by a primal active-set method:
///
///     minimise 1/2 x^T H x + g^T x   subject to lo <= x <= hi,
///
/// H symmetric positive definite (n x n, n up to max_n). The muscle problems are this shape
/// (activations within what activation dynamics allows, squared activations plus penalised
/// backups or reserves); n is a few dozen, so a dense Cholesky of the free block per iteration
/// is cheaper than a general solver's set-up. Workspace is allocated once: solve() allocates
/// nothing and throws nothing.

#include <Eigen/Core>
#include <vector>

namespace biodyn::muscles {

struct BoxQpResult {
  int iterations = 0;
  bool converged = false;  ///< KKT conditions met within kBoxQpTolerance
  int active = 0;          ///< variables on a bound at the solution
};

inline constexpr double kBoxQpTolerance = 1e-10;

class BoxQp {
 public:
  explicit BoxQp(int max_n);

  /// Solves for the first n = g.size() variables. `x` holds a start (clamped into the box) and
  /// receives the solution. `start_bounds` (optional, n): a guess of the active set (-1 on lo,
  /// +1 on hi, 0 free), e.g. the last solution's bounds(): a sequence of close problems then
  /// takes one or two iterations each. The problem is strictly convex, so the solution does
  /// not depend on the start (to the tolerance). Bounds with lo > hi are an invariant broken
  /// (assert).
  BoxQpResult solve(const Eigen::MatrixXd& H, const Eigen::VectorXd& g, const Eigen::VectorXd& lo,
                    const Eigen::VectorXd& hi, Eigen::VectorXd* x,
                    const int* start_bounds = nullptr);
  /// The last solution's active set: -1 on lo, +1 on hi, 0 free, for variable i.
  int bound(int i) const { return state_[static_cast<std::size_t>(i)]; }

 private:
  bool factor_free(const Eigen::MatrixXd& H, int n_free);
  void solve_free(int n_free);

  int max_n_;
  std::vector<int> state_;  // -1 at lo, +1 at hi, 0 free
  std::vector<int> free_;   // indices of the free variables
  Eigen::MatrixXd L_;       // Cholesky of H[free, free]
  Eigen::VectorXd rhs_, candidate_, grad_;
};

}  // namespace biodyn::muscles
