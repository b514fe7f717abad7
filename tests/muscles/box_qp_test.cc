// The box QP (muscles/box_qp.h) on seeded random strictly convex problems: its answer meets the
// KKT conditions, equals the minimiser found by enumerating every active set (small n), and
// handles fixed variables (lo == hi), starts on the bounds and the unconstrained case.
#include <Eigen/Cholesky>
#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "biodyn/muscles/box_qp.h"

namespace biodyn::muscles::box_qp_test {
namespace {

constexpr unsigned kQpSeed = 2025;
constexpr double kKktTolerance = 1e-8;       // gradient sign / zero on free variables
constexpr double kSolutionTolerance = 1e-8;  // against the enumerated minimiser
constexpr int kMaxN = 16;

struct Problem {
  Eigen::MatrixXd H;
  Eigen::VectorXd g, lo, hi;
};

// H = A A^T + 0.1 I (well conditioned enough, not diagonal), g and the box random; a share
// `fixed` of the variables get lo == hi.
Problem random_problem(int n, std::mt19937* rng, double fixed = 0.0) {
  std::normal_distribution<double> normal(0.0, 1.0);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  Problem p;
  Eigen::MatrixXd A(n, n);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) A(i, j) = normal(*rng);
  p.H = A * A.transpose() + 0.1 * Eigen::MatrixXd::Identity(n, n);
  p.g = Eigen::VectorXd(n);
  p.lo = Eigen::VectorXd(n);
  p.hi = Eigen::VectorXd(n);
  for (int i = 0; i < n; ++i) {
    p.g(i) = 3.0 * normal(*rng);
    p.lo(i) = -unit(*rng);
    p.hi(i) = unit(*rng) < fixed ? p.lo(i) : p.lo(i) + 2.0 * unit(*rng);
  }
  return p;
}

double objective(const Problem& p, const Eigen::VectorXd& x) {
  return 0.5 * x.dot(p.H * x) + p.g.dot(x);
}

// The KKT conditions of min 1/2 x'Hx + g'x on the box, with a tolerance scaled by the problem.
void check_kkt(const Problem& p, const Eigen::VectorXd& x) {
  const Eigen::VectorXd grad = p.H * x + p.g;
  const double tol = kKktTolerance * (1.0 + p.g.cwiseAbs().maxCoeff());
  for (int i = 0; i < x.size(); ++i) {
    INFO("variable " << i << ": x " << x(i) << " in [" << p.lo(i) << ", " << p.hi(i)
                     << "], gradient " << grad(i));
    REQUIRE(x(i) >= p.lo(i));
    REQUIRE(x(i) <= p.hi(i));
    if (p.lo(i) == p.hi(i)) continue;  // fixed: any multiplier
    if (x(i) == p.lo(i)) {
      CHECK(grad(i) >= -tol);  // pushing out through lo
    } else if (x(i) == p.hi(i)) {
      CHECK(grad(i) <= tol);
    } else {
      CHECK(std::abs(grad(i)) <= tol);
    }
  }
}

// The minimiser by brute force: every assignment of each variable to lo, hi or free; the free
// block solved exactly; the feasible candidate with the least objective (the problem is strictly
// convex, so that is the unique minimiser).
Eigen::VectorXd enumerate_minimiser(const Problem& p) {
  const int n = static_cast<int>(p.g.size());
  int combos = 1;
  for (int i = 0; i < n; ++i) combos *= 3;
  Eigen::VectorXd best;
  double best_f = std::numeric_limits<double>::infinity();
  for (int code = 0; code < combos; ++code) {
    Eigen::VectorXd x(n);
    std::vector<int> free;
    int c = code;
    for (int i = 0; i < n; ++i, c /= 3) {
      if (c % 3 == 0) x(i) = p.lo(i);
      if (c % 3 == 1) x(i) = p.hi(i);
      if (c % 3 == 2) free.push_back(i);
    }
    if (!free.empty()) {
      const int k = static_cast<int>(free.size());
      Eigen::MatrixXd Hf(k, k);
      Eigen::VectorXd rhs(k);
      for (int a = 0; a < k; ++a) {
        rhs(a) = -p.g(free[a]);
        for (int j = 0; j < n; ++j) {
          const bool j_free = std::find(free.begin(), free.end(), j) != free.end();
          if (!j_free) rhs(a) -= p.H(free[a], j) * x(j);
        }
        for (int b = 0; b < k; ++b) Hf(a, b) = p.H(free[a], free[b]);
      }
      const Eigen::VectorXd xf = Hf.llt().solve(rhs);
      for (int a = 0; a < k; ++a) x(free[a]) = xf(a);
    }
    bool feasible = true;
    for (int i = 0; i < n; ++i) feasible = feasible && x(i) >= p.lo(i) && x(i) <= p.hi(i);
    if (feasible && objective(p, x) < best_f) best_f = objective(p, x), best = x;
  }
  return best;
}

}  // namespace

TEST_CASE("box QP: random SPD problems meet KKT and equal the enumerated minimiser", "[muscles]") {
  std::mt19937 rng(kQpSeed);
  BoxQp qp(kMaxN);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  int active_total = 0, problems = 0;
  for (int n = 1; n <= 6; ++n) {
    for (int trial = 0; trial < 40; ++trial) {
      const Problem p = random_problem(n, &rng, trial % 4 == 0 ? 0.3 : 0.0);
      Eigen::VectorXd x(n);
      for (int i = 0; i < n; ++i) x(i) = p.lo(i) + (p.hi(i) - p.lo(i)) * unit(rng);
      const BoxQpResult r = qp.solve(p.H, p.g, p.lo, p.hi, &x);
      INFO("n " << n << ", trial " << trial << ", iterations " << r.iterations);
      REQUIRE(r.converged);
      check_kkt(p, x);
      const Eigen::VectorXd want = enumerate_minimiser(p);
      CHECK((x - want).cwiseAbs().maxCoeff() < kSolutionTolerance);
      int on_bounds = 0;
      for (int i = 0; i < n; ++i) on_bounds += x(i) == p.lo(i) || x(i) == p.hi(i) ? 1 : 0;
      CHECK(r.active == on_bounds);
      active_total += r.active;
      ++problems;
    }
  }
  // The problems exercise the bounds: some variables active, not all.
  CHECK(active_total > problems / 2);
  CHECK(active_total < problems * 3);
}

TEST_CASE("box QP: larger problems meet KKT from any start, fixed variables stay put",
          "[muscles]") {
  std::mt19937 rng(kQpSeed + 1);
  BoxQp qp(kMaxN);
  for (int trial = 0; trial < 100; ++trial) {
    const int n = 7 + trial % (kMaxN - 6);
    const Problem p = random_problem(n, &rng, 0.2);
    // Starts: on lo, on hi, outside the box (clamped).
    for (int start = 0; start < 3; ++start) {
      Eigen::VectorXd x = start == 0 ? p.lo : start == 1 ? p.hi : Eigen::VectorXd(10.0 * p.hi);
      const BoxQpResult r = qp.solve(p.H, p.g, p.lo, p.hi, &x);
      INFO("trial " << trial << ", n " << n << ", start " << start);
      REQUIRE(r.converged);
      check_kkt(p, x);
      for (int i = 0; i < n; ++i)
        if (p.lo(i) == p.hi(i)) CHECK(x(i) == p.lo(i));
    }
  }
}

TEST_CASE("box QP: every variable fixed, and an unconstrained problem", "[muscles]") {
  std::mt19937 rng(kQpSeed + 2);
  BoxQp qp(kMaxN);
  Problem p = random_problem(5, &rng, 1.0);  // lo == hi everywhere
  Eigen::VectorXd x = Eigen::VectorXd::Zero(5);
  BoxQpResult r = qp.solve(p.H, p.g, p.lo, p.hi, &x);
  CHECK(r.converged);
  CHECK(r.active == 5);
  CHECK(x == p.lo);
  // A box far wider than the minimiser: x = -H^-1 g, nothing active.
  p = random_problem(8, &rng);
  p.lo.setConstant(-1e6);
  p.hi.setConstant(1e6);
  x.setZero(8);
  r = qp.solve(p.H, p.g, p.lo, p.hi, &x);
  CHECK(r.converged);
  CHECK(r.active == 0);
  const Eigen::VectorXd want = -p.H.llt().solve(p.g);
  CHECK((x - want).cwiseAbs().maxCoeff() < kSolutionTolerance);
}

TEST_CASE("box QP: an indefinite H is reported as not converged", "[muscles]") {
  BoxQp qp(3);
  Eigen::MatrixXd H = Eigen::MatrixXd::Identity(2, 2);
  H(1, 1) = -1.0;
  const Eigen::VectorXd g = Eigen::VectorXd::Ones(2), lo = -Eigen::VectorXd::Ones(2),
                        hi = Eigen::VectorXd::Ones(2);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(2);
  CHECK_FALSE(qp.solve(H, g, lo, hi, &x).converged);
}

}  // namespace biodyn::muscles::box_qp_test
