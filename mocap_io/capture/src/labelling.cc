#include "biodyn/capture/labelling.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "biodyn/capture/t_pose.h"
#include "biodyn/sim/errors.h"

namespace biodyn::capture {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
/// m: the gates of the T-pose fit's assignments, from the rough heading to the fitted skeleton
/// (a subject's arms 10-20 degrees off horizontal put the hands ~20 cm from the model's).
constexpr double kTposeGates_m[] = {0.30, 0.20, 0.20, 0.12, 0.08, 0.05, 0.04, 0.04};

/// m: a point is ambiguous when a marker left unlabelled lies less than this further from it
/// than the marker that took it.
constexpr double kAmbiguity_m = 0.01;

/// m: a label in a gap looks this much further for its point per frame of the gap, up to the
/// maximum (a hidden hand turning about its wrist: ~5 cm over 20 frames of a walk).
constexpr double kGateGrowth_m = 0.003;
constexpr double kMaxReacquireGate_m = 0.10;

/// m: the subject calibration moves a marker's site only when the T-pose fit misses it by more
/// than this (a few times the reconstruction's noise).
constexpr double kCalibrateBeyond_m = 0.003;

/// Labels lost at once (and points left over) that make a frame look for them with the skeleton.
constexpr int kRecoverLost = 2;
/// m: that search's gates, narrowing as the skeleton is refitted with what it finds.
constexpr double kRecoverGates_m[] = {0.40, 0.20, 0.10, 0.05};

/// The constant-velocity gate grows by this share of the marker's last step.
constexpr double kGatePerStep = 0.5;

/// m: a point this close to a point left unlabelled in the frame before has persisted.
constexpr double kPersist_m = 0.05;

bool is_set(const Eigen::Vector3d& v) { return !std::isnan(v.x()); }

}  // namespace

std::vector<int> min_cost_assignment(const Eigen::MatrixXd& cost, double forbidden) {
  // Kuhn-Munkres with row/column potentials on the rows x (cols + rows) matrix whose extra
  // columns are "no pair" at cost `forbidden`: a pair is made only when it is cheaper than
  // leaving its row alone, and every row can be left alone, so the square-or-wide form holds.
  const int rows = static_cast<int>(cost.rows()), cols = static_cast<int>(cost.cols());
  const int width = cols + rows;
  const auto at = [&](int r, int c) {
    if (c >= cols) return forbidden;
    const double v = cost(r, c);
    return std::isnan(v) || v >= forbidden ? 2 * forbidden + 1 : v;
  };
  std::vector<double> u(static_cast<std::size_t>(rows) + 1, 0),
      v(static_cast<std::size_t>(width) + 1, 0);
  std::vector<int> row_of(static_cast<std::size_t>(width) + 1, 0),
      way(static_cast<std::size_t>(width) + 1, 0);
  std::vector<double> min_to(static_cast<std::size_t>(width) + 1);
  std::vector<char> used(static_cast<std::size_t>(width) + 1);
  const auto idx = [](int i) { return static_cast<std::size_t>(i); };
  for (int r = 1; r <= rows; ++r) {
    row_of[0] = r;
    int c0 = 0;
    std::fill(min_to.begin(), min_to.end(), std::numeric_limits<double>::infinity());
    std::fill(used.begin(), used.end(), 0);
    do {
      used[idx(c0)] = 1;
      const int r0 = row_of[idx(c0)];
      double delta = std::numeric_limits<double>::infinity();
      int c1 = 0;
      for (int c = 1; c <= width; ++c) {
        if (used[idx(c)]) continue;
        const double reduced = at(r0 - 1, c - 1) - u[idx(r0)] - v[idx(c)];
        if (reduced < min_to[idx(c)]) {
          min_to[idx(c)] = reduced;
          way[idx(c)] = c0;
        }
        if (min_to[idx(c)] < delta) {
          delta = min_to[idx(c)];
          c1 = c;
        }
      }
      for (int c = 0; c <= width; ++c) {
        if (used[idx(c)]) {
          u[idx(row_of[idx(c)])] += delta;
          v[idx(c)] -= delta;
        } else {
          min_to[idx(c)] -= delta;
        }
      }
      c0 = c1;
    } while (row_of[idx(c0)] != 0);
    do {
      const int c1 = way[idx(c0)];
      row_of[idx(c0)] = row_of[idx(c1)];
      c0 = c1;
    } while (c0 != 0);
  }
  std::vector<int> col_of_row(idx(rows), -1);
  for (int c = 1; c <= cols; ++c) {
    const int r = row_of[idx(c)];
    if (r > 0 && at(r - 1, c - 1) < forbidden) col_of_row[idx(r - 1)] = c - 1;
  }
  return col_of_row;
}

void LabellingParams::validate() const {
  const auto positive = [](double v, const char* name) {
    if (!(v > 0) || !std::isfinite(v))
      throw sim::InvalidArgument(std::string("labelling: ") + name + " must be positive, got " +
                                 std::to_string(v));
  };
  positive(tpose_max_rms_m, "tpose_max_rms_m");
  positive(gate_m, "gate_m");
  positive(reacquire_gate_m, "reacquire_gate_m");
  positive(max_residual_m, "max_residual_m");
  if (!(tpose_min_labelled > 0 && tpose_min_labelled <= 1))
    throw sim::InvalidArgument("labelling: tpose_min_labelled must be in (0, 1], got " +
                               std::to_string(tpose_min_labelled));
}

MarkerLabeller::MarkerLabeller(const sim::Model& subject, std::vector<std::string> labels,
                               const LabellingParams& params)
    : model_(subject.copy()), labels_(std::move(labels)), params_(params) {
  params_.validate();
  const mjModel& m = *model_;
  for (const std::string& l : labels_) {
    const int s = mj_name2id(&m, mjOBJ_SITE, ("marker_" + l).c_str());
    if (s < 0)
      throw sim::InvalidArgument("labelling: the subject model has no marker site for label \"" +
                                 l + "\"");
    site_of_.push_back(s);
  }
  mocap_io::MarkerIkOptions ik;
  ik.min_visible_fraction = 0.25;  // a frame of few markers still moves the skeleton
  ik.max_frame_rms_m = 0.10;
  ik.regularization = kSkeletonRegularization;
  ik_ = std::make_unique<mocap_io::MarkerIk>(m, labels_, std::vector<double>(labels_.size(), 1.0),
                                             ik);
  const Eigen::Index n = static_cast<Eigen::Index>(labels_.size());
  skeleton_.resize(3, n);
  predicted_.resize(3, n);
  last_.setConstant(3, n, kNaN);
  before_last_.setConstant(3, n, kNaN);
  gates_.resize(labels_.size());
  gap_frames_.resize(labels_.size());
  targets_.resize(3 * labels_.size());
}

MarkerLabeller::~MarkerLabeller() = default;

void MarkerLabeller::assign(const std::vector<Eigen::Vector3d>& points,
                            const Eigen::Matrix3Xd& predicted, const std::vector<double>& gates,
                            std::vector<int>* point_of_label) {
  const Eigen::Index n = predicted.cols(), p = static_cast<Eigen::Index>(points.size());
  // Costs are distances relative to each label's gate, so one "no pair" cost (1) serves all.
  Eigen::MatrixXd cost(n, p);
  for (Eigen::Index k = 0; k < n; ++k) {
    for (Eigen::Index j = 0; j < p; ++j) {
      const double d = (predicted.col(k) - points[static_cast<std::size_t>(j)]).norm();
      cost(k, j) = std::isnan(d) ? kNaN : d / gates[static_cast<std::size_t>(k)];
    }
  }
  *point_of_label = min_cost_assignment(cost, 1.0);
}

double MarkerLabeller::fit_skeleton(const std::vector<Eigen::Vector3d>& points,
                                    const std::vector<int>& point_of_label, std::vector<double>* q,
                                    bool* solved) {
  for (std::size_t k = 0; k < labels_.size(); ++k) {
    const int j = point_of_label[k];
    for (int i = 0; i < 3; ++i)
      targets_[3 * k + static_cast<std::size_t>(i)] =
          j < 0 ? kNaN : points[static_cast<std::size_t>(j)][i];
  }
  const mocap_io::MarkerIkFrame f = ik_->solve(targets_.data(), true, q->data());
  *solved = f.solved;
  return f.solved ? f.rms_error_m : std::numeric_limits<double>::infinity();
}

double MarkerLabeller::fit_heading(const std::vector<Eigen::Vector3d>& points, double heading,
                                   std::vector<double>* q, std::vector<int>* point_of_label) {
  const mjModel& m = *model_;
  *q = t_pose_qpos(m);
  const auto root = static_cast<std::size_t>(m.jnt_qposadr[0]);
  // The model's markers' horizontal centroid on the points' centroid, turned to `heading`.
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& p : points) centroid += p;
  centroid /= static_cast<double>(points.size());
  const Eigen::Quaterniond turn(Eigen::AngleAxisd(heading, Eigen::Vector3d::UnitZ()));
  Eigen::Matrix3Xd sites = ik_->marker_positions(q->data());
  const Eigen::Vector3d model_centroid = sites.rowwise().mean();
  Eigen::Vector3d root_p((*q)[root], (*q)[root + 1], (*q)[root + 2]);
  root_p = turn * (root_p - model_centroid);
  (*q)[root] = root_p.x() + centroid.x();
  (*q)[root + 1] = root_p.y() + centroid.y();
  (*q)[root + 2] = root_p.z() + model_centroid.z();
  (*q)[root + 3] = turn.w();
  (*q)[root + 4] = turn.x();
  (*q)[root + 5] = turn.y();
  (*q)[root + 6] = turn.z();
  double rms = std::numeric_limits<double>::infinity();
  std::vector<double> gates(labels_.size());
  for (std::size_t step = 0; step < std::size(kTposeGates_m); ++step) {
    sites = ik_->marker_positions(q->data());
    std::fill(gates.begin(), gates.end(), kTposeGates_m[step]);
    assign(points, sites, gates, point_of_label);
    if (step < 2) {
      // A rigid fit of the model's markers to their points first: IK from a pose 10-30 cm
      // off converges, from a heading 90 degrees off it need not.
      std::vector<Eigen::Vector3d> from, to;
      for (std::size_t k = 0; k < labels_.size(); ++k) {
        const int j = (*point_of_label)[k];
        if (j < 0) continue;
        from.push_back(sites.col(static_cast<Eigen::Index>(k)));
        to.push_back(points[static_cast<std::size_t>(j)]);
      }
      if (from.size() < 3) return std::numeric_limits<double>::infinity();
      Eigen::Matrix3Xd a(3, static_cast<Eigen::Index>(from.size())), b(3, a.cols());
      for (Eigen::Index i = 0; i < a.cols(); ++i) {
        a.col(i) = from[static_cast<std::size_t>(i)];
        b.col(i) = to[static_cast<std::size_t>(i)];
      }
      const Eigen::Matrix4d t = Eigen::umeyama(a, b, false);
      const Eigen::Matrix3d r = t.topLeftCorner<3, 3>();
      const Eigen::Vector3d p = r * Eigen::Vector3d((*q)[root], (*q)[root + 1], (*q)[root + 2]) +
                                t.topRightCorner<3, 1>();
      const Eigen::Quaterniond o =
          Eigen::Quaterniond(r) *
          Eigen::Quaterniond((*q)[root + 3], (*q)[root + 4], (*q)[root + 5], (*q)[root + 6]);
      for (int i = 0; i < 3; ++i) (*q)[root + static_cast<std::size_t>(i)] = p[i];
      (*q)[root + 3] = o.w();
      (*q)[root + 4] = o.x();
      (*q)[root + 5] = o.y();
      (*q)[root + 6] = o.z();
      continue;
    }
    bool solved = false;
    rms = fit_skeleton(points, *point_of_label, q, &solved);
    if (!solved) return std::numeric_limits<double>::infinity();
  }
  // The last assignment against the fitted skeleton. A point that an unlabelled marker of the
  // model lies about as close to is ambiguous (two foot markers and one point: a hidden heel
  // lets its label take the ankle's point); it is left for tracking to label, not guessed.
  sites = ik_->marker_positions(q->data());
  assign(points, sites, gates, point_of_label);
  std::vector<int>& of = *point_of_label;
  // Likewise two labels whose points, swapped, would fit almost as well.
  const std::vector<int> assigned = of;
  const auto dist = [&](std::size_t k, int j) {
    return (sites.col(static_cast<Eigen::Index>(k)) - points[static_cast<std::size_t>(j)]).norm();
  };
  for (std::size_t k = 0; k < of.size(); ++k) {
    if (assigned[k] < 0) continue;
    const double d = dist(k, assigned[k]);
    for (std::size_t other = 0; other < of.size(); ++other) {
      if (other == k) continue;
      if (assigned[other] < 0) {
        if (dist(other, assigned[k]) < d + kAmbiguity_m) of[k] = -1;
      } else if (dist(k, assigned[other]) + dist(other, assigned[k]) <
                 d + dist(other, assigned[other]) + kAmbiguity_m) {
        of[k] = -1;
      }
    }
  }
  return rms;
}

bool MarkerLabeller::initialise(const std::vector<Eigen::Vector3d>& points, LabelledFrame* out) {
  const std::size_t n = labels_.size();
  out->point_of_label.assign(n, -1);
  out->previous_position.setConstant(3, static_cast<Eigen::Index>(n), kNaN);
  out->labelled = 0;
  out->skeleton_fitted = false;
  out->fit_rms_m = 0;
  if (static_cast<double>(points.size()) < params_.tpose_min_labelled * static_cast<double>(n))
    return false;
  // The horizontal principal axis of the points: the arm span in a T-pose.
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (const Eigen::Vector3d& p : points) mean += p.head<2>();
  mean /= static_cast<double>(points.size());
  Eigen::Matrix2d cov = Eigen::Matrix2d::Zero();
  for (const Eigen::Vector3d& p : points) {
    const Eigen::Vector2d d = p.head<2>() - mean;
    cov += d * d.transpose();
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(cov);
  const Eigen::Vector2d span = eig.eigenvectors().col(1);
  // The model's left (+y) along the span: heading = angle(span) - 90 degrees; and the others.
  const double base = std::atan2(span.y(), span.x()) - M_PI / 2;
  double best = std::numeric_limits<double>::infinity();
  int best_labelled = -1;
  std::vector<double> q, best_q;
  std::vector<int> labels_of, best_labels;
  for (int h = 0; h < 4; ++h) {
    const double rms = fit_heading(points, base + h * M_PI / 2, &q, &labels_of);
    const int labelled = static_cast<int>(
        std::count_if(labels_of.begin(), labels_of.end(), [](int j) { return j >= 0; }));
    // More markers labelled wins; at equal count, the closer fit.
    if (labelled > best_labelled || (labelled == best_labelled && rms < best)) {
      best = rms;
      best_labelled = labelled;
      best_q = q;
      best_labels = labels_of;
    }
  }
  if (!(best < params_.tpose_max_rms_m) ||
      best_labelled < params_.tpose_min_labelled * static_cast<double>(n))
    return false;
  qpos_ = best_q;
  if (params_.calibrate_marker_sites) {
    calibrate_sites(points, best_labels);
    bool solved = false;
    fit_skeleton(points, best_labels, &qpos_, &solved);
  }
  initialised_ = true;
  last_.setConstant(kNaN);
  before_last_.setConstant(kNaN);
  out->point_of_label = best_labels;
  out->labelled = best_labelled;
  out->skeleton_fitted = true;
  out->fit_rms_m = best;
  for (std::size_t k = 0; k < n; ++k) {
    if (best_labels[k] >= 0)
      last_.col(static_cast<Eigen::Index>(k)) = points[static_cast<std::size_t>(best_labels[k])];
  }
  skeleton_ = ik_->marker_positions(qpos_.data());
  skeleton_previous_ = skeleton_;
  for (std::size_t k = 0; k < n; ++k) gap_frames_[k] = best_labels[k] >= 0 ? 0 : 1;
  unlabelled_previous_.clear();
  for (std::size_t j = 0; j < points.size(); ++j) {
    if (std::find(best_labels.begin(), best_labels.end(), static_cast<int>(j)) == best_labels.end())
      unlabelled_previous_.push_back(points[j]);
  }
  return true;
}

void MarkerLabeller::calibrate_sites(const std::vector<Eigen::Vector3d>& points,
                                     const std::vector<int>& point_of_label) {
  mjModel& m = *model_;
  sim::Data data(m);
  for (int i = 0; i < m.nq; ++i) data->qpos[i] = qpos_[static_cast<std::size_t>(i)];
  mj_kinematics(&m, data.get());
  for (std::size_t k = 0; k < labels_.size(); ++k) {
    const int j = point_of_label[k];
    if (j < 0) continue;
    const int s = site_of_[k], b = m.site_bodyid[s];
    const Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> r(data->xmat + 9 * b);
    // A marker the fit already meets within the noise keeps the model's place: moving it by
    // a millimetre lets weakly seen DOFs (a straight arm's twist) settle elsewhere for good.
    if ((points[static_cast<std::size_t>(j)] - Eigen::Vector3d(data->site_xpos + 3 * s)).norm() <
        kCalibrateBeyond_m)
      continue;
    const Eigen::Vector3d local =
        r.transpose() * (points[static_cast<std::size_t>(j)] - Eigen::Vector3d(data->xpos + 3 * b));
    for (int i = 0; i < 3; ++i) m.site_pos[3 * s + i] = local[i];
  }
}

void MarkerLabeller::predict() {
  // A label seen in the last two frames is predicted at constant velocity; one in a gap, by
  // the skeleton fitted to the last frame. The skeleton is not extrapolated: the DOFs no
  // marker sees while one is hidden would keep their last (noise-driven) velocity and carry
  // the hidden marker away (a hand turning 10 cm about its wrist over a 20-frame gap).
  for (Eigen::Index k = 0; k < predicted_.cols(); ++k) {
    const std::size_t i = static_cast<std::size_t>(k);
    if (is_set(last_.col(k)) && is_set(before_last_.col(k))) {
      predicted_.col(k) = 2 * last_.col(k) - before_last_.col(k);
      // A fast marker's next step is less certain (a foot at 5 m/s changes its step by
      // centimetres from one frame to the next): the gate grows with the step.
      gates_[i] = params_.gate_m + kGatePerStep * (last_.col(k) - before_last_.col(k)).norm();
    } else if (is_set(last_.col(k))) {
      // Seen once since a gap: it moves as the skeleton's marker moved over the last frame (a
      // heel in swing moves 3-4 cm a frame).
      predicted_.col(k) = last_.col(k) + skeleton_.col(k) - skeleton_previous_.col(k);
      gates_[i] = params_.gate_m;
    } else {
      // In a gap: where the skeleton puts it. The DOFs only this marker saw have stood still
      // since, so the gate widens with the gap (a hand turns about its wrist while its
      // finger marker is hidden).
      predicted_.col(k) = 2 * skeleton_.col(k) - skeleton_previous_.col(k);
      gates_[i] =
          std::min(params_.reacquire_gate_m + kGateGrowth_m * gap_frames_[i], kMaxReacquireGate_m);
    }
  }
}

void MarkerLabeller::assign_tracked(const std::vector<Eigen::Vector3d>& points,
                                    LabelledFrame* out) {
  // A label in a gap takes a point only if the point has persisted: it lies near a point left
  // unlabelled in the last frame that was itself within the label's gate (a marker coming out
  // of its gap), rather than flickered up this frame (a ghost of mismatched rays). That costs
  // every gap one frame, given back through LabelledFrame::previous_position.
  const Eigen::Index n = predicted_.cols(), np = static_cast<Eigen::Index>(points.size());
  cost_.resize(n, np);
  origin_.assign(static_cast<std::size_t>(np), -1);
  for (Eigen::Index j = 0; j < np; ++j) {
    const Eigen::Vector3d& p = points[static_cast<std::size_t>(j)];
    double nearest = kPersist_m;
    for (std::size_t u = 0; u < unlabelled_previous_.size(); ++u) {
      const double d = (unlabelled_previous_[u] - p).norm();
      if (d < nearest) {
        nearest = d;
        origin_[static_cast<std::size_t>(j)] = static_cast<int>(u);
      }
    }
    const int from = origin_[static_cast<std::size_t>(j)];
    for (Eigen::Index k = 0; k < n; ++k) {
      const std::size_t i = static_cast<std::size_t>(k);
      const double d = (predicted_.col(k) - p).norm();
      bool allowed = true;
      if (gap_frames_[i] > 0 && !is_set(last_.col(k))) {
        allowed =
            from >= 0 &&
            (unlabelled_previous_[static_cast<std::size_t>(from)] - predicted_.col(k)).norm() <
                gates_[i];
      }
      cost_(k, j) = std::isnan(d) || !allowed ? kNaN : d / gates_[i];
    }
  }
  out->point_of_label = min_cost_assignment(cost_, 1.0);
  // A label coming out of a gap does not take a point that another label left without one is
  // about as near (two hidden foot markers, one point back): it waits for a clearer frame.
  const std::vector<int> taken = out->point_of_label;
  for (Eigen::Index k = 0; k < n; ++k) {
    const std::size_t i = static_cast<std::size_t>(k);
    if (taken[i] < 0 || gap_frames_[i] == 0) continue;
    const Eigen::Vector3d& p = points[static_cast<std::size_t>(taken[i])];
    const double d = (predicted_.col(k) - p).norm();
    for (Eigen::Index o = 0; o < n; ++o) {
      if (o != k && taken[static_cast<std::size_t>(o)] < 0 &&
          (predicted_.col(o) - p).norm() < d + kAmbiguity_m)
        out->point_of_label[i] = -1;
    }
  }
  // A tracked label does not take a point nearer to where a label lost last frame was last
  // seen than to its own last point (a foot thrown sideways loses its ankle and toe; the heel's
  // guess lands on the ankle's point and the heel alone would bend the skeleton's foot to fit):
  // it joins the gap and the skeleton looks for the foot's labels together.
  for (Eigen::Index k = 0; k < n; ++k) {
    const std::size_t i = static_cast<std::size_t>(k);
    if (taken[i] < 0 || gap_frames_[i] > 0 || !is_set(last_.col(k))) continue;
    const Eigen::Vector3d& p = points[static_cast<std::size_t>(taken[i])];
    const double d = (last_.col(k) - p).norm();
    for (Eigen::Index o = 0; o < n; ++o) {
      const std::size_t io = static_cast<std::size_t>(o);
      if (o != k && taken[io] < 0 && gap_frames_[io] == 1 && is_set(before_last_.col(o)) &&
          (before_last_.col(o) - p).norm() < d)
        out->point_of_label[i] = -1;
    }
  }
  out->previous_position.setConstant(3, n, kNaN);
  for (Eigen::Index k = 0; k < n; ++k) {
    const int j = out->point_of_label[static_cast<std::size_t>(k)];
    if (j >= 0 && gap_frames_[static_cast<std::size_t>(k)] > 0 && !is_set(last_.col(k)))
      out->previous_position.col(k) =
          unlabelled_previous_[static_cast<std::size_t>(origin_[static_cast<std::size_t>(j)])];
  }
}

bool MarkerLabeller::fit_checked(const std::vector<Eigen::Vector3d>& points, LabelledFrame* out,
                                 double* rms) {
  // The skeleton from its last pose (LM needs 2-4 iterations for a frame's motion); with too
  // few markers it stays where it was.
  qpos_fit_ = qpos_;
  bool solved = false;
  *rms = fit_skeleton(points, out->point_of_label, &qpos_fit_, &solved);
  if (solved) {
    // A label the fitted skeleton puts far from its point has followed another marker's or a
    // ghost's track (its own prediction carried it there): it is dropped, back to a gap, and
    // the skeleton refitted without it.
    const Eigen::Matrix3Xd fitted = ik_->marker_positions(qpos_fit_.data());
    bool dropped = false;
    for (std::size_t k = 0; k < labels_.size(); ++k) {
      const int j = out->point_of_label[k];
      if (j < 0 ||
          (fitted.col(static_cast<Eigen::Index>(k)) - points[static_cast<std::size_t>(j)]).norm() <=
              params_.max_residual_m)
        continue;
      out->point_of_label[k] = -1;
      dropped = true;
    }
    if (dropped) {
      qpos_fit_ = qpos_;
      *rms = fit_skeleton(points, out->point_of_label, &qpos_fit_, &solved);
    }
  }
  return solved;
}

void MarkerLabeller::recover_lost(const std::vector<Eigen::Vector3d>& points, LabelledFrame* out) {
  // Labels lost together (a whole foot in a fast swing, a limb hidden for a while) come back
  // as at the T-pose: the skeleton, fitted to the markers still tracked, looks for them among
  // the points that have persisted unlabelled, with gates that narrow as the fit improves.
  std::vector<int>& of = out->point_of_label;
  std::vector<char> free(points.size(), 0);
  bool any_free = false;
  for (std::size_t j = 0; j < points.size(); ++j) {
    free[j] = origin_[j] >= 0 && std::find(of.begin(), of.end(), static_cast<int>(j)) == of.end();
    any_free = any_free || free[j];
  }
  const auto lost = static_cast<int>(std::count(of.begin(), of.end(), -1));
  if (!any_free || lost < kRecoverLost) return;
  const std::vector<int> tracked = of;
  qpos_fit_ = qpos_;
  bool solved = false;
  for (double gate : kRecoverGates_m) {
    const Eigen::Matrix3Xd sites = ik_->marker_positions(qpos_fit_.data());
    cost_.setConstant(static_cast<Eigen::Index>(labels_.size()),
                      static_cast<Eigen::Index>(points.size()), kNaN);
    for (std::size_t k = 0; k < labels_.size(); ++k) {
      if (tracked[k] >= 0) continue;
      for (std::size_t j = 0; j < points.size(); ++j)
        if (free[j])
          cost_(static_cast<Eigen::Index>(k), static_cast<Eigen::Index>(j)) =
              (sites.col(static_cast<Eigen::Index>(k)) - points[j]).norm() / gate;
    }
    const std::vector<int> found = min_cost_assignment(cost_, 1.0);
    for (std::size_t k = 0; k < labels_.size(); ++k)
      of[k] = tracked[k] >= 0 ? tracked[k] : found[k];
    qpos_fit_ = qpos_;
    fit_skeleton(points, of, &qpos_fit_, &solved);
    if (!solved) break;
  }
  // Kept: the recovered labels the final fit puts within the residual gate, unambiguous.
  const Eigen::Matrix3Xd sites = ik_->marker_positions(qpos_fit_.data());
  for (std::size_t k = 0; k < labels_.size(); ++k) {
    if (tracked[k] >= 0 || of[k] < 0) continue;
    const Eigen::Vector3d& p = points[static_cast<std::size_t>(of[k])];
    const double d = (sites.col(static_cast<Eigen::Index>(k)) - p).norm();
    bool keep = solved && d <= params_.max_residual_m;
    for (std::size_t o = 0; keep && o < labels_.size(); ++o)
      keep = o == k || of[o] >= 0 ||
             (sites.col(static_cast<Eigen::Index>(o)) - p).norm() >= d + kAmbiguity_m;
    if (!keep) {
      of[k] = -1;
      continue;
    }
    out->previous_position.col(static_cast<Eigen::Index>(k)) =
        unlabelled_previous_[static_cast<std::size_t>(origin_[static_cast<std::size_t>(of[k])])];
  }
  qpos_fit_ = qpos_;
  double rms = 0;
  if (fit_checked(points, out, &rms)) std::swap(qpos_, qpos_fit_);
}

void MarkerLabeller::track(const std::vector<Eigen::Vector3d>& points, LabelledFrame* out) {
  if (!initialised_) throw std::logic_error("MarkerLabeller::track before initialise");
  predict();
  assign_tracked(points, out);
  double rms = 0;
  bool solved = fit_checked(points, out, &rms);
  if (solved) std::swap(qpos_, qpos_fit_);
  recover_lost(points, out);
  unlabelled_previous_.clear();
  for (std::size_t j = 0; j < points.size(); ++j) {
    if (std::find(out->point_of_label.begin(), out->point_of_label.end(), static_cast<int>(j)) ==
        out->point_of_label.end())
      unlabelled_previous_.push_back(points[j]);
  }
  skeleton_previous_ = skeleton_;
  skeleton_ = ik_->marker_positions(qpos_.data());
  before_last_ = last_;
  out->labelled = 0;
  for (std::size_t k = 0; k < labels_.size(); ++k) {
    const int j = out->point_of_label[k];
    last_.col(static_cast<Eigen::Index>(k)) =
        j < 0 ? Eigen::Vector3d::Constant(kNaN) : points[static_cast<std::size_t>(j)];
    out->labelled += j >= 0 ? 1 : 0;
    gap_frames_[k] = j >= 0 ? 0 : gap_frames_[k] + 1;
  }
  out->skeleton_fitted = solved;
  out->fit_rms_m = solved ? rms : 0;
}

GapFillReport fill_gaps(mocap_io::MarkerData* markers, double max_spline_gap_s,
                        const Eigen::MatrixXd* skeleton_m) {
  GapFillReport report;
  const int frames = markers->frame_count();
  const int max_spline = static_cast<int>(std::floor(max_spline_gap_s * markers->rate_hz + 1e-9));
  Eigen::MatrixXd& x = markers->positions_m;
  const auto seen = [&](int f, int k) { return f >= 0 && f < frames && !std::isnan(x(f, 3 * k)); };
  for (int k = 0; k < markers->marker_count(); ++k) {
    for (int f = 0; f < frames;) {
      if (seen(f, k)) {
        ++f;
        continue;
      }
      int end = f;
      while (end < frames && !seen(end, k)) ++end;  // gap: [f, end)
      const int a = f - 1, b = end, length = end - f;
      const bool both = seen(a, k) && seen(b, k);
      for (int c = 0; c < 3; ++c) {
        const int col = 3 * k + c;
        if (both && length <= max_spline) {
          // Cubic Hermite between the last sample before and the first after, with the
          // velocities (per frame) the neighbouring samples give (one-sided if need be).
          const double p0 = x(a, col), p1 = x(b, col);
          const double m0 = seen(a - 1, k) ? p0 - x(a - 1, col) : (p1 - p0) / (length + 1);
          const double m1 = seen(b + 1, k) ? x(b + 1, col) - p1 : (p1 - p0) / (length + 1);
          const double span = length + 1;
          for (int g = f; g < end; ++g) {
            const double t = (g - a) / span, t2 = t * t, t3 = t2 * t;
            x(g, col) = (2 * t3 - 3 * t2 + 1) * p0 + (t3 - 2 * t2 + t) * span * m0 +
                        (-2 * t3 + 3 * t2) * p1 + (t3 - t2) * span * m1;
          }
        } else if (skeleton_m) {
          const Eigen::MatrixXd& s = *skeleton_m;
          const double off_a = seen(a, k) ? x(a, col) - s(a, col) : kNaN;
          const double off_b = seen(b, k) ? x(b, col) - s(b, col) : kNaN;
          for (int g = f; g < end; ++g) {
            double off = 0;
            if (!std::isnan(off_a) && !std::isnan(off_b)) {
              const double t = static_cast<double>(g - a) / (length + 1);
              off = (1 - t) * off_a + t * off_b;
            } else if (!std::isnan(off_a)) {
              off = off_a;
            } else if (!std::isnan(off_b)) {
              off = off_b;
            }
            x(g, col) = s(g, col) + off;
          }
        }
      }
      if (both && length <= max_spline) {
        report.spline += length;
      } else if (skeleton_m) {
        for (int g = f; g < end; ++g) {
          if (seen(g, k)) {
            ++report.skeleton;
          } else {
            ++report.left;  // the skeleton has no pose there (before labelling began)
          }
        }
      } else {
        report.left += length;
      }
      f = end;
    }
  }
  return report;
}

}  // namespace biodyn::capture
