// Static optimisation (muscles/static_optimization.h) on a hinge spanned by straight muscles
// whose moment arms are known in closed form: the a^2 solution against its analytic value,
// reserves taking what the muscles cannot give, the bounds, force-velocity at the frame's state,
// the whole-range function against the per-frame one, bad input refused, and no allocation per
// frame.
#include "biodyn/muscles/static_optimization.h"

#include <atomic>
#include <cstdlib>

#include "biodyn/muscles/hill_curves.h"
#include "biodyn/sim/errors.h"
#include "test_support.h"

namespace {

// Counts heap allocations while armed: malloc itself is interposed (Eigen allocates through it,
// operator new too), forwarding to glibc's. Not in an AddressSanitizer build, which owns malloc.
std::atomic<bool> g_count_allocations{false};
std::atomic<long> g_allocations{0};

}  // namespace

#if defined(__SANITIZE_ADDRESS__)
constexpr bool kAllocationsCounted = false;
#else
constexpr bool kAllocationsCounted = true;
extern "C" void* __libc_malloc(std::size_t size);
extern "C" void* malloc(std::size_t size) {
  if (g_count_allocations.load(std::memory_order_relaxed)) ++g_allocations;
  return __libc_malloc(size);
}
#endif

using namespace biodyn;
using muscles::MuscleParams;
using muscles::MuscleSet;
using muscles::StaticOptimization;
using muscles::StaticOptimizationFrame;
using muscles::StaticOptimizationParams;

namespace {

constexpr double kTolerance = 1e-9;  // the QP is solved exactly (active set, KKT to 1e-10)

// A hinge about y at the origin; each muscle runs straight down from a site 0.3 m above the
// joint (fixed) to one 0.2 m below it (on the link), at x = d. Rotating the link by q about y
// moves the lower site to (d cos q - 0.2 sin q, 0, -d sin q - 0.2 cos q), so at q = 0 the path
// lengthens at dl/dq = d: the moment arm is r = -dl/dq = -d, and the path is 0.5 m long.
constexpr double kX[3] = {-0.05, -0.03, 0.04};  // m: r = +0.05, +0.03 (agonists), -0.04
constexpr double kPath_m = 0.5;

const char* kHingeXml = R"(
<mujoco>
  <option gravity="0 0 0"/>
  <worldbody>
    <site name="o0" pos="-0.05 0 0.3"/> <site name="o1" pos="-0.03 0 0.3"/>
    <site name="o2" pos="0.04 0 0.3"/>
    <body name="link">
      <joint name="hinge" type="hinge" axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0 0 -0.4" size="0.02" mass="1"/>
      <site name="i0" pos="-0.05 0 -0.2"/> <site name="i1" pos="-0.03 0 -0.2"/>
      <site name="i2" pos="0.04 0 -0.2"/>
    </body>
  </worldbody>
  <tendon>
    <spatial name="m0"><site site="o0"/><site site="i0"/></spatial>
    <spatial name="m1"><site site="o1"/><site site="i1"/></spatial>
    <spatial name="m2"><site site="o2"/><site site="i2"/></spatial>
  </tendon>
</mujoco>)";

/// Muscle `i` of the hinge: no pennation, fibre at its optimal length at q = 0 (l_opt 0.1 m,
/// slack 0.4 m), so its force is F_max a f_V with no passive force.
MuscleParams hinge_muscle(int i, double f_max_N) {
  MuscleParams p;
  p.name = "m" + std::to_string(i);
  p.max_isometric_force_N = f_max_N;
  p.optimal_fiber_length_m = 0.1;
  p.tendon_slack_length_m = kPath_m - 0.1;
  return p;
}

struct Hinge {
  sim::Model model;
  sim::Data data;
  std::vector<MuscleParams> params;
};

/// The hinge with `muscles` of the three, their F_max `f_max_N`, at angle q (rad) and rate qdot.
Hinge hinge(const std::vector<int>& muscles, const std::vector<double>& f_max_N, double q = 0,
            double qdot = 0) {
  sim::Model model = testing::load_inline(kHingeXml);
  sim::Data data(*model);
  data->qpos[0] = q;
  data->qvel[0] = qdot;
  mj_forward(model.get(), data.get());
  std::vector<MuscleParams> params;
  for (std::size_t k = 0; k < muscles.size(); ++k)
    params.push_back(hinge_muscle(muscles[k], f_max_N[k]));
  return {std::move(model), std::move(data), std::move(params)};
}

StaticOptimizationParams weight(double w) {
  StaticOptimizationParams p;
  p.reserve_weight_per_Nm2 = w;
  return p;
}

/// min sum a^2 + w (tau - b.a)^2 without bounds: a = w b tau / (1 + w |b|^2).
Eigen::VectorXd analytic(const Eigen::VectorXd& b, double tau, double w) {
  return w * b * tau / (1.0 + w * b.squaredNorm());
}

}  // namespace

TEST_CASE_METHOD(testing::SimulationTest,
                 "Static optimisation: two agonists share a torque as the a^2 solution says",
                 "[muscles][static_optimization]") {
  Hinge h = hinge({0, 1}, {1000.0, 1500.0});
  StaticOptimization so(MuscleSet(*h.model, h.params));
  REQUIRE(so.set().covered_dofs() == std::vector<int>{0});
  Eigen::MatrixXd R(1, 2);
  so.set().moment_arms(*h.model, *h.data, &R);
  CHECK(R(0, 0) == Approx(-kX[0]).epsilon(1e-9));
  CHECK(R(0, 1) == Approx(-kX[1]).epsilon(1e-9));
  // b_i = r_i F_max,i (N m per unit activation: no pennation, f_L = 1, f_V = 1, no passive).
  const Eigen::VectorXd b = Eigen::Vector2d(0.05 * 1000.0, 0.03 * 1500.0);
  for (const double w : {1.0, 0.1, 1e4}) {
    const double tau = 20.0;  // N m: both muscles well inside their bounds
    StaticOptimization sw(MuscleSet(*h.model, h.params), weight(w));
    StaticOptimizationFrame f = sw.make_frame();
    sw.solve(*h.model, *h.data, &tau, &f);
    const Eigen::VectorXd a = analytic(b, tau, w);
    INFO("w = " << w << ": a = " << f.activation.transpose() << ", analytic " << a.transpose());
    CHECK(f.converged);
    CHECK((f.activation - a).cwiseAbs().maxCoeff() < 1e-6 * a.maxCoeff());
    // Each muscle's share grows with its torque capacity: a_i proportional to b_i.
    CHECK(f.activation(0) / f.activation(1) == Approx(b(0) / b(1)).epsilon(1e-6));
    CHECK(f.force_N(0) == Approx(1000.0 * f.activation(0)).epsilon(1e-9));
    CHECK(f.muscle_moment_Nm(0) == Approx(b.dot(f.activation)).epsilon(1e-6));
    CHECK(f.reserve_Nm(0) == Approx(tau / (1.0 + w * b.squaredNorm())).epsilon(1e-6));
    CHECK(f.tau_Nm(0) == tau);
    // A weight on this DOF's reserve replaces the default weight there.
    StaticOptimizationParams per_dof;
    per_dof.reserve_weight_of_dof_per_Nm2[0] = w;
    StaticOptimization sd(MuscleSet(*h.model, h.params), per_dof);
    StaticOptimizationFrame fd = sd.make_frame();
    sd.solve(*h.model, *h.data, &tau, &fd);
    CHECK(sd.reserve_weights()(0) == w);
    CHECK((fd.activation - f.activation).cwiseAbs().maxCoeff() < kTolerance);
  }
  StaticOptimizationParams elsewhere;
  elsewhere.reserve_weight_of_dof_per_Nm2[3] = 1.0;
  CHECK_THROWS_WITH(StaticOptimization(MuscleSet(*h.model, h.params), elsewhere),
                    Catch::Contains("DOF 3 is spanned by no muscle"));
}

TEST_CASE_METHOD(testing::SimulationTest,
                 "Static optimisation: reserves take what weak or opposing muscles cannot give, "
                 "activations stay in [0, 1]",
                 "[muscles][static_optimization]") {
  Hinge h = hinge({0, 1, 2}, {200.0, 300.0, 400.0});
  StaticOptimization so(MuscleSet(*h.model, h.params));
  StaticOptimizationFrame f = so.make_frame();
  // 100 N m flexion: the agonists give at most 0.05 * 200 + 0.03 * 300 = 19 N m.
  double tau = 100.0;
  so.solve(*h.model, *h.data, &tau, &f);
  CHECK(f.converged);
  CHECK(f.activation(0) == 1.0);
  CHECK(f.activation(1) == 1.0);
  CHECK(f.activation(2) == 0.0);  // the antagonist would only add to the reserve
  CHECK(f.muscle_moment_Nm(0) == Approx(19.0).epsilon(1e-9));
  CHECK(f.reserve_Nm(0) == Approx(81.0).epsilon(1e-9));
  // Extension the agonists cannot give: the antagonist alone, as the a^2 solution with b =
  // -0.04 * 400 says; the agonists sit on their lower bound.
  tau = -5.0;
  so.solve(*h.model, *h.data, &tau, &f);
  const double b = -0.04 * 400.0;
  CHECK(f.activation(0) == 0.0);
  CHECK(f.activation(1) == 0.0);
  CHECK(f.activation(2) == Approx(b * tau / (1.0 + b * b)).epsilon(1e-9));
  CHECK(f.reserve_Nm(0) == Approx(tau - b * f.activation(2)).epsilon(1e-9));
  // No torque: no activation, no reserve.
  tau = 0.0;
  so.solve(*h.model, *h.data, &tau, &f);
  CHECK(f.activation.cwiseAbs().maxCoeff() < kTolerance);
  CHECK(std::abs(f.reserve_Nm(0)) < kTolerance);
}

TEST_CASE_METHOD(testing::SimulationTest,
                 "Static optimisation: force-velocity at the frame's state (rigid tendon)",
                 "[muscles][static_optimization]") {
  // At qdot = 2 rad/s muscle 0 (r = +0.05 m) shortens at 0.1 m/s, 0.1 of its v_max (10 l_opt/s
  // of 0.1 m): its force per activation is F_max f_V(-0.1). Muscle 2 lengthens at 0.08 m/s.
  const double qdot = 2.0;
  Hinge h = hinge({0, 2}, {1000.0, 1000.0}, 0.0, qdot);
  StaticOptimization so(MuscleSet(*h.model, h.params));
  StaticOptimizationFrame f = so.make_frame();
  const double tau = 10.0;
  so.solve(*h.model, *h.data, &tau, &f);
  const muscles::HillCurveParams curves;
  const double fv = muscles::force_velocity(-0.05 * qdot / 1.0, curves);
  CHECK(fv < 1.0);
  CHECK(f.force_N(0) == Approx(1000.0 * fv * f.activation(0)).epsilon(1e-6));
  CHECK(f.activation(1) == 0.0);
  const double b0 = 0.05 * 1000.0 * fv;
  CHECK(f.activation(0) == Approx(b0 * tau / (1.0 + b0 * b0)).epsilon(1e-6));
}

TEST_CASE_METHOD(testing::SimulationTest,
                 "Static optimisation over frames: the per-frame solution, timed, no allocation "
                 "per frame, bad input refused",
                 "[muscles][static_optimization]") {
  Hinge h = hinge({0, 1, 2}, {1000.0, 800.0, 1200.0});
  StaticOptimization so(MuscleSet(*h.model, h.params));
  constexpr int kFrames = 50;
  Eigen::MatrixXd qpos(kFrames, 1), qvel(kFrames, 1), tau(kFrames, 1);
  for (int i = 0; i < kFrames; ++i) {
    qpos(i, 0) = 0.3 * std::sin(0.2 * i);
    qvel(i, 0) = 0.6 * std::cos(0.2 * i);
    tau(i, 0) = 40.0 * std::sin(0.13 * i);
  }
  double last_progress = 0;
  const muscles::StaticOptimizationResult r = muscles::static_optimization(
      *h.model, &so, qpos, qvel, tau, [&](double p) { last_progress = p; });
  CHECK(last_progress == 1.0);
  CHECK(r.qp_failures == 0);
  CHECK(r.solve_time_s > 0);
  REQUIRE(r.activation.rows() == kFrames);
  REQUIRE(r.reserve_Nm.cols() == 1);
  sim::Data d(*h.model);
  StaticOptimizationFrame f = so.make_frame();
  for (int i = 0; i < kFrames; i += 7) {
    d->qpos[0] = qpos(i, 0);
    d->qvel[0] = qvel(i, 0);
    mj_forward(h.model.get(), d.get());
    so.solve(*h.model, *d, &tau(i, 0), &f);
    CHECK((r.activation.row(i).transpose() - f.activation).cwiseAbs().maxCoeff() < kTolerance);
    CHECK(r.reserve_Nm(i, 0) == Approx(f.reserve_Nm(0)).margin(kTolerance));
    CHECK(r.muscle_moment_Nm(i, 0) + r.reserve_Nm(i, 0) == Approx(tau(i, 0)).margin(kTolerance));
    CHECK(r.activation.row(i).minCoeff() >= 0.0);
    CHECK(r.activation.row(i).maxCoeff() <= 1.0);
  }
  // solve() allocates nothing (set-up did, once); the counter sees an Eigen temporary.
  if (kAllocationsCounted) {
    g_allocations = 0;
    g_count_allocations = true;
    const Eigen::VectorXd temporary = f.activation * 2.0;
    g_count_allocations = false;
    CHECK(g_allocations == 1);
    g_allocations = 0;
    g_count_allocations = true;
    for (int i = 0; i < kFrames; ++i) so.solve(*h.model, *d, &tau(i, 0), &f);
    g_count_allocations = false;
    CHECK(g_allocations == 0);
  }

  Eigen::MatrixXd bad = tau;
  bad(3, 0) = std::nan("");
  CHECK_THROWS_AS(muscles::static_optimization(*h.model, &so, qpos, qvel, bad),
                  sim::InvalidArgument);
  CHECK_THROWS_WITH(muscles::static_optimization(*h.model, &so, qpos, qvel, tau.topRows(3)),
                    Catch::Contains("tau_Nm must be 50 x 1, got 3 x 1"));
  CHECK_THROWS_WITH(StaticOptimization(MuscleSet(*h.model, h.params), weight(0)),
                    Catch::Contains("reserve_weight_per_Nm2 must be > 0"));
}
