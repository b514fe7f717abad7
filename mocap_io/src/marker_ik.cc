#include "biodyn/mocap_io/marker_ik.h"

#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include "biodyn/mocap_io/marker_labels.h"
#include "biodyn/models/rig.h"
#include "biodyn/sim/errors.h"

namespace biodyn::mocap_io {
namespace {

/// LM damping update factors (Nielsen-style: shrink after a good step, grow after a bad one).
constexpr double kDampingDecrease = 1.0 / 3.0;
constexpr double kDampingIncrease = 4.0;
constexpr double kMaxDamping = 1e8;  ///< beyond this a step cannot lower the cost: stop
constexpr double kMinDamping = 1e-12;
constexpr double kLimitSlack = 1e-9;  ///< rad or m: a DOF this close to a limit is on it
constexpr int kMinRootMarkers = 3;    ///< thesis: the root is placed from the 3 pelvis markers

bool finite3(const double* p) {
  return std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]);
}

/// Throws sim::InvalidArgument unless there are `count` weights, each >= 0 (`name(i)` names the
/// i-th in the message).
template <typename Name>
void check_weights(const std::vector<double>& weights, size_t count, const Name& name) {
  if (weights.size() != count) {
    throw sim::InvalidArgument("IK weights: expected one per label (" + std::to_string(count) +
                               "), got " + std::to_string(weights.size()));
  }
  for (size_t i = 0; i < weights.size(); ++i) {
    if (!(weights[i] >= 0)) {
      throw sim::InvalidArgument("IK weight of " + name(i) + ": must be >= 0, got " +
                                 std::to_string(weights[i]));
    }
  }
}

}  // namespace

void MarkerIkOptions::validate() const {
  if (max_iterations < 1) {
    throw sim::InvalidArgument("IK max_iterations: must be >= 1, got " +
                               std::to_string(max_iterations));
  }
  if (!(tolerance_m > 0)) {
    throw sim::InvalidArgument("IK tolerance_m: must be > 0, got " + std::to_string(tolerance_m));
  }
  if (!(initial_damping > 0)) {
    throw sim::InvalidArgument("IK initial_damping: must be > 0, got " +
                               std::to_string(initial_damping));
  }
  if (!(regularization >= 0)) {
    throw sim::InvalidArgument("IK regularization: must be >= 0, got " +
                               std::to_string(regularization));
  }
  if (!(max_frame_rms_m > 0)) {
    throw sim::InvalidArgument("IK max_frame_rms_m: must be > 0, got " +
                               std::to_string(max_frame_rms_m));
  }
  if (!(min_visible_fraction >= 0 && min_visible_fraction <= 1)) {
    throw sim::InvalidArgument("IK min_visible_fraction: must be within [0, 1], got " +
                               std::to_string(min_visible_fraction));
  }
}

MarkerIk::MarkerIk(const mjModel& model, const std::vector<std::string>& labels,
                   const std::vector<double>& weights, const MarkerIkOptions& options)
    : m_(model), data_(model), options_(options), ldlt_(model.nv) {
  options_.validate();
  check_weights(weights, labels.size(), [&](size_t i) { return labels[i]; });
  const models::Rig rig(model);
  for (size_t i = 0; i < labels.size(); ++i) {
    const int site = rig.marker_site(labels[i]);
    site_of_.push_back(site);
    weight_.push_back(weights[i]);
    if (site < 0) {
      unmapped_.push_back(labels[i]);
      ++unmapped_count_;
    }
  }
  if (mapped_count() < kMinRootMarkers) {
    throw sim::InvalidArgument("IK: only " + std::to_string(mapped_count()) +
                               " of the capture's labels name a marker site of the character; "
                               "at least 3 are needed (check the marker set). The capture's "
                               "labels: " +
                               label_list(labels));
  }
  // The root: the body of the model's free joint (the pelvis of a generated character).
  for (int j = 0; j < m_.njnt; ++j) {
    if (m_.jnt_type[j] == mjJNT_FREE) {
      root_body_ = m_.jnt_bodyid[j];
      break;
    }
  }
  const Eigen::Index rows = 3 * static_cast<Eigen::Index>(labels.size());
  jacobian_ = Eigen::MatrixXd::Zero(rows, m_.nv);
  residual_ = Eigen::VectorXd::Zero(rows);
  jtj_ = Eigen::MatrixXd::Zero(m_.nv, m_.nv);
  system_ = Eigen::MatrixXd::Zero(m_.nv, m_.nv);
  jtr_ = Eigen::VectorXd::Zero(m_.nv);
  rhs_ = Eigen::VectorXd::Zero(m_.nv);
  step_ = Eigen::VectorXd::Zero(m_.nv);
  jac_site_.assign(3 * static_cast<size_t>(m_.nv), 0.0);
  trial_qpos_.assign(static_cast<size_t>(m_.nq), 0.0);
}

double MarkerIk::evaluate(const double* targets_m, const mjtNum* qpos, bool with_jacobian) {
  mjData* d = data_.get();
  mju_copy(d->qpos, qpos, m_.nq);
  mj_kinematics(&m_, d);
  if (with_jacobian) mj_comPos(&m_, d);  // cdof, needed by the Jacobians
  double cost = 0.0;
  for (size_t i = 0; i < site_of_.size(); ++i) {
    const int site = site_of_[i];
    const double* target = targets_m + 3 * i;
    const Eigen::Index row = 3 * static_cast<Eigen::Index>(i);
    if (site < 0 || weight_[i] == 0.0 || !finite3(target)) {
      residual_.segment<3>(row).setZero();
      if (with_jacobian) jacobian_.middleRows<3>(row).setZero();
      continue;
    }
    const double sw = std::sqrt(weight_[i]);
    for (int k = 0; k < 3; ++k) {
      residual_(row + k) = sw * (target[k] - d->site_xpos[3 * site + k]);
    }
    cost += residual_.segment<3>(row).squaredNorm();
    if (with_jacobian) {
      mj_jacSite(&m_, d, jac_site_.data(), nullptr, site);
      for (int k = 0; k < 3; ++k) {
        for (int v = 0; v < m_.nv; ++v) {
          jacobian_(row + k, v) = sw * jac_site_[static_cast<size_t>(k * m_.nv + v)];
        }
      }
    }
  }
  return cost;
}

void MarkerIk::project_limits(mjtNum* qpos) const {
  for (int j = 0; j < m_.njnt; ++j) {
    if (!m_.jnt_limited[j]) continue;
    const int a = m_.jnt_qposadr[j];
    const double lo = m_.jnt_range[2 * j], hi = m_.jnt_range[2 * j + 1];
    switch (m_.jnt_type[j]) {
      case mjJNT_HINGE:
      case mjJNT_SLIDE:
        qpos[a] = std::min(std::max(qpos[a], lo), hi);
        break;
      case mjJNT_BALL: {  // range[1]: the largest rotation angle (MuJoCo's ball limit)
        Eigen::Quaterniond q(qpos[a], qpos[a + 1], qpos[a + 2], qpos[a + 3]);
        q.normalize();
        if (q.w() < 0) q.coeffs() *= -1;
        const Eigen::AngleAxisd aa(q);
        if (aa.angle() > hi) {
          q = Eigen::Quaterniond(Eigen::AngleAxisd(hi, aa.axis()));
        }
        qpos[a] = q.w();
        qpos[a + 1] = q.x();
        qpos[a + 2] = q.y();
        qpos[a + 3] = q.z();
        break;
      }
      case mjJNT_FREE:
        break;
    }
  }
}

void MarkerIk::place_root(const double* targets_m, mjtNum* qpos) {
  // Rigid fit (Kabsch) of the visible root-body markers: their sites in the root frame (the
  // site offsets) against their captured positions.
  Eigen::Matrix3Xd local(3, 0), world(3, 0);
  for (size_t i = 0; i < site_of_.size(); ++i) {
    const int site = site_of_[i];
    if (site < 0 || m_.site_bodyid[site] != root_body_ || !finite3(targets_m + 3 * i)) continue;
    local.conservativeResize(3, local.cols() + 1);
    world.conservativeResize(3, world.cols() + 1);
    local.col(local.cols() - 1) = Eigen::Vector3d(m_.site_pos + 3 * site);
    world.col(world.cols() - 1) = Eigen::Vector3d(targets_m + 3 * i);
  }
  const Eigen::Vector3d lc = local.rowwise().mean(), wc = world.rowwise().mean();
  const Eigen::Matrix3d h = (local.colwise() - lc) * (world.colwise() - wc).transpose();
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(h, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d fix = Eigen::Matrix3d::Identity();
  fix(2, 2) = (svd.matrixV() * svd.matrixU().transpose()).determinant() < 0 ? -1.0 : 1.0;
  const Eigen::Matrix3d r = svd.matrixV() * fix * svd.matrixU().transpose();
  const Eigen::Vector3d t = wc - r * lc;
  const int a = m_.jnt_qposadr[m_.body_jntadr[root_body_]];
  const Eigen::Quaterniond q(r);
  qpos[a] = t.x();
  qpos[a + 1] = t.y();
  qpos[a + 2] = t.z();
  qpos[a + 3] = q.w();
  qpos[a + 4] = q.x();
  qpos[a + 5] = q.y();
  qpos[a + 6] = q.z();
}

void MarkerIk::hold_dofs_at_limits(const mjtNum* qpos) {
  // Active set for hinge and slide limits: a DOF sitting on a limit whose descent direction
  // (J' r) points out of the range is held this iteration, so the other DOFs take the step
  // instead of it being projected away iteration after iteration.
  for (int j = 0; j < m_.njnt; ++j) {
    const mjtJoint type = static_cast<mjtJoint>(m_.jnt_type[j]);
    if (!m_.jnt_limited[j] || (type != mjJNT_HINGE && type != mjJNT_SLIDE)) continue;
    const int a = m_.jnt_qposadr[j], v = m_.jnt_dofadr[j];
    const double lo = m_.jnt_range[2 * j], hi = m_.jnt_range[2 * j + 1];
    const bool out_low = qpos[a] <= lo + kLimitSlack && rhs_(v) < 0;
    const bool out_high = qpos[a] >= hi - kLimitSlack && rhs_(v) > 0;
    if (!out_low && !out_high) continue;
    system_.row(v).setZero();
    system_.col(v).setZero();
    system_(v, v) = 1.0;
    rhs_(v) = 0.0;
  }
}

MarkerIkFrame MarkerIk::solve(const double* targets_m, bool have_previous, mjtNum* qpos) {
  MarkerIkFrame out;
  int visible = 0, root_visible = 0;
  for (size_t i = 0; i < site_of_.size(); ++i) {
    const int site = site_of_[i];
    if (site < 0 || !finite3(targets_m + 3 * i)) continue;
    ++visible;
    if (m_.site_bodyid[site] == root_body_) ++root_visible;
    if (weight_[i] > 0) ++out.markers_used;
  }
  if (visible < options_.min_visible_fraction * mapped_count() || out.markers_used < 3 ||
      (!have_previous && root_visible < kMinRootMarkers)) {
    out.markers_used = 0;
    return out;  // too few markers: not solved, qpos untouched
  }
  if (!have_previous) place_root(targets_m, qpos);
  weight_sum_visible_ = 0.0;
  for (size_t i = 0; i < site_of_.size(); ++i) {
    if (site_of_[i] >= 0 && finite3(targets_m + 3 * i)) weight_sum_visible_ += weight_[i];
  }

  double cost = evaluate(targets_m, qpos, true);
  jtj_.noalias() = jacobian_.transpose() * jacobian_;
  jtr_.noalias() = jacobian_.transpose() * residual_;
  double damping = options_.initial_damping;
  while (out.iterations < options_.max_iterations) {
    ++out.iterations;
    // Marquardt's scaling: damp each DOF by its own curvature, plus a small floor so DOFs no
    // marker sees stay where the previous frame left them.
    system_ = jtj_;
    system_.diagonal() += damping * jtj_.diagonal();
    system_.diagonal().array() += options_.regularization;
    rhs_ = jtr_;
    hold_dofs_at_limits(qpos);
    ldlt_.compute(system_);
    step_ = ldlt_.solve(rhs_);
    mju_copy(trial_qpos_.data(), qpos, m_.nq);
    mj_integratePos(&m_, trial_qpos_.data(), step_.data(), 1.0);
    project_limits(trial_qpos_.data());
    const double trial_cost = evaluate(targets_m, trial_qpos_.data(), false);
    if (!(trial_cost < cost)) {  // rejected: damp harder and retry from the same linearisation
      damping *= kDampingIncrease;
      if (damping > kMaxDamping) break;
      continue;
    }
    mju_copy(qpos, trial_qpos_.data(), m_.nq);
    damping = std::max(damping * kDampingDecrease, kMinDamping);
    // Converged when the step moved no DOF by more than the tolerance (rad or m: about the
    // marker motion at a 1 m lever arm) or lowered the weighted RMS marker error by less.
    const double total_weight = std::max(weight_sum_visible_, 1e-12);
    const double rms_gain = std::sqrt(cost / total_weight) - std::sqrt(trial_cost / total_weight);
    if (step_.cwiseAbs().maxCoeff() < options_.tolerance_m || rms_gain < options_.tolerance_m) {
      break;
    }
    cost = evaluate(targets_m, qpos, true);
    jtj_.noalias() = jacobian_.transpose() * jacobian_;
    jtr_.noalias() = jacobian_.transpose() * residual_;
  }
  // Errors at the final pose (unweighted distances).
  mju_copy(data_->qpos, qpos, m_.nq);
  mj_kinematics(&m_, data_.get());
  double sum_sq = 0.0;
  int n = 0;
  for (size_t i = 0; i < site_of_.size(); ++i) {
    const int site = site_of_[i];
    const double* target = targets_m + 3 * i;
    if (site < 0 || weight_[i] == 0.0 || !finite3(target)) continue;
    const double e =
        (Eigen::Vector3d(target) - Eigen::Vector3d(data_->site_xpos + 3 * site)).norm();
    sum_sq += e * e;
    ++n;
    if (e > out.max_error_m) {
      out.max_error_m = e;
      out.max_error_marker = static_cast<int>(i);
    }
  }
  out.rms_error_m = n > 0 ? std::sqrt(sum_sq / n) : 0.0;
  out.solved = true;
  return out;
}

void MarkerIk::set_weights(const std::vector<double>& weights) {
  check_weights(weights, weight_.size(), [](size_t i) { return "#" + std::to_string(i); });
  std::copy(weights.begin(), weights.end(), weight_.begin());
}

Eigen::Matrix3Xd MarkerIk::marker_positions(const mjtNum* qpos) {
  mju_copy(data_->qpos, qpos, m_.nq);
  mj_kinematics(&m_, data_.get());
  Eigen::Matrix3Xd out(3, static_cast<Eigen::Index>(site_of_.size()));
  for (size_t i = 0; i < site_of_.size(); ++i) {
    const int site = site_of_[i];
    out.col(static_cast<Eigen::Index>(i)) =
        site < 0 ? Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN())
                 : Eigen::Vector3d(data_->site_xpos + 3 * site);
  }
  return out;
}

int MarkerIkResult::solved_count() const {
  return static_cast<int>(
      std::count_if(frames.begin(), frames.end(), [](const MarkerIkFrame& f) { return f.solved; }));
}

int MarkerIkResult::rejected_count() const {
  return static_cast<int>(std::count_if(frames.begin(), frames.end(),
                                        [](const MarkerIkFrame& f) { return f.rejected; }));
}

double MarkerIkResult::solved_per_second() const {
  return solved_count() / std::max(seconds, 1e-9);
}

MarkerIkResult solve_marker_ik(const mjModel& model, const MarkerData& markers,
                               const std::vector<double>& weights, const MarkerIkOptions& options,
                               const std::vector<double>& initial_qpos,
                               void (*progress)(double, void*), void* progress_user) {
  MarkerIk ik(model, markers.labels, weights, options);
  std::vector<mjtNum> qpos(model.qpos0, model.qpos0 + model.nq);
  if (!initial_qpos.empty()) {
    if (static_cast<int>(initial_qpos.size()) != model.nq) {
      throw sim::InvalidArgument("IK initial qpos: expected " + std::to_string(model.nq) +
                                 " values, got " + std::to_string(initial_qpos.size()));
    }
    qpos = initial_qpos;
  }
  MarkerIkResult result;
  const int frames = markers.frame_count();
  result.qpos =
      Eigen::MatrixXd::Constant(frames, model.nq, std::numeric_limits<double>::quiet_NaN());
  result.frames.resize(static_cast<size_t>(frames));
  // One row of targets at a time, contiguous x, y, z per marker.
  Eigen::VectorXd targets(3 * markers.marker_count());
  bool have_previous = false;
  std::vector<mjtNum> accepted = qpos;  // the last accepted pose (a rejected fit restarts here)
  const auto start = std::chrono::steady_clock::now();
  for (int f = 0; f < frames; ++f) {
    targets = markers.positions_m.row(f).transpose();
    MarkerIkFrame frame = ik.solve(targets.data(), have_previous, qpos.data());
    // Written so that a NaN fit (non-finite data) is refused too.
    if (frame.solved && !(frame.rms_error_m <= options.max_frame_rms_m)) {
      frame.solved = false;
      frame.rejected = true;
      qpos = accepted;
    }
    result.frames[static_cast<size_t>(f)] = frame;
    if (frame.solved) {
      accepted = qpos;
      have_previous = true;
      for (int k = 0; k < model.nq; ++k) result.qpos(f, k) = qpos[static_cast<size_t>(k)];
    }
    if (progress && (f % 64 == 0 || f + 1 == frames)) progress((f + 1.0) / frames, progress_user);
  }
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace biodyn::mocap_io
