#pragma once
/// Marker inverse kinematics (thesis: skeleton-marker model; OpenSim's InverseKinematicsTool):
/// per frame, the pose q minimising sum_i w_i |p_i(q) - m_i|^2 over the visible markers, where
/// p_i is marker site i of the character ("marker_<label>") and m_i the captured position.
/// Solved by Levenberg-Marquardt (damped least squares on the site Jacobians, step accepted
/// only if it lowers the cost), joint limits by projection after each step, warm-started from
/// the previous frame; gaps get zero weight. The root is placed first from the markers on the
/// root body (thesis: the 3 pelvis markers) with a rigid fit when there is no previous frame.

#include <mujoco/mujoco.h>

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <string>
#include <vector>

#include "biodyn/mocap_io/marker_data.h"
#include "biodyn/sim/model.h"

namespace biodyn::mocap_io {

/// Settings of the per-frame solve.
struct MarkerIkOptions {
  int max_iterations = 15;  ///< LM iterations per frame (the thesis's cap: 15)
  /// m (or rad); stop when a step moves no DOF by more than this or lowers the weighted RMS
  /// marker error by less.
  double tolerance_m = 1e-6;
  double initial_damping = 1e-3;  ///< LM lambda (relative to diag(J'J)) at the first step
  /// 1/rad^2-like regulariser added to every DOF (in m^2 per unit of q): keeps DOFs the markers
  /// do not see (e.g. arms in a lower-body set) at the previous frame instead of drifting.
  double regularization = 1e-6;
  /// A frame is solved when at least this fraction of the mapped markers is visible and the
  /// root has a pose (a previous frame, or >= 3 visible root-body markers); others are skipped.
  double min_visible_fraction = 0.5;
  /// m; solve_marker_ik refuses a frame whose RMS marker error is larger (MarkerIkFrame::
  /// rejected): no body pose is that far from every marker, so such a fit means wrong data
  /// (gaps stored as zeros, swapped labels) or a wrong body, and is not reported as solved.
  /// Good fits of a scaled body are 0.5-1.5 cm; a generic body scaled by height ~8 cm.
  double max_frame_rms_m = 0.05;

  /// Throws sim::InvalidArgument naming the field and value.
  void validate() const;
};

/// What one frame's solve found.
struct MarkerIkFrame {
  bool solved = false;        ///< false: too few markers, or rejected (qpos left as it was)
  bool rejected = false;      ///< fitted, but RMS > MarkerIkOptions::max_frame_rms_m
  int iterations = 0;         ///< LM iterations taken
  int markers_used = 0;       ///< visible mapped markers with weight > 0
  double rms_error_m = 0;     ///< m, RMS distance marker - site over the used markers
  double max_error_m = 0;     ///< m, largest distance
  int max_error_marker = -1;  ///< index into the labels of the marker with max_error_m
};

/// Marker IK for one character model and one capture's labels. Holds its own mjData and
/// buffers: solve() allocates nothing. Not thread-safe; make one per thread (it copies nothing
/// big: the model is shared read-only).
class MarkerIk {
 public:
  /// `labels` are the capture's marker labels; each is matched to the site "marker_<label>"
  /// (labels without a site are ignored and listed by unmapped()). `weights` has one weight
  /// (>= 0) per label. Throws sim::InvalidArgument if fewer than 3 labels map to sites, or for
  /// bad options or weights.
  MarkerIk(const mjModel& model, const std::vector<std::string>& labels,
           const std::vector<double>& weights, const MarkerIkOptions& options = {});

  /// Solves one frame in place: `qpos` (nq) is the warm start and receives the pose; `targets_m`
  /// has 3 * labels values (x, y, z per marker, NaN for a gap). `have_previous` false places the
  /// root first with a rigid fit of the root-body markers.
  MarkerIkFrame solve(const double* targets_m, bool have_previous, mjtNum* qpos);

  /// Replaces the weights (one per label, >= 0) for the following solves, e.g. to fade a
  /// constraint in and out over frames. Allocates nothing. Throws sim::InvalidArgument for a
  /// wrong count or a negative weight.
  void set_weights(const std::vector<double>& weights);

  /// Marker sites of every label at `qpos` (3 x labels, NaN for unmapped labels), m, world.
  Eigen::Matrix3Xd marker_positions(const mjtNum* qpos);

  const std::vector<std::string>& unmapped() const { return unmapped_; }
  int mapped_count() const { return static_cast<int>(site_of_.size()) - unmapped_count_; }

 private:
  double evaluate(const double* targets_m, const mjtNum* qpos, bool with_jacobian);
  void place_root(const double* targets_m, mjtNum* qpos);
  void project_limits(mjtNum* qpos) const;
  void hold_dofs_at_limits(const mjtNum* qpos);

  const mjModel& m_;
  sim::Data data_;
  MarkerIkOptions options_;
  std::vector<int> site_of_;  ///< per label: site id, -1 if unmapped
  std::vector<double> weight_;
  std::vector<std::string> unmapped_;
  int unmapped_count_ = 0;
  int root_body_ = 1;
  // Scratch (sized once in the constructor).
  Eigen::MatrixXd jacobian_;  ///< (3 * labels) x nv, weighted rows (zero for gaps)
  Eigen::VectorXd residual_;  ///< 3 * labels, weighted
  Eigen::MatrixXd jtj_, system_;
  Eigen::VectorXd jtr_, rhs_, step_;
  double weight_sum_visible_ = 0.0;
  // Sized in the constructor's initialiser list: LDLT(size) leaves its info unset, so assigning
  // one (a copy of that indeterminate enum) is undefined behaviour (UBSan, issue 24).
  Eigen::LDLT<Eigen::MatrixXd> ldlt_;
  std::vector<mjtNum> jac_site_;  ///< 3 x nv, one site's translational Jacobian
  std::vector<mjtNum> trial_qpos_;
};

/// Statistics of a whole capture's IK.
struct MarkerIkResult {
  Eigen::MatrixXd qpos;  ///< frames x nq (NaN rows for unsolved frames)
  std::vector<MarkerIkFrame> frames;
  double seconds = 0.0;  ///< wall time of the solves
  int solved_count() const;
  int rejected_count() const;
  /// Solved frames per second of wall time (skipped frames cost nothing and are not counted).
  double solved_per_second() const;
};

/// Runs MarkerIk over every frame of `markers` (m, in the model's world frame), starting from
/// `initial_qpos` (nq; the model's qpos0 if empty) and warm-starting each frame from the last
/// solved one. A frame fitted worse than options.max_frame_rms_m is rejected: marked unsolved
/// (NaN row), and the next frame starts from the last accepted pose. `progress` (optional) is
/// called with the fraction done.
MarkerIkResult solve_marker_ik(const mjModel& model, const MarkerData& markers,
                               const std::vector<double>& weights,
                               const MarkerIkOptions& options = {},
                               const std::vector<double>& initial_qpos = {},
                               void (*progress)(double fraction, void* user) = nullptr,
                               void* progress_user = nullptr);

}  // namespace biodyn::mocap_io
