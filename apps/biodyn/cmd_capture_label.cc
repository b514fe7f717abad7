#ifdef BIODYN_HAVE_CAPTURE
#include "cmd_capture.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <limits>

#include "biodyn/capture/evaluation.h"
#include "biodyn/mocap_io/c3d.h"
#include "biodyn/mocap_io/filter.h"
#include "biodyn/mocap_io/marker_ik.h"
#include "biodyn/mocap_io/motion_csv.h"
#include "biodyn/mocap_io/trc.h"
#include "biodyn/models/body_file.h"
#include "biodyn/models/mjcf.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/queries.h"

namespace biodyn::apps {
namespace fs = std::filesystem;
using nlohmann::json;

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kRadToDeg = 180.0 / M_PI;

/// Whether joint j moves a marker site (one on its body or a body below it): the joints the
/// marker set can see. The 26 markers put none on the toes, so their joint is invisible.
bool moves_a_marker(const mjModel& m, int j) {
  const int body = m.jnt_bodyid[j];
  for (int s = 0; s < m.nsite; ++s) {
    if (std::string(mj_id2name(&m, mjOBJ_SITE, s)).rfind("marker_", 0) != 0) continue;
    for (int b = m.site_bodyid[s]; b > 0; b = m.body_parentid[b])
      if (b == body) return true;
  }
  return false;
}

}  // namespace

std::string lower_extension(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext;
}

std::vector<std::string> marker_labels(const models::Character& character) {
  std::vector<std::string> labels;
  for (const models::Marker& m : character.markers) labels.push_back(m.name);
  return labels;
}

double LabelOptions::filter_cutoff_hz() const {
  if (filter_hz == "auto") return kNaN;
  std::size_t used = 0;
  double hz = kNaN;
  try {
    hz = std::stod(filter_hz, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != filter_hz.size() || !(hz >= 0))
    throw sim::InvalidArgument("--filter-hz: auto or a cut-off >= 0 Hz (0: unfiltered), got \"" +
                               filter_hz + "\"");
  return hz;
}

void LabelOptions::validate() const {
  filter_cutoff_hz();
  if (fill != "none" && fill != "spline" && fill != "skeleton")
    throw sim::InvalidArgument("--fill: none, spline or skeleton, got \"" + fill + "\"");
  if (!(max_gap_s >= 0 && max_gap_s <= 10))
    throw sim::InvalidArgument("--max-gap: must be 0 .. 10 s, got " + std::to_string(max_gap_s));
  if (!markers_out.empty()) {
    const std::string ext = lower_extension(markers_out);
    if (ext != ".c3d" && ext != ".trc")
      throw sim::InvalidArgument("-o: labelled markers are written as .c3d or .trc, got \"" +
                                 markers_out + "\"");
  }
}

void LabelOptions::validate_filter(double rate_hz) const {
  const double hz = filter_cutoff_hz();
  if (std::isnan(hz) || hz == 0) return;
  try {
    mocap_io::single_pass_cutoff_hz({hz}, rate_hz);
  } catch (const sim::InvalidArgument& e) {
    throw sim::InvalidArgument(std::string("--filter-hz: ") + e.what());
  }
}

std::string capture_rig_path(const std::string& dir, const std::string& given) {
  if (!given.empty()) return given;
  for (const char* name : {"rig.json", "rig_truth.json"}) {
    const fs::path p = fs::path(dir) / name;
    if (fs::exists(p)) return p.string();
  }
  throw sim::InvalidArgument(dir +
                             ": no rig.json (a calibration) or rig_truth.json (a synthetic "
                             "capture's) in it; name the rig with --rig");
}

models::CharacterSpec capture_subject(const std::string& dir, const LabelOptions& o,
                                      std::string* note) {
  if (o.subject.geometry_given()) {
    *note = "the subject from the command line";
    return o.subject.to_spec();
  }
  const fs::path about = fs::path(dir) / "capture.json";
  if (fs::exists(about)) {
    const json j = json::parse(read_file(about.string()), nullptr, false);
    if (!j.is_discarded() && j.contains("subject")) {
      *note = "the subject recorded in " + about.string();
      return models::parse_body_json(j["subject"].dump(), about.string() + ": subject");
    }
  }
  throw sim::InvalidArgument(
      "labelling needs the subject's body: give --height and --mass (and --sex), or a capture "
      "whose capture.json records its \"subject\" (capture synth writes one)");
}

LabelStage::LabelStage(const models::CharacterSpec& subject, double rate_hz,
                       const LabelTruth* truth)
    : spec_(subject),
      character_(models::generate_character(subject)),
      model_(sim::Model::from_string(models::to_mjcf(character_), "subject")),
      labels_(marker_labels(character_)),
      labeller_(model_, labels_),
      rate_hz_(rate_hz),
      truth_(truth),
      was_wrong_(labels_.size(), 0) {}

void LabelStage::add(const std::vector<capture::Point3>& points) {
  const int frame = static_cast<int>(labelled_.size());
  points_.clear();
  for (const capture::Point3& p : points) points_.push_back(p.p_W);
  const Eigen::Index n = static_cast<Eigen::Index>(labels_.size());
  Eigen::VectorXd row = Eigen::VectorXd::Constant(3 * n, kNaN);
  Eigen::VectorXd skeleton = Eigen::VectorXd::Constant(3 * n, kNaN);
  capture::LabelledFrame out;
  bool labelled = false;
  if (!labeller_.initialised()) {
    labelled = labeller_.initialise(points_, &out);
    if (labelled) {
      init_frame_ = frame;
      init_qpos_ = labeller_.qpos();
    }
  } else {
    labeller_.track(points_, &out);
    labelled = true;
  }
  if (labelled) {
    for (Eigen::Index k = 0; k < n; ++k) {
      const int j = out.point_of_label[static_cast<std::size_t>(k)];
      if (j >= 0) row.segment<3>(3 * k) = points_[static_cast<std::size_t>(j)];
      skeleton.segment<3>(3 * k) = labeller_.skeleton_markers().col(k);
      // A label back from a gap also names its point in the frame before.
      if (frame > 0 && !std::isnan(out.previous_position(0, k)))
        labelled_.back().segment<3>(3 * k) = out.previous_position.col(k);
    }
  }
  labelled_.push_back(row);
  skeleton_.push_back(skeleton);
  if (truth_ && frame < truth_->markers.frame_count())
    score_frame(points_, labelled ? out.point_of_label : std::vector<int>(labels_.size(), -1));
}

std::vector<std::pair<std::string, Eigen::Vector3d>> LabelStage::latest() const {
  std::vector<std::pair<std::string, Eigen::Vector3d>> out;
  if (labelled_.empty()) return out;
  const Eigen::VectorXd& row = labelled_.back();
  for (std::size_t k = 0; k < labels_.size(); ++k) {
    const Eigen::Vector3d p = row.segment<3>(3 * static_cast<Eigen::Index>(k));
    if (!std::isnan(p.x())) out.emplace_back(labels_[k], p);
  }
  return out;
}

void LabelStage::score_frame(const std::vector<Eigen::Vector3d>& points,
                             const std::vector<int>& point_of_label) {
  const int frame = static_cast<int>(labelled_.size()) - 1;
  const mocap_io::MarkerData& t = truth_->markers;
  for (std::size_t k = 0; k < labels_.size(); ++k) {
    const int tk = t.find(labels_[k]);
    if (tk < 0) continue;
    const Eigen::Vector3d at = t.position(frame, tk);
    bool there = false;
    for (const Eigen::Vector3d& p : points)
      there = there || (p - at).norm() < capture::kPointGate_m;
    reconstructed_ += there ? 1 : 0;
    const int j = point_of_label[k];
    const bool wrong =
        j >= 0 && (points[static_cast<std::size_t>(j)] - at).norm() >= capture::kPointGate_m;
    right_ += j >= 0 && !wrong ? 1 : 0;
    wrong_ += wrong ? 1 : 0;
    swaps_ += wrong && !was_wrong_[k] ? 1 : 0;
    was_wrong_[k] = wrong ? 1 : 0;
  }
}

json LabelStage::score_motion(const mjModel& m, const Eigen::MatrixXd& qpos) const {
  const mocap_io::Motion truth = mocap_io::read_motion_csv(truth_->motion_path);
  mocap_io::check_motion_matches(truth, m, truth_->motion_path);
  json joints = json::object();
  double sum = 0, sum_seen = 0;
  long count = 0, count_seen = 0;
  std::vector<std::string> unseen;
  std::string worst;
  double worst_rms = 0;
  for (int j = 1; j < m.njnt; ++j) {  // joint 0: the free root
    double sq = 0;
    long n = 0;
    for (Eigen::Index f = 0; f < std::min(qpos.rows(), truth.qpos.rows()); ++f) {
      if (std::isnan(qpos(f, 0))) continue;
      const double e = sim::joint_distance(m, j, truth.qpos.row(f), qpos.row(f));
      sq += e * e;
      ++n;
    }
    if (n == 0) continue;
    const double rms_deg = std::sqrt(sq / static_cast<double>(n)) * kRadToDeg;
    joints[mj_id2name(&m, mjOBJ_JOINT, j)] = rms_deg;
    sum += sq;
    count += n;
    if (moves_a_marker(m, j)) {
      sum_seen += sq;
      count_seen += n;
    } else {
      unseen.push_back(mj_id2name(&m, mjOBJ_JOINT, j));
    }
    if (rms_deg > worst_rms) {
      worst_rms = rms_deg;
      worst = mj_id2name(&m, mjOBJ_JOINT, j);
    }
  }
  const auto rms = [](double sq, long n) {
    return n ? std::sqrt(sq / static_cast<double>(n)) * kRadToDeg : 0.0;
  };
  return {{"joint_rms_deg", rms(sum, count)}, {"seen_joint_rms_deg", rms(sum_seen, count_seen)},
          {"joints_no_marker_sees", unseen},  {"worst_joint", worst},
          {"worst_joint_rms_deg", worst_rms}, {"per_joint_rms_deg", joints}};
}

json LabelStage::finish(const LabelOptions& o) {
  const int frames = static_cast<int>(labelled_.size());
  const Eigen::Index n = static_cast<Eigen::Index>(labels_.size());
  mocap_io::MarkerData markers;
  markers.rate_hz = rate_hz_;
  markers.labels = labels_;
  markers.positions_m.resize(frames, 3 * n);
  Eigen::MatrixXd skeleton(frames, 3 * n);
  for (int f = 0; f < frames; ++f) {
    markers.positions_m.row(f) = labelled_[static_cast<std::size_t>(f)].transpose();
    skeleton.row(f) = skeleton_[static_cast<std::size_t>(f)].transpose();
  }
  long observed = 0;
  for (int f = 0; f < frames; ++f)
    for (Eigen::Index k = 0; k < n; ++k)
      observed += markers.visible(f, static_cast<int>(k)) ? 1 : 0;
  capture::GapFillReport fill;
  if (o.fill != "none")
    fill = capture::fill_gaps(&markers, o.max_gap_s, o.fill == "skeleton" ? &skeleton : nullptr);
  json summary = {
      {"labelled", init_frame_ >= 0},
      {"initialised_at_frame", init_frame_},
      {"labelled_marker_frames",
       static_cast<double>(observed) /
           std::max(1.0, static_cast<double>(frames) * static_cast<double>(n))},
      {"gap_fill",
       {{"method", o.fill},
        {"max_spline_gap_s", o.max_gap_s},
        {"spline_samples", fill.spline},
        {"skeleton_samples", fill.skeleton},
        {"left_samples", fill.left},
        {"about",
         "filled samples are estimates (a cubic across a short gap; the fitted skeleton's "
         "segment carrying the marker across a long one), written as valid samples; "
         "--fill none leaves every gap"}}}};
  if (!o.markers_out.empty()) {
    if (lower_extension(o.markers_out) == ".c3d") {
      mocap_io::C3dFile file;
      file.markers = markers;
      mocap_io::write_c3d(o.markers_out, file);
    } else {
      mocap_io::write_trc(o.markers_out, markers, "mm");
    }
  }
  if (!o.motion_out.empty() || (truth_ && !truth_->motion_path.empty())) {
    const mjModel& m = labeller_.subject_model();
    // The default (weak) regularisation: the gaps are filled, and a stronger pull towards the
    // last frame lags the DOFs the markers see weakly (a shoulder's twist with the elbow
    // straight: 8 degrees behind on a walk with 1e-3). From the labeller's T-pose fit: from the
    // model's arms-down pose the first frame's 90-degree shoulder turn can end in a twisted arm
    // that every later frame keeps.
    // Reconstruction noise (0.5 px: ~2 mm a marker a frame) turns a forearm's pronation or a
    // foot's inversion, seen by markers a few centimetres apart, by degrees; one cut-off does
    // not suit every motion (6 Hz halves a noisy walk's error but blurs a lunge's foot), so by
    // default each marker gets its own from the residual analysis (Winter 2009, §3.4.4.3).
    mocap_io::MarkerData filtered = markers;
    const double hz = o.filter_cutoff_hz();
    json cutoffs = json::object();
    if (std::isnan(hz)) {
      std::vector<double> each;
      mocap_io::low_pass_markers_auto(&filtered, &each);
      for (std::size_t k = 0; k < labels_.size(); ++k) cutoffs[labels_[k]] = each[k];
    } else {
      mocap_io::low_pass_markers(&filtered, {hz});
      for (const std::string& l : labels_) cutoffs[l] = hz;
    }
    const mocap_io::MarkerIkResult ik = mocap_io::solve_marker_ik(
        m, filtered, std::vector<double>(labels_.size(), 1.0), {}, init_qpos_);
    summary["ik"] = {{"solved_frames", ik.solved_count()},
                     {"frames", frames},
                     {"marker_filter", o.filter_hz},
                     {"marker_cutoffs_hz", cutoffs},
                     {"about",
                      "the skeleton is solved from the labelled markers, each low-pass filtered "
                      "at its marker_cutoffs_hz (zero-lag Butterworth; auto: Winter's residual "
                      "analysis; 0: unfiltered); the written markers are unfiltered"}};
    if (!o.motion_out.empty()) {
      mocap_io::Motion motion;
      motion.columns = mocap_io::qpos_names(m);
      motion.qpos = ik.qpos;
      for (int f = 0; f < frames; ++f) motion.times_s.push_back(f / rate_hz_);
      mocap_io::set_motion_body(&motion, spec_);
      motion.comments.push_back(" source: biodyn capture run (labelled markers through marker IK)");
      write_file_atomically(o.motion_out, mocap_io::format_motion_csv(motion));
    }
    if (truth_ && !truth_->motion_path.empty()) summary["truth_motion"] = score_motion(m, ik.qpos);
  }
  if (truth_) {
    summary["truth"] = {
        {"reconstructed_marker_frames", reconstructed_},
        {"labelled_right",
         reconstructed_ ? static_cast<double>(right_) / static_cast<double>(reconstructed_) : 1.0},
        {"wrong_labels", wrong_},
        {"identity_swaps", swaps_}};
  }
  return summary;
}

}  // namespace biodyn::apps
#endif  // BIODYN_HAVE_CAPTURE
