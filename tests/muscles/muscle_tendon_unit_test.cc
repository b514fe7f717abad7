// One muscle-tendon unit (muscles/muscle_tendon_unit.h): activation dynamics against its time
// constants, the excitation that reaches an activation, the compliant tendon's backward-Euler
// fibre (quasi-static convergence, stability at large steps, agreement with a rigid tendon when
// the tendon is stiff), and the soleus of the generated character held isometric across ankle
// angles against an independent computation written here from Thelen 2003's formulas.
#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <random>
#include <vector>

#include "biodyn/models/character.h"
#include "biodyn/models/mjcf.h"
#include "biodyn/models/rig.h"
#include "biodyn/muscles/muscle_set.h"
#include "biodyn/muscles/muscle_tendon_unit.h"
#include "biodyn/sim/model.h"
#include "biodyn/sim/units.h"
#include "character.h"
#include "test_support.h"

namespace biodyn::muscles::mtu_test {
namespace {

constexpr double kTimeTolerance_s = 1e-9;      // exponential crossing time: rounding only
constexpr double kActivationExact = 1e-12;     // closed-form activation: rounding only
constexpr double kExcitationInverse = 1e-9;    // excitation_for undoes activation_step
constexpr double kIndependentRelative = 1e-6;  // the bar: production vs independent

// Rajagopal 2016's soleus (unscaled): F_max, l_opt, l_slack, pennation.
MuscleParams soleus_like(TendonModel tendon = TendonModel::kCompliant) {
  MuscleParams p;
  p.name = "soleus_test";
  p.max_isometric_force_N = 6194.843;
  p.optimal_fiber_length_m = 0.044;
  p.tendon_slack_length_m = 0.276756;
  p.pennation_at_optimal_rad = 0.381429;
  p.tendon = tendon;
  p.validate();
  return p;
}

// MTU length with the fibre at its optimal length and the tendon at its slack length.
double optimal_mtu_length(const MuscleParams& p) {
  return p.tendon_slack_length_m + p.optimal_fiber_length_m * std::cos(p.pennation_at_optimal_rad);
}

// A step of excitation `u` from activation `a0` simulated at `dt`: the time the activation
// covers 1 - 1/e of the step, ln|u - a| interpolated linearly between samples (exact for an
// exponential, so the answer is the time constant whatever dt).
double time_to_one_time_constant(double a0, double u, double dt, const MuscleParams& p) {
  const double u_eff = std::clamp(u, p.min_activation, 1.0);
  const double target = std::log(std::abs(u_eff - a0)) - 1.0;
  double a = a0, t = 0.0;
  for (int step = 0; step < 100000; ++step) {
    const double next = activation_step(a, u, dt, p);
    if (std::log(std::abs(u_eff - next)) <= target) {
      const double y0 = std::log(std::abs(u_eff - a)), y1 = std::log(std::abs(u_eff - next));
      return t + dt * (target - y0) / (y1 - y0);
    }
    a = next;
    t += dt;
  }
  return -1.0;
}

}  // namespace

TEST_CASE("activation reaches 1-1/e of a step in tau_act = 15 ms, deactivation in 50 ms",
          "[muscles]") {
  const MuscleParams p = soleus_like();
  REQUIRE(p.activation_time_constant_s == 0.015);
  REQUIRE(p.deactivation_time_constant_s == 0.050);
  for (double dt : {0.001, 0.002}) {
    INFO("dt = " << dt);
    CHECK(time_to_one_time_constant(p.min_activation, 1.0, dt, p) ==
          Approx(0.015).margin(kTimeTolerance_s));
    CHECK(time_to_one_time_constant(0.3, 0.8, dt, p) == Approx(0.015).margin(kTimeTolerance_s));
    // Excitation 0 is clamped to the minimum activation: the step is 1 -> 0.01.
    CHECK(time_to_one_time_constant(1.0, 0.0, dt, p) == Approx(0.050).margin(kTimeTolerance_s));
    CHECK(time_to_one_time_constant(0.8, 0.3, dt, p) == Approx(0.050).margin(kTimeTolerance_s));
  }
  // At dt = 1 ms the 15th sample is the time constant itself.
  double a = p.min_activation;
  for (int i = 0; i < 15; ++i) a = activation_step(a, 1.0, 0.001, p);
  CHECK(a == Approx(p.min_activation + (1.0 - std::exp(-1.0)) * (1.0 - p.min_activation))
                 .margin(kActivationExact));
  // Never past the excitation, at any step.
  CHECK(activation_step(0.2, 0.7, 10.0, p) == Approx(0.7).margin(kActivationExact));
  CHECK(activation_step(0.2, 0.7, 0.001, p) < 0.7);
}

TEST_CASE("reachable_activation and excitation_for invert activation_step", "[muscles]") {
  const MuscleParams p = soleus_like();
  std::mt19937 rng(2503);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (double dt : {0.001, 0.002, 0.010}) {
    for (int i = 0; i < 500; ++i) {
      const double a = p.min_activation + (1.0 - p.min_activation) * unit(rng);
      const ActivationRange r = reachable_activation(a, dt, p);
      INFO("a = " << a << ", dt = " << dt);
      REQUIRE(r.lo <= a);
      REQUIRE(r.hi >= a);
      CHECK(r.lo == Approx(activation_step(a, p.min_activation, dt, p)).margin(kActivationExact));
      CHECK(r.hi == Approx(activation_step(a, 1.0, dt, p)).margin(kActivationExact));
      // A reachable activation: its excitation takes a there.
      const double next = r.lo + (r.hi - r.lo) * unit(rng);
      const double u = excitation_for(a, next, dt, p);
      CHECK(u >= p.min_activation);
      CHECK(u <= 1.0);
      CHECK(activation_step(a, u, dt, p) == Approx(next).margin(kExcitationInverse));
      // An excitation: excitation_for finds it back from where it leads.
      const double e = p.min_activation + (1.0 - p.min_activation) * unit(rng);
      CHECK(excitation_for(a, activation_step(a, e, dt, p), dt, p) ==
            Approx(e).margin(kExcitationInverse));
      // Beyond reach: clamped to the bounds.
      CHECK(excitation_for(a, r.hi + 0.1, dt, p) == 1.0);
      CHECK(excitation_for(a, r.lo - 0.1, dt, p) == p.min_activation);
    }
  }
}

TEST_CASE("rigid tendon: force affine in activation, fibre kinematics from the path", "[muscles]") {
  const MuscleParams p = soleus_like(TendonModel::kRigid);
  const double h = p.fiber_height_m();
  for (double dl : {-0.01, 0.0, 0.015}) {
    for (double v : {-0.2, 0.0, 0.1}) {
      const double l_mtu = optimal_mtu_length(p) + dl;
      const ForceAffine f = rigid_tendon_affine(p, l_mtu, v);
      const MuscleKinematics k = rigid_tendon_state(p, 0.6, l_mtu, v);
      CHECK(k.tendon_force_N == Approx(0.6 * f.active_N + f.passive_N).epsilon(1e-12));
      // Constant thickness: l_M cos(alpha) = l_MTU - l_slack, l_M sin(alpha) = h.
      const double along = l_mtu - p.tendon_slack_length_m;
      CHECK(k.fiber_length_m == Approx(std::hypot(along, h)).epsilon(1e-12));
      CHECK(k.cos_pennation == Approx(along / std::hypot(along, h)).epsilon(1e-12));
      // d l_M / dt = cos(alpha) d l_MTU / dt (differentiate l_M^2 = along^2 + h^2).
      CHECK(k.fiber_velocity_m_s == Approx(v * along / std::hypot(along, h)).epsilon(1e-12));
    }
  }
}

TEST_CASE("compliant tendon: a quasi-static stretch converges to the equilibrium fibre length",
          "[muscles]") {
  constexpr double kStretch_m = 0.02, kDuration_s = 4.0, kHold_s = 4.0, kDt = 0.002;
  constexpr double kHoldDt = 0.010;
  // Lag behind equilibrium while stretching at 5 mm/s (fibre ~1% of v_max), and what is left
  // after holding 4 s (relaxation time ~0.15 s at full activation).
  constexpr double kLagTolerance_lopt = 0.02, kSettledTolerance_m = 1e-9;
  const MuscleParams p = soleus_like();
  for (double activation : {1.0, 0.5, 0.0}) {
    INFO("activation " << activation);
    const double l0 = optimal_mtu_length(p) - 0.01;
    double x = equilibrium_fiber_length(p, activation, l0);
    double worst_lag = 0.0;
    const int n = static_cast<int>(kDuration_s / kDt);
    for (int i = 1; i <= n; ++i) {
      const double l = l0 + kStretch_m * i / n;
      const MuscleKinematics k = compliant_tendon_step(p, activation, x, l, kDt);
      REQUIRE(k.converged);
      x = k.fiber_length_m;
      worst_lag = std::max(worst_lag, std::abs(x - equilibrium_fiber_length(p, activation, l)));
    }
    CHECK(worst_lag < kLagTolerance_lopt * p.optimal_fiber_length_m);
    const double l1 = l0 + kStretch_m;
    for (int i = 0; i < static_cast<int>(kHold_s / kHoldDt); ++i) {
      x = compliant_tendon_step(p, activation, x, l1, kHoldDt).fiber_length_m;
    }
    const double eq = equilibrium_fiber_length(p, activation, l1);
    CHECK(std::abs(x - eq) < kSettledTolerance_m);
    // The equilibrium balances: tendon force = fibre force along the tendon, at rest.
    const MuscleKinematics rest = compliant_tendon_step(p, activation, eq, l1, kDt);
    CHECK(rest.fiber_length_m == Approx(eq).epsilon(1e-9));
    CHECK(std::abs(rest.fiber_velocity_m_s) < 1e-6);
  }
}

TEST_CASE("compliant tendon: stable at dt 2 ms and 10 ms under a sinusoidal MTU length",
          "[muscles]") {
  constexpr double kAmplitude_m = 0.025, kFrequency_Hz = 2.0, kDuration_s = 2.0;
  constexpr double kForceBound_Fmax = 2.5;  // plateau 1.4 plus passive force at l~ <= 1.6
  const MuscleParams p = soleus_like();
  const double mid = optimal_mtu_length(p);
  for (double dt : {0.002, 0.010}) {
    for (double activation : {1.0, 0.0}) {
      INFO("dt = " << dt << ", activation " << activation);
      double x = equilibrium_fiber_length(p, activation, mid);
      double peak_force = 0.0;
      int failures = 0;
      const int n = static_cast<int>(kDuration_s / dt);
      for (int i = 1; i <= n; ++i) {
        const double l = mid + kAmplitude_m * std::sin(2.0 * kPi * kFrequency_Hz * i * dt);
        const MuscleKinematics k = compliant_tendon_step(p, activation, x, l, dt);
        INFO("t = " << i * dt << ", l_MTU = " << l << ", l_M = " << k.fiber_length_m);
        REQUIRE(std::isfinite(k.fiber_length_m));
        REQUIRE(std::isfinite(k.tendon_force_N));
        REQUIRE(std::isfinite(k.fiber_velocity_m_s));
        REQUIRE(k.fiber_length_m >= p.min_fiber_length_m() * (1.0 - 1e-12));
        REQUIRE(k.fiber_length_m <= l);                    // within [min, path length]
        REQUIRE(k.fiber_length_m * k.cos_pennation <= l);  // and fits along the path
        REQUIRE(k.tendon_force_N >= 0.0);
        REQUIRE(k.tendon_force_N <= kForceBound_Fmax * p.max_isometric_force_N);
        failures += k.converged ? 0 : 1;
        peak_force = std::max(peak_force, k.tendon_force_N);
        x = k.fiber_length_m;
      }
      CHECK(failures == 0);
      CHECK(peak_force > 0.0);
    }
  }
}

TEST_CASE("rigid and compliant tendons agree for a very stiff tendon at slow speed", "[muscles]") {
  constexpr double kSpeed_m_s = 0.01, kDt = 0.002, kDuration_s = 2.0;
  // A stiff tendon (strain 1e-4 at F_max) stretches ~3e-5 m: the fibre differs by that, the
  // force by its force-length slope times it (< 1e-3 F_max).
  constexpr double kStiffTolerance_Fmax = 1e-3;
  MuscleParams compliant = soleus_like();
  compliant.curves.tendon_strain_at_fmax = 1e-4;
  compliant.fiber_damping = 0.0;  // the rigid tendon has no fibre damping
  MuscleParams rigid = compliant;
  rigid.tendon = TendonModel::kRigid;
  for (double activation : {1.0, 0.5}) {
    INFO("activation " << activation);
    const double l0 = optimal_mtu_length(compliant) - 0.01;
    double x = equilibrium_fiber_length(compliant, activation, l0);
    double worst = 0.0;
    for (double sign : {1.0, -1.0}) {
      for (int i = 1; i <= static_cast<int>(kDuration_s / kDt); ++i) {
        const double v = sign * kSpeed_m_s;
        const double l = sign > 0 ? l0 + v * i * kDt : l0 + kSpeed_m_s * kDuration_s + v * i * kDt;
        const MuscleKinematics c = compliant_tendon_step(compliant, activation, x, l, kDt);
        x = c.fiber_length_m;
        const MuscleKinematics r = rigid_tendon_state(rigid, activation, l, v);
        if (i > 10) worst = std::max(worst, std::abs(c.tendon_force_N - r.tendon_force_N));
      }
    }
    CHECK(worst < kStiffTolerance_Fmax * compliant.max_isometric_force_N);
  }
}

// ---- The isometric soleus (issue 25): an independent computation from Thelen 2003 ----
namespace {

// Thelen 2003, written here from the paper (not from hill_curves.cc): eq. 3 active
// force-length (gamma 0.45), eq. 2 passive (kPE 5; eps0_M the muscle's, Thelen's 0.6 or the
// anatomy table's), eq. 4 tendon (eps0_T 0.04, toe to 0.609 eps0_T with F_toe 0.33 and k_toe 3,
// then 1.712/eps0_T linear).
struct Thelen2003 {
  double eps_m = 0.6;  // passive strain at F_max
  double gamma = 0.45, k_pe = 5.0, eps_t = 0.04;

  double active(double l) const { return std::exp(-(l - 1.0) * (l - 1.0) / gamma); }
  double passive(double l) const {
    return l <= 1.0 ? 0.0 : (std::exp(k_pe * (l - 1.0) / eps_m) - 1.0) / (std::exp(k_pe) - 1.0);
  }
  double tendon(double strain) const {
    const double toe = 0.609 * eps_t;
    if (strain <= 0.0) return 0.0;
    if (strain <= toe) return 0.33 / (std::exp(3.0) - 1.0) * (std::exp(3.0 * strain / toe) - 1.0);
    return 1.712 / eps_t * (strain - toe) + 0.33;
  }
};

struct IsometricResult {
  double fiber_length_m = 0, force_N = 0;
  int sign_changes = 0;  // of the balance on a fine grid: 1 for a unique equilibrium
};

// At rest (v = 0: f_V = 1, no damping), constant-thickness pennation (sin alpha = h / l_M):
// tendon force = cos(alpha) F_max (a f_L + f_PE). Bisection on the fibre length between the
// pennation limit (fibre as short as its height) and the length that leaves the tendon slack.
IsometricResult independent_isometric(const models::MuscleDefinition& def, double activation,
                                      double l_mtu) {
  const double F_max = def.max_isometric_force_N, l_opt = def.optimal_fiber_length_m,
               l_slack = def.tendon_slack_length_m, alpha_opt = def.pennation_at_optimal_rad;
  const Thelen2003 t{def.passive_strain_at_fmax};
  const double h = l_opt * std::sin(alpha_opt);
  const auto balance = [&](double l) {
    const double along = std::sqrt(l * l - h * h);
    const double tendon = t.tendon((l_mtu - along - l_slack) / l_slack);
    const double fibre = activation * t.active(l / l_opt) + t.passive(l / l_opt);
    return tendon - along / l * fibre;
  };
  double lo = h * (1.0 + 1e-9), hi = std::hypot(l_mtu - l_slack, h);
  IsometricResult out;
  constexpr int kGrid = 2000;
  for (int i = 0; i < kGrid; ++i) {
    const double a = lo + (hi - lo) * i / kGrid, b = lo + (hi - lo) * (i + 1) / kGrid;
    out.sign_changes += (balance(a) > 0) != (balance(b) > 0) ? 1 : 0;
  }
  for (int it = 0; it < 200 && hi - lo > 1e-16; ++it) {
    const double mid = 0.5 * (lo + hi);
    (balance(mid) > 0 ? lo : hi) = mid;
  }
  out.fiber_length_m = 0.5 * (lo + hi);
  const double l = out.fiber_length_m;
  out.force_N = F_max * t.tendon((l_mtu - std::sqrt(l * l - h * h) - l_slack) / l_slack);
  return out;
}

}  // namespace

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "isometric soleus across ankle angles matches an independent Thelen computation",
                 "[muscles]") {
  constexpr double kFdStep_rad = 1e-6;
  const models::Character c = testing::muscled_character();
  const sim::Model model = sim::Model::from_string(models::to_mjcf(c));
  const mjModel& m = *model;
  sim::Data data(m);
  mjData& d = *data;
  const models::MuscleDefinition* def = nullptr;
  for (const models::MuscleDefinition& md : c.muscles) def = md.name == "soleus_r" ? &md : def;
  REQUIRE(def != nullptr);
  std::vector<MuscleParams> params = muscle_params({*def}, TendonChoice::kPerMuscle);
  REQUIRE(params[0].tendon == TendonModel::kCompliant);
  const MuscleSet set(m, params);
  const MuscleParams& p = set.params(0);
  const models::Rig rig(m);
  const int ankle_dof =
      rig.groups()[static_cast<std::size_t>(rig.leg(models::kRight).ankle)].dof_begin;
  REQUIRE(std::string(mj_id2name(&m, mjOBJ_JOINT, m.dof_jntid[ankle_dof])) ==
          "ankle_dorsiflexion_r");
  const int qadr = m.jnt_qposadr[m.dof_jntid[ankle_dof]];
  const auto path_length = [&](double angle) {
    mj_resetData(&m, &d);
    d.qpos[qadr] = angle;
    mj_kinematics(&m, &d);
    mj_comPos(&m, &d);
    mj_tendon(&m, &d);
    return set.length(d, 0);
  };
  Eigen::MatrixXd R(static_cast<Eigen::Index>(set.covered_dofs().size()), 1);
  const auto ankle_row =
      std::find(set.covered_dofs().begin(), set.covered_dofs().end(), ankle_dof) -
      set.covered_dofs().begin();
  REQUIRE(ankle_row < static_cast<Eigen::Index>(set.covered_dofs().size()));
  for (int deg = -40; deg <= 20; deg += 5) {
    const double angle = deg * kRadPerDeg;
    const double r_fd = -(path_length(angle + kFdStep_rad) - path_length(angle - kFdStep_rad)) /
                        (2.0 * kFdStep_rad);
    const double l_mtu = path_length(angle);
    set.moment_arms(m, d, &R);
    for (double activation : {1.0, 0.5}) {
      INFO("ankle " << deg << " deg, activation " << activation << ", l_MTU " << l_mtu);
      const IsometricResult want = independent_isometric(*def, activation, l_mtu);
      REQUIRE(want.sign_changes == 1);
      const double l_eq = equilibrium_fiber_length(p, activation, l_mtu);
      const MuscleKinematics got = compliant_tendon_step(p, activation, l_eq, l_mtu, 0.002);
      CHECK(got.converged);
      CHECK(got.fiber_length_m == Approx(want.fiber_length_m).epsilon(kIndependentRelative));
      CHECK(l_eq == Approx(want.fiber_length_m).epsilon(kIndependentRelative));
      CHECK(got.tendon_force_N == Approx(want.force_N).epsilon(kIndependentRelative));
      // The ankle moment: the production's generalized force against force x moment arm from
      // finite differences of MuJoCo's path length. Soleus plantarflexes: r < 0 (dorsiflexion
      // positive lengthens it).
      std::vector<double> qfrc(static_cast<std::size_t>(m.nv), 0.0);
      set.add_generalized_force(R, &got.tendon_force_N, qfrc.data());
      CHECK(r_fd < 0.0);
      CHECK(qfrc[static_cast<std::size_t>(ankle_dof)] ==
            Approx(want.force_N * r_fd).epsilon(kIndependentRelative));
    }
  }
}

}  // namespace biodyn::muscles::mtu_test
