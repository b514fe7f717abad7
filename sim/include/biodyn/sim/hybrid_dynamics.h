#pragma once
/// Contact-consistent hybrid dynamics: some DOFs have a prescribed acceleration, the others a
/// prescribed generalized force, and MuJoCo's own constraint model (contacts, welds, joint
/// limits, with their softness) closes the system.
///
/// Why this is the right inverse dynamics for a character standing on its feet
/// (issue 3; walking-notes.md, "the naive velocity-based controller does not stand"):
/// the naive method takes the root acceleration from the last forward dynamics and runs
/// mj_inverse; that root acceleration contradicts the joint accelerations the controller
/// asks for while a foot is on the ground, and inverse dynamics turns the mismatch into
/// huge soft-contact forces. Here the root acceleration and every constraint force are
/// unknowns solved *together* with the torques:
///
///   M a + c = tau + J' f(J a - aref)                (MuJoCo's equations of motion)
///   a_j = a_desired_j   for actuated DOFs that are not saturated
///   tau_j = 0           for unactuated DOFs (the free root: no helping hand)
///   tau_j = bound_j     for actuated DOFs whose torque would leave [min, max]
///
/// where f(.) is MuJoCo's own soft-constraint force law (mj_constraintUpdate: quadratic
/// zone, separating zone, friction-cone zone). The unknown accelerations minimise MuJoCo's
/// convex Gauss-principle cost with the prescribed accelerations held fixed, so the result
/// is exactly what mj_step2 will compute when it is given these torques: contacts stay
/// unilateral (a contact that would pull is dropped, as MuJoCo drops it), friction stays in
/// the cone, a weld holds. The saturated set is found by an active-set loop on the torque
/// bounds (hybrid dynamics, Featherstone 2008 ch. 9, with box bounds).
///
/// Closed chains: with two welded feet, arbitrary joint accelerations are inconsistent with
/// the loop; prescribed exactly, the mismatch would become internal weld force that saturates
/// the muscles. So the desired accelerations are first projected, with the least change
/// (uniform weights on actuated DOFs, the root free), onto the equality constraints'
/// reference accelerations J_eq a = aref_eq; unilateral contacts need no such step (a
/// contact that would pull simply drops).
///
/// What it neglects: (1) Euler's implicit joint damping, which scales the integrated
/// velocity change of a damped DOF by M/(M + h b) (< 4% for the lightest biodyn joints);
/// (2) contacts that appear during the step (the contact set is that of mj_step1);
/// (3) actuator forces from `ctrl` (the caller owns the torques; keep ctrl at zero or pass
/// them in qfrc_other). Newton uses MuJoCo's exact cone-zone Hessian (mj_constraintUpdate with
/// flg_coneHessian) and a backtracking line search.
///
/// No allocation after construction; call after mj_step1 (or mj_forward) on the data that
/// will be stepped, before mj_step2. It overwrites efc_force, efc_state and
/// qfrc_constraint, which mj_step2 recomputes.

#include <mujoco/mujoco.h>

#include <cstdint>
#include <vector>

namespace biodyn::sim {

/// Settings of the solve. Defaults suit the generated characters.
struct HybridDynamicsOptions {
  int max_newton_iterations = 20;      ///< per active-set pass
  int max_active_set_iterations = 10;  ///< passes over the torque bounds
  double gradient_tolerance = 1e-9;    ///< N m (or N): stop when |gradient|_inf is below
};

/// Per-call result.
struct HybridDynamicsResult {
  int newton_iterations = 0;      ///< total over all passes
  int active_set_iterations = 0;  ///< passes used
  int saturated_dofs = 0;         ///< actuated DOFs held at a bound in the answer
  bool converged = true;          ///< false: iteration cap hit (forces are still in bounds)
};

/// Preallocated solver for one model (one per thread, like the data it works on).
class HybridDynamics {
 public:
  /// Allocates work space for `m` (dense or sparse constraint Jacobians).
  explicit HybridDynamics(const mjModel& m, HybridDynamicsOptions options = {});

  /// Solves for the current state of `d`. Arrays have length nv:
  ///  - `actuated[i]`: DOF i can take a force; unactuated DOFs get exactly zero.
  ///  - `qacc_desired`, `force_min`, `force_max`: read for actuated DOFs only
  ///    (rad/s^2 or m/s^2; N m or N; force_min <= force_max).
  ///  - `qfrc_other`: every other generalized force that will act in this step on top of
  ///    MuJoCo's passive and bias forces (e.g. qfrc_applied not written by the caller,
  ///    pushes mapped with mj_applyFT), N m / N.
  /// Writes `force` (the actuated forces; 0 elsewhere) and `qacc` (the accelerations
  /// mj_step2 will produce with them).
  HybridDynamicsResult solve(const mjModel& m, mjData& d, const std::uint8_t* actuated,
                             const mjtNum* qacc_desired, const mjtNum* force_min,
                             const mjtNum* force_max, const mjtNum* qfrc_other, mjtNum* force,
                             mjtNum* qacc);

 private:
  // Newton on the unknown accelerations with the prescribed ones fixed; returns iterations.
  int minimize(const mjModel& m, mjData& d, bool* converged);
  // Cost (Gauss principle + constraint cost - work of the fixed forces) at a_; fills Ma_,
  // jar_ and (through mj_constraintUpdate) efc_force/qfrc_constraint.
  double evaluate(const mjModel& m, mjData& d, const mjtNum* a);

  HybridDynamicsOptions options_;
  int nv_ = 0;
  std::vector<mjtNum> M_;           // nv x nv dense mass matrix
  std::vector<mjtNum> b_;           // passive - bias + other, nv
  std::vector<mjtNum> a_;           // current accelerations, nv
  std::vector<mjtNum> trial_;       // line-search point, nv
  std::vector<mjtNum> Ma_;          // M a, nv
  std::vector<mjtNum> jar_;         // J a - aref, njmax
  std::vector<mjtNum> fixed_;       // prescribed force on unknown-acceleration DOFs, nv
  std::vector<int> unknown_;        // DOFs whose acceleration is unknown
  std::vector<std::uint8_t> mode_;  // per DOF: kPrescribedAcc, kZeroForce, kAtMin, kAtMax
  std::vector<mjtNum> H_;           // |unknown|^2 Hessian block (Cholesky in place)
  std::vector<mjtNum> g_;           // gradient on the unknowns
  std::vector<mjtNum> step_;        // Newton step on the unknowns
  std::vector<mjtNum> row_;         // one Jacobian row restricted to the unknowns
  std::vector<mjtNum> cone_rows_;   // one elliptic contact's rows (<= 6) on the unknowns
  std::vector<mjtNum> desired_;     // projected desired accelerations, nv
  std::vector<mjtNum> eq_lhs_;      // projection system, (6 neq)^2
  std::vector<mjtNum> eq_rhs_;      // 6 neq
  std::vector<int> eq_rows_;        // efc rows of equality constraints
  std::vector<mjtNum> J_dense_;     // efc_J expanded to dense rows (sparse models only)
  const mjtNum* J_ = nullptr;       // dense efc_J rows of the current solve

  // Projects qacc_desired onto the equality rows into desired_.
  void project_on_equalities(const mjData& d, const std::uint8_t* actuated,
                             const mjtNum* qacc_desired);
};

}  // namespace biodyn::sim
