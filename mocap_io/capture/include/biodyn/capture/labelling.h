#pragma once
/// Labelling of reconstructed (unlabelled) markers with the subject's skeleton-marker model
/// (thesis: T-pose initialisation, then 3D tracking with the IK-fitted skeleton predicting the
/// markers it cannot see; system.md, Motion capture; the same scheme as Vicon's labelling with
/// a calibrated subject).
///
/// Initialisation: the subject stands in a T-pose. Its points' horizontal principal axis is the
/// arm span, which leaves four headings (the span either way, and the two across it, for a
/// subject whose arms are not out); for each, the height-scaled model in its T-pose is put on
/// the points, markers assigned to points (minimum total distance), the model moved by a rigid
/// fit and then by marker IK, and assigned again, with a gate that narrows. The heading whose
/// fit labels the most markers closest wins. Each marker's place on its segment is then taken
/// from the fit (the subject calibration: a real subject's markers sit where they were stuck,
/// not where the generic model puts them).
///
/// Tracking: each label is predicted from its last two positions (constant velocity over one
/// frame: 10 ms at 100 Hz moves a foot ~1 mm off that line), or, after a gap, by the skeleton
/// fitted to the last frame; labels and points are assigned at minimum total distance within
/// gates; the skeleton is then fitted to the labelled points by marker IK.

#include <mujoco/mujoco.h>

#include <Eigen/Core>
#include <memory>
#include <string>
#include <vector>

#include "biodyn/mocap_io/marker_data.h"
#include "biodyn/mocap_io/marker_ik.h"
#include "biodyn/sim/model.h"

namespace biodyn::capture {

/// The labeller's skeleton fit (marker IK) holds the DOFs no marker sees while one is hidden
/// (a hand while its finger marker is gone) at the last frame's pose: a 0.1 rad change costs
/// (3 mm)^2, below one marker's error (MarkerIkOptions::regularization).
inline constexpr double kSkeletonRegularization = 1e-3;

/// Minimum-cost assignment (Hungarian algorithm with potentials, O(r^2 c)): per row of `cost`
/// (rows x cols, any shape) the column it gets, or -1. Pairs whose cost is >= `forbidden` are
/// never made; a row whose every pair is forbidden gets -1.
std::vector<int> min_cost_assignment(const Eigen::MatrixXd& cost, double forbidden);

struct LabellingParams {
  /// m: a T-pose fit is accepted when the RMS distance of its labelled markers is below this
  double tpose_max_rms_m = 0.03;
  /// a T-pose fit must label at least this fraction of the labels
  double tpose_min_labelled = 0.8;
  /// m: a tracked label takes a point this close to its constant-velocity prediction
  double gate_m = 0.03;
  /// m: a label in a gap takes a point this close to the skeleton's prediction of it (at the
  /// gap's first frame; the gate widens as the gap lasts)
  double reacquire_gate_m = 0.04;
  /// m: a label whose point the fitted skeleton misses by more than this is dropped (its
  /// track was another marker's or a ghost's); labelled markers fit within a few mm
  double max_residual_m = 0.025;
  /// Take each marker's place on its segment from the T-pose fit (subject calibration).
  bool calibrate_marker_sites = true;
  void validate() const;  ///< throws sim::InvalidArgument naming the field and value
};

/// One frame's labels.
struct LabelledFrame {
  std::vector<int> point_of_label;  ///< per label: index of its point in the frame, -1 = none
  int labelled = 0;                 ///< labels with a point
  bool skeleton_fitted = false;     ///< the IK fit used this frame's markers
  double fit_rms_m = 0;             ///< m, RMS distance of the labelled points to the skeleton
  /// m, 3 x labels: a label that came back from a gap this frame was also the point here in
  /// the frame before (where it was left unlabelled until it had persisted); NaN otherwise.
  Eigen::Matrix3Xd previous_position;
};

class MarkerLabeller {
 public:
  /// `subject`: the subject's character (generated from its height and mass), whose sites
  /// "marker_<label>" are the markers; every label must have one. Throws sim::InvalidArgument.
  MarkerLabeller(const sim::Model& subject, std::vector<std::string> labels,
                 const LabellingParams& params = {});
  ~MarkerLabeller();

  /// Tries to find the subject in a T-pose among `points` (m, world, z up). True when a fit is
  /// accepted: `out` gets its labels and the labeller tracks from this frame. False leaves the
  /// labeller as it was (try a later frame) and `out` without labels.
  bool initialise(const std::vector<Eigen::Vector3d>& points, LabelledFrame* out);
  /// Labels the frame after the last one (initialise first: throws std::logic_error if not).
  void track(const std::vector<Eigen::Vector3d>& points, LabelledFrame* out);

  bool initialised() const { return initialised_; }
  const std::vector<std::string>& labels() const { return labels_; }
  /// The skeleton fitted to the last frame (qpos of the subject model).
  const std::vector<double>& qpos() const { return qpos_; }
  /// m, world: every marker of the skeleton fitted to the last frame (3 x labels), where the
  /// fit puts the markers it did not see.
  const Eigen::Matrix3Xd& skeleton_markers() const { return skeleton_; }
  /// The subject model with its marker sites as calibrated at initialisation.
  const mjModel& subject_model() const { return *model_; }

 private:
  double fit_heading(const std::vector<Eigen::Vector3d>& points, double heading,
                     std::vector<double>* q, std::vector<int>* point_of_label);
  void assign(const std::vector<Eigen::Vector3d>& points, const Eigen::Matrix3Xd& predicted,
              const std::vector<double>& gates, std::vector<int>* point_of_label);
  double fit_skeleton(const std::vector<Eigen::Vector3d>& points,
                      const std::vector<int>& point_of_label, std::vector<double>* q, bool* solved);
  void predict();
  void assign_tracked(const std::vector<Eigen::Vector3d>& points, LabelledFrame* out);
  bool fit_checked(const std::vector<Eigen::Vector3d>& points, LabelledFrame* out, double* rms);
  void recover_lost(const std::vector<Eigen::Vector3d>& points, LabelledFrame* out);
  void calibrate_sites(const std::vector<Eigen::Vector3d>& points,
                       const std::vector<int>& point_of_label);

  sim::Model model_;
  std::vector<std::string> labels_;
  LabellingParams params_;
  std::vector<int> site_of_;
  std::unique_ptr<mocap_io::MarkerIk> ik_;
  bool initialised_ = false;
  std::vector<double> qpos_, qpos_fit_;
  Eigen::Matrix3Xd skeleton_, skeleton_previous_, predicted_;
  Eigen::Matrix3Xd last_, before_last_;  ///< labelled positions (NaN: none) of the last 2 frames
  std::vector<double> gates_, targets_;
  std::vector<int> gap_frames_;  ///< per label: frames since it last had a point
  std::vector<Eigen::Vector3d> unlabelled_previous_;  ///< the last frame's points left unlabelled
  Eigen::MatrixXd cost_;
  std::vector<int> origin_;  ///< per point: the last frame's unlabelled point it continues, or -1
};

/// How the gaps of labelled trajectories are filled.
struct GapFillReport {
  long spline = 0;    ///< samples filled by a cubic between the gap's ends
  long skeleton = 0;  ///< samples filled from the fitted skeleton (its segment carries them)
  long left = 0;      ///< samples left in gaps (NaN)
};

/// Fills the gaps of `markers` (labelled positions, NaN = gap). A gap of at most
/// `max_spline_gap_s` with samples on both sides gets a cubic Hermite curve between them; other
/// gaps, when `skeleton_m` is given (frames x 3 labels, the fitted skeleton's markers), get the
/// skeleton's marker moved by the offset observed at the gap's ends (blended across it) — the
/// rigid segment carries the marker. Without it they stay NaN.
GapFillReport fill_gaps(mocap_io::MarkerData* markers, double max_spline_gap_s,
                        const Eigen::MatrixXd* skeleton_m);

}  // namespace biodyn::capture
