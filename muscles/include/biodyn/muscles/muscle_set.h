#pragma once
/// The character's muscles bound to a compiled model: each muscle's Hill parameters
/// (muscle_tendon_unit.h) and its MuJoCo spatial tendon (models/muscle_anatomy.h writes them),
/// the DOFs the muscles span, their moment arms from MuJoCo's tendon Jacobian, and the
/// generalized force of muscle tensions applied through it. Nothing acts on the free root: a
/// tendon's length does not change when the whole body moves, so its Jacobian's root columns are
/// zero (tested).

#include <mujoco/mujoco.h>

#include <Eigen/Core>
#include <string>
#include <vector>

#include "biodyn/models/muscle_anatomy.h"
#include "biodyn/muscles/muscle_tendon_unit.h"

namespace biodyn::muscles {

/// Which tendon model the muscles use.
enum class TendonChoice {
  kPerMuscle,     ///< each muscle's default: compliant soleus and gastrocnemius, rigid others
  kAllRigid,      ///< every tendon rigid (faster; for comparison)
  kAllCompliant,  ///< every tendon compliant
};
/// "default" | "rigid" | "compliant"; throws sim::InvalidArgument naming `field` and the value.
TendonChoice parse_tendon_choice(const std::string& text, const std::string& field);
const char* to_string(TendonChoice choice);

/// The Hill parameters of the character's muscles (names, F_max, lengths, pennation from the
/// anatomy; time constants and curves at their Thelen 2003 defaults).
std::vector<MuscleParams> muscle_params(const std::vector<models::MuscleDefinition>& muscles,
                                        TendonChoice tendons);

/// Applies a muscle parameter file to `params`: JSON {"muscles": {"soleus":
/// {"max_isometric_force_N": 5000, "tendon": "compliant"}, "tib_ant_l": {...}}} keyed by muscle
/// name or by name without side (both sides); fields: max_isometric_force_N,
/// optimal_fiber_length_m, tendon_slack_length_m, pennation_at_optimal_deg,
/// max_contraction_velocity_lopt_per_s, activation_time_constant_s, deactivation_time_constant_s,
/// min_activation, fiber_damping, tendon, and "scale_max_isometric_force" (a factor on the
/// table's F_max). A side-specific entry wins over a side-less one; a refused file changes
/// nothing. Throws
/// sim::InvalidArgument naming `source`, the muscle, the field, the rule and the value (unknown
/// names and fields too).
void apply_muscle_overrides(const std::string& json_text, const std::string& source,
                            std::vector<MuscleParams>* params);

class MuscleSet {
 public:
  /// Binds `params` (validated) to the spatial tendons of `m` with the same names. Throws
  /// sim::InvalidArgument naming the muscle if a parameter is bad or the model has no such
  /// tendon (a model generated without --muscles).
  MuscleSet(const mjModel& m, std::vector<MuscleParams> params);

  int size() const { return static_cast<int>(params_.size()); }
  const MuscleParams& params(int i) const { return params_[static_cast<std::size_t>(i)]; }
  const std::vector<MuscleParams>& params() const { return params_; }
  int tendon(int i) const { return tendons_[static_cast<std::size_t>(i)]; }
  /// The DOFs (qvel indices, ascending) at least one muscle spans: the muscles' joints.
  const std::vector<int>& covered_dofs() const { return covered_; }
  /// For each covered DOF (same order), the muscles spanning it.
  const std::vector<std::vector<int>>& muscles_of_dof() const { return muscles_of_dof_; }

  /// m, the tendon's length and m/s its velocity (valid after mj_fwdPosition / mj_fwdVelocity).
  double length(const mjData& d, int i) const { return d.ten_length[tendons_[i]]; }
  double velocity(const mjData& d, int i) const { return d.ten_velocity[tendons_[i]]; }
  /// Moment arms r = -dl/dq on the covered DOFs (rows) of every muscle (columns), m (N m per N
  /// of tension) at the state of `d` (ten_J, sparse or dense), on the DOFs each muscle spans
  /// (0 elsewhere). `R` must be sized covered_dofs().size() x size().
  void moment_arms(const mjModel& m, const mjData& d, Eigen::MatrixXd* R) const;
  /// Adds the generalized force R F (= -J^T F on the spanned DOFs; the root's columns of J are
  /// zero) of tensions `tension_N` (size()) to `qfrc` (nv), with R from moment_arms().
  void add_generalized_force(const Eigen::MatrixXd& R, const double* tension_N, double* qfrc) const;

 private:
  std::vector<MuscleParams> params_;
  std::vector<int> tendons_;
  std::vector<int> covered_;
  std::vector<std::vector<int>> muscles_of_dof_;
  std::vector<int> row_of_dof_;                                // nv: row in covered_, or -1
  Eigen::Matrix<char, Eigen::Dynamic, Eigen::Dynamic> spans_;  // covered x muscles: 1 if spanned
};

}  // namespace biodyn::muscles
