#pragma once
// biodyn capture: what its subcommands share (cmd_capture*.cc). `capture run`'s labelling
// stage: each frame's 3D points labelled with the subject's skeleton-marker model
// (capture/labelling.h), gaps filled, the markers written as C3D or TRC and the skeleton's
// motion solved by marker IK; scored against a synthetic capture's truth. `capture bench`:
// the processing's speed on frames held in memory.
#include <Eigen/Core>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "biodyn/capture/blobs.h"
#include "biodyn/capture/labelling.h"
#include "biodyn/capture/reconstruct.h"
#include "biodyn/mocap_io/marker_data.h"
#include "biodyn/models/character.h"
#include "biodyn/sim/model.h"
#include "cli_common.h"

namespace biodyn::apps {

struct LabelOptions {
  std::string markers_out;  ///< -o: labelled markers, .c3d or .trc
  std::string motion_out;   ///< --motion-out: the skeleton's motion (qpos CSV)
  CharacterOptions subject;
  std::string fill = "skeleton";  ///< none | spline | skeleton
  double max_gap_s = 0.1;         ///< s, longest gap a cubic fills
  /// Low-pass cut-off of the marker trajectories marker IK solves the skeleton from (the
  /// written markers stay as reconstructed): "auto" (each marker's by Winter's residual
  /// analysis), or Hz ("0": unfiltered)
  std::string filter_hz = "auto";
  /// Hz: filter_hz as a number; NaN for "auto". Throws sim::InvalidArgument for anything else.
  double filter_cutoff_hz() const;
  bool wanted() const { return !markers_out.empty() || !motion_out.empty(); }
  /// Throws sim::InvalidArgument naming the option and value.
  void validate() const;
  /// Throws sim::InvalidArgument when --filter-hz is not below the Nyquist frequency of a
  /// capture at `rate_hz` (corrected for the filter's double pass).
  void validate_filter(double rate_hz) const;
};

/// The extension of `path`, lower case, with its dot (".c3d"; "" for none).
std::string lower_extension(const std::string& path);
/// The names of `character`'s marker sites, in its order.
std::vector<std::string> marker_labels(const models::Character& character);

/// The rig a capture is processed with: `given` (--rig), else DIR/rig.json (a calibration),
/// else DIR/rig_truth.json (a synthetic capture's truth). Throws sim::InvalidArgument when none.
std::string capture_rig_path(const std::string& dir, const std::string& given);

struct CaptureBenchOptions {
  std::string dir, rig_path, summary_path;
  int frames = 300, threads = 0;
  bool label = true, tracking_2d = true;
  capture::BlobParams blobs;
  capture::ReconstructionParams reconstruction;
  LabelOptions subject;  ///< only its --height/--mass/... (the subject to label with)
};
/// biodyn capture bench: loads frames of a recorded capture into memory, then times detection,
/// reconstruction and labelling on them.
int run_capture_bench(const CaptureBenchOptions& o);

/// The subject to label with: the command line's --height/--mass/... when given, else the
/// "subject" a synthetic capture's capture.json records (`note` says which). Throws
/// sim::InvalidArgument when neither is there.
models::CharacterSpec capture_subject(const std::string& dir, const LabelOptions& o,
                                      std::string* note);

/// A synthetic capture's truth for scoring the labels and the skeleton.
struct LabelTruth {
  mocap_io::MarkerData markers;  ///< truth/markers.trc
  std::string motion_path;       ///< truth/motion.csv ("" if absent)
};

/// Labels a capture frame by frame, then fills, writes and solves (finish).
class LabelStage {
 public:
  LabelStage(const models::CharacterSpec& subject, double rate_hz, const LabelTruth* truth);
  /// The next frame's points.
  void add(const std::vector<capture::Point3>& points);
  /// The last frame's labelled markers (label, m in W), for the overlay video.
  std::vector<std::pair<std::string, Eigen::Vector3d>> latest() const;
  /// Fills the gaps, writes the outputs `o` names, solves the motion; the summary's "labelling"
  /// part (with "truth" scores when a truth was given).
  nlohmann::json finish(const LabelOptions& o);

 private:
  void score_frame(const std::vector<Eigen::Vector3d>& points,
                   const std::vector<int>& point_of_label);
  nlohmann::json score_motion(const mjModel& m, const Eigen::MatrixXd& qpos) const;

  models::CharacterSpec spec_;
  models::Character character_;
  sim::Model model_;
  std::vector<std::string> labels_;
  capture::MarkerLabeller labeller_;
  double rate_hz_;
  const LabelTruth* truth_;
  std::vector<Eigen::VectorXd> labelled_, skeleton_;  ///< per frame: 3 x labels (NaN: none)
  std::vector<Eigen::Vector3d> points_;
  int init_frame_ = -1;
  std::vector<double> init_qpos_;  ///< the skeleton the labelling started from (its T-pose fit)
  // Truth scores: marker-frames reconstructed (a point within 1 cm), labelled right, wrong.
  long reconstructed_ = 0, right_ = 0, wrong_ = 0, swaps_ = 0;
  std::vector<char> was_wrong_;
};

}  // namespace biodyn::apps
