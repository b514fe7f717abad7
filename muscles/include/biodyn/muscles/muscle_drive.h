#pragma once
/// Muscles driving the joints a controller wants to turn (thesis §3.4.1: muscles backed by
/// controllers with a limited range of action). Each control step:
///
///   1. the controller's wanted torques tau_w on the DOFs the muscles span are shared among the
///      muscles by a small QP (box_qp.h), as in OpenSim's Computed Muscle Control:
///        minimise  sum a_i^2 + w_b sum_k (tau_w,k - sum_i r_ki F_i(a_i))^2
///      over the activations a_i at the end of the step, bounded by what activation dynamics can
///      reach in one step from the present ones; F_i(a) is the Hill force at the end of the step,
///      affine in a: for a rigid tendon exactly; for a compliant one the backward-Euler fibre
///      step taken at both ends of the reachable range and interpolated (the tendon force this
///      step can give: a compliant muscle's force follows its activation with the tendon's lag,
///      and the sharing sees it);
///   2. the forces that act are the Hill model's at the chosen activations (activation dynamics,
///      force-length-velocity, the tendon), applied through the tendons (muscle_set.h);
///   3. the backups (the controller's remaining torque, tau_w - muscle torque) act only within
///      their range of action, which shrinks as the muscles cover more of the joint:
///        range_k,dir = tau_max,k * max(min_backup_share, 1 - C_k,dir / tau_max,k),
///      C_k,dir = sum_i F_max,i max(0, +-r_ki) in the standing pose (the muscles' torque capacity
///      in that direction). Thesis §3.4.1's rule: a joint with more of its muscles modelled
///      leaves its controller less range.
/// Whatever the muscles and backups cannot give is not applied: the body feels the muscles'
/// delays and limits. DOFs no muscle spans keep the controller's torque.
///
/// Lifecycle like the joint controllers: construct -> reset -> (compute, commit)*; a step redone
/// (honest welds) calls compute again from the same state. No allocation after construction.

#include <mujoco/mujoco.h>

#include <Eigen/Core>
#include <vector>

#include "biodyn/muscles/box_qp.h"
#include "biodyn/muscles/muscle_set.h"

namespace biodyn::muscles {

struct MuscleDriveParams {
  /// Weight of a squared backup torque, per (N m)^2, against sum a^2 ("a heavy cost on
  /// backups": 1 N m of backup costs as much as ten muscles at full activation). > 0.
  double backup_weight_per_Nm2 = 10.0;
  /// Backups keep at least this share of tau_max in each direction (a fully covered joint still
  /// has a stabilising reserve). In [0, 1].
  double min_backup_share = 0.1;

  /// Throws sim::InvalidArgument naming the field and value.
  void validate() const;
};

/// Everything of the muscles that changes from step to step (copyable: rewinds and redos).
struct MuscleDriveState {
  std::vector<double> activation;          ///< per muscle, in [min_activation, 1]
  std::vector<double> excitation;          ///< per muscle, the last step's
  std::vector<double> fiber_length_m;      ///< per muscle (compliant: the state; rigid: kinematic)
  std::vector<double> fiber_velocity_m_s;  ///< per muscle, m/s, the last step's
  /// Per muscle (compliant), m per unit activation: the last step's secant of the fibre length
  /// in the activation (where the next step's solves start).
  std::vector<double> fiber_slope_m;
  std::vector<double> tension_N;         ///< per muscle, the last step's force along the path
  std::vector<double> muscle_torque_Nm;  ///< per covered DOF, the last step's
  std::vector<double> backup_torque_Nm;  ///< per covered DOF, the last step's
  std::vector<double> wanted_torque_Nm;  ///< per covered DOF, the last step's
  /// Per covered DOF: integrals over the run of |muscle torque|, |backup torque| and the
  /// torque wanted but given by neither (N m s).
  std::vector<double> muscle_impulse_Nms, backup_impulse_Nms, missing_impulse_Nms;
  long steps = 0;
  /// Per muscle, the last QP solution's active set (-1 lower bound, +1 upper, 0 free): the next
  /// step's warm start (part of the state so a rewound run repeats bit for bit).
  std::vector<int> qp_bounds;
  int qp_failures = 0;     ///< steps whose QP did not converge (forces of its last iterate used)
  int fiber_failures = 0;  ///< compliant fibre solves that missed their tolerance
};

class MuscleDrive {
 public:
  /// `tau_max_Nm` per DOF (nv; the joint controllers'): the backups' ranges scale with it.
  /// Throws sim::InvalidArgument for bad parameters.
  MuscleDrive(const mjModel& m, MuscleSet set, const std::vector<double>& tau_max_Nm,
              MuscleDriveParams params = {});

  const MuscleSet& set() const { return set_; }
  const MuscleDriveParams& params() const { return params_; }
  /// N m, the backups' range per covered DOF: [-lower, +upper].
  const std::vector<double>& backup_lower_Nm() const { return backup_lo_; }
  const std::vector<double>& backup_upper_Nm() const { return backup_hi_; }

  /// Starts holding `tau_hold_Nm` (nv, e.g. the joint controllers' holding torques): the
  /// activations that share it best (no rate bound), fibres at rest at those activations.
  /// Needs d's positions and velocities computed (mj_forward).
  void reset(const mjModel& m, const mjData& d, const double* tau_hold_Nm);

  /// One step: muscles and backups for the wanted torques `tau_wanted_Nm` (nv); writes the
  /// muscle plus backup torque into `qfrc` (nv) on the covered DOFs, leaves the others. Needs d
  /// after mj_step1. Pending until commit(). No allocation.
  void compute(const mjModel& m, const mjData& d, const double* tau_wanted_Nm, double* qfrc);
  /// The last compute() becomes the state (call once the step is kept).
  void commit() { state_ = pending_; }

  const MuscleDriveState& state() const { return state_; }
  void restore(const MuscleDriveState& state) { state_ = pending_ = state; }

 private:
  void share(const double* tau_wanted_Nm, const Eigen::VectorXd& lo, const Eigen::VectorXd& hi);

  /// Muscles that share no DOF (the two legs) are shared out by separate QPs.
  struct Group {
    Group(const MuscleSet& set, std::vector<int> muscle_ids, std::vector<int> row_ids);
    std::vector<int> muscles, rows;  // indices into the set's muscles and covered DOFs
    // The structure of B = R diag(A) (fixed by the anatomy): per muscle (local index) the local
    // rows it spans, and the muscle pairs (a >= b) sharing a row with those rows; H's other
    // off-diagonal entries stay 0, so sums skip only exact zeros.
    std::vector<std::vector<int>> rows_of_muscle;
    std::vector<int> pair_a, pair_b, pair_rows_begin, pair_rows;
    BoxQp qp;
    Eigen::MatrixXd B, H;
    Eigen::VectorXd g, c, x, lo, hi;
    std::vector<int> bounds;
  };

  MuscleSet set_;
  MuscleDriveParams params_;
  std::vector<Group> groups_;
  std::vector<double> backup_lo_, backup_hi_;
  MuscleDriveState state_, pending_;
  // Per-step workspace (sized once).
  Eigen::MatrixXd R_;
  Eigen::VectorXd A_, P_, lo_, hi_, x_, tension_;
  // Compliant: l_M(a) ~ fiber_guess_ + pending_.fiber_slope_m * a (the step's secant).
  Eigen::VectorXd fiber_guess_;
};

}  // namespace biodyn::muscles
