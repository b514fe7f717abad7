#pragma once
/// Static optimisation (Crowninshield & Brand 1981; OpenSim's StaticOptimization): each frame of
/// a captured motion on its own, the joint torques inverse dynamics found on the DOFs the muscles
/// span shared among the muscles by
///
///   minimise  sum_i a_i^2 + sum_k w_k (r_k / 1 N m)^2
///   subject to  sum_i R_ki (A_i a_i + P_i) + r_k = tau_ID,k   (k: every DOF a muscle spans)
///               0 <= a_i <= 1,
///
/// a_i the activations, r_k the reserve torques (an ideal torque actuator per DOF that takes
/// what the muscles cannot give), R the moment arms (muscle_set.h, R = -dl/dq), F_i = A_i a_i +
/// P_i the muscle's force along its path at this frame's fibre length and velocity (active
/// force-length x force-velocity x F_max cos(alpha), and passive). This is the per-frame,
/// whole-range version of MuscleDrive's share() (muscle_drive.h) without activation dynamics.
///
/// - Rigid tendons (muscle_tendon_unit.h: rigid_tendon_affine): the fibre length follows the
///   path at every frame and its velocity is the path's velocity times cos(alpha), so F is
///   exactly affine in a and each frame is a QP. A compliant tendon's fibre state depends on the
///   history (a state integrated in time), which SO does not have; OpenSim's SO likewise treats
///   tendons as rigid. Outputs say so.
/// - The reserves are eliminated (r = tau_ID - R (A a + P)), leaving a box QP in a alone:
///   H = I + B^T W B, g = -B^T W c with B = R diag(A), c = tau_ID - R P, W = diag(w_k)
///   (box_qp.h).
/// - Why a^2, not a^3 (Crowninshield & Brand's endurance criterion): the squared sum makes each
///   frame a strictly convex QP (H = I + ... is positive definite), so the solution is unique
///   and found exactly by a finite active-set method in microseconds; it is the default of
///   OpenSim's SO (activation_exponent 2), so figures compare with the literature. Cubes need a
///   nonlinear solver, and the activation patterns they give differ little in gait.
/// - The reserve weight w (per (N m)^2) defaults to 1: OpenSim's SO reserve actuators are
///   coordinate actuators of optimal force 1 N m whose control squared is summed with the
///   activations squared, i.e. 1 N m of reserve costs as much as one muscle fully active. At the
///   optimum a muscle with torque capacity C (N m per unit activation) at activation a leaves a
///   reserve of about a / (w C): ~0.003 N m for C = 150 N m, a = 0.5. Reserves grow large only
///   where the muscles cannot give the torque (saturated, wrong direction, or no moment arm).
///
/// Lifecycle: construct (sizes everything) -> solve per frame. solve() allocates nothing and
/// throws nothing.

#include <mujoco/mujoco.h>

#include <Eigen/Core>
#include <functional>
#include <map>

#include "biodyn/muscles/box_qp.h"
#include "biodyn/muscles/muscle_set.h"

namespace biodyn::muscles {

struct StaticOptimizationParams {
  /// w: cost of a squared reserve torque per (N m)^2 against sum a^2; OpenSim's SO with reserve
  /// actuators of optimal force 1 N m (see the file comment). Finite, > 0.
  double reserve_weight_per_Nm2 = 1.0;
  /// Per DOF (qvel index): a weight replacing reserve_weight_per_Nm2 on that DOF's reserve, e.g.
  /// a cheap reserve where the muscles do not model what the joint carries (OpenSim: a reserve
  /// actuator of larger optimal force, w = 1 / F_opt^2). Empty by default. Each finite, > 0.
  std::map<int, double> reserve_weight_of_dof_per_Nm2;

  /// Throws sim::InvalidArgument naming the field and value.
  void validate() const;
};

/// One frame's solution (sized by StaticOptimization::make_frame()).
struct StaticOptimizationFrame {
  Eigen::VectorXd activation;        ///< per muscle, in [0, 1]
  Eigen::VectorXd force_N;           ///< per muscle, N, tension along the path (>= 0)
  Eigen::VectorXd tau_Nm;            ///< per covered DOF, N m: the torque to share (tau_ID)
  Eigen::VectorXd muscle_moment_Nm;  ///< per covered DOF, N m: R F
  Eigen::VectorXd reserve_Nm;        ///< per covered DOF, N m: tau_ID - R F
  int iterations = 0;                ///< active-set iterations of the QP
  bool converged = false;            ///< the QP met its KKT tolerance
};

class StaticOptimization {
 public:
  /// Every muscle of `set` takes part, with a rigid tendon whatever its params say (see the file
  /// comment). Throws sim::InvalidArgument for bad parameters or a per-DOF weight on a DOF no
  /// muscle spans.
  explicit StaticOptimization(MuscleSet set, StaticOptimizationParams params = {});

  const MuscleSet& set() const { return set_; }
  const StaticOptimizationParams& params() const { return params_; }
  /// Per covered DOF (MuscleSet::covered_dofs order), the reserve weight used, per (N m)^2.
  const Eigen::VectorXd& reserve_weights() const { return weight_; }
  /// A frame sized for this set (activations zero: a cold start).
  StaticOptimizationFrame make_frame() const;

  /// Solves one frame at the state of `d` (ten_length, ten_velocity, ten_J valid: after
  /// mj_fwdPosition and mj_fwdVelocity, or mj_forward) for the generalized forces `tau_Nm` (nv,
  /// e.g. a row of InverseDynamicsResult::generalized_force). Starts the QP from
  /// frame->activation (the previous frame's solution is a good start) and overwrites *frame.
  /// No allocation; a QP that does not converge leaves frame->converged false (its last iterate
  /// is used).
  void solve(const mjModel& m, const mjData& d, const double* tau_Nm,
             StaticOptimizationFrame* frame);

 private:
  MuscleSet set_;
  StaticOptimizationParams params_;
  BoxQp qp_;
  // Per-frame workspace (sized once).
  Eigen::MatrixXd R_, B_, H_;
  Eigen::VectorXd A_, P_, lo_, hi_, g_, c_;
  Eigen::VectorXd weight_, sqrt_weight_;  // per covered DOF
};

/// Static optimisation over a whole motion: per frame, result rows.
struct StaticOptimizationResult {
  Eigen::MatrixXd activation;        ///< frames x muscles, in [0, 1]
  Eigen::MatrixXd force_N;           ///< frames x muscles, N
  Eigen::MatrixXd tau_Nm;            ///< frames x covered DOFs, N m (tau_ID)
  Eigen::MatrixXd muscle_moment_Nm;  ///< frames x covered DOFs, N m
  Eigen::MatrixXd reserve_Nm;        ///< frames x covered DOFs, N m
  long qp_iterations = 0;            ///< summed over the frames
  int qp_failures = 0;               ///< frames whose QP did not converge
  /// s, wall-clock time of the per-frame loop only: setting the state, mj_fwdPosition and
  /// mj_fwdVelocity (contacts and constraints disabled), moment arms, Hill forces and the QP;
  /// not the set-up, inverse dynamics or any I/O.
  double solve_time_s = 0;
};

/// Runs static optimisation on every frame: `qpos` (frames x nq), `qvel` (frames x nv) and the
/// generalized forces `tau_Nm` (frames x nv) of `m` (a model whose spatial tendons `so`'s set
/// was bound to). Contacts and constraints play no part (they are disabled on a copy of `m`: the
/// ground is in tau_ID already). Each frame starts from the previous one's activations.
/// `progress` (optional) is called with the fraction done every few dozen frames. Throws
/// sim::InvalidArgument naming the argument when the sizes disagree or a value is not finite.
StaticOptimizationResult static_optimization(const mjModel& m, StaticOptimization* so,
                                             const Eigen::MatrixXd& qpos,
                                             const Eigen::MatrixXd& qvel,
                                             const Eigen::MatrixXd& tau_Nm,
                                             const std::function<void(double)>& progress = {});

}  // namespace biodyn::muscles
