#include "biodyn/muscles/static_optimization.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <string>

#include "biodyn/sim/errors.h"
#include "biodyn/sim/model.h"

namespace biodyn::muscles {
namespace {

/// Frames solved between two progress reports (and two reads of the clock).
constexpr int kProgressChunkFrames = 64;

void check_shape(const Eigen::MatrixXd& x, Eigen::Index rows, int cols, const char* name) {
  if (x.rows() != rows || x.cols() != cols) {
    throw sim::InvalidArgument("static optimisation: " + std::string(name) + " must be " +
                               std::to_string(rows) + " x " + std::to_string(cols) + ", got " +
                               std::to_string(x.rows()) + " x " + std::to_string(x.cols()));
  }
  for (Eigen::Index r = 0; r < x.rows(); ++r) {
    if (!x.row(r).allFinite()) {
      throw sim::InvalidArgument("static optimisation: " + std::string(name) + " row " +
                                 std::to_string(r) + " is not finite");
    }
  }
}

}  // namespace

void StaticOptimizationParams::validate() const {
  if (!(reserve_weight_per_Nm2 > 0 && std::isfinite(reserve_weight_per_Nm2))) {
    throw sim::InvalidArgument("static optimisation: reserve_weight_per_Nm2 must be > 0, got " +
                               std::to_string(reserve_weight_per_Nm2));
  }
  for (const auto& [dof, w] : reserve_weight_of_dof_per_Nm2) {
    if (!(w > 0 && std::isfinite(w))) {
      throw sim::InvalidArgument("static optimisation: reserve_weight_of_dof_per_Nm2[" +
                                 std::to_string(dof) + "] must be > 0, got " + std::to_string(w));
    }
  }
}

StaticOptimization::StaticOptimization(MuscleSet set, StaticOptimizationParams params)
    : set_(std::move(set)), params_(params), qp_(set_.size()) {
  params_.validate();
  const int n = set_.size(), k = static_cast<int>(set_.covered_dofs().size());
  R_.setZero(k, n);
  B_.setZero(k, n);
  H_.setZero(n, n);
  A_.setZero(n);
  P_.setZero(n);
  lo_.setZero(n);
  hi_.setOnes(n);
  g_.setZero(n);
  c_.setZero(k);
  weight_.setConstant(k, params_.reserve_weight_per_Nm2);
  for (const auto& [dof, w] : params_.reserve_weight_of_dof_per_Nm2) {
    const auto& covered = set_.covered_dofs();
    const auto it = std::find(covered.begin(), covered.end(), dof);
    if (it == covered.end()) {
      throw sim::InvalidArgument("static optimisation: reserve_weight_of_dof_per_Nm2: DOF " +
                                 std::to_string(dof) + " is spanned by no muscle");
    }
    weight_(it - covered.begin()) = w;
  }
  sqrt_weight_ = weight_.cwiseSqrt();
}

StaticOptimizationFrame StaticOptimization::make_frame() const {
  const int n = set_.size(), k = static_cast<int>(set_.covered_dofs().size());
  StaticOptimizationFrame f;
  f.activation.setZero(n);
  f.force_N.setZero(n);
  f.tau_Nm.setZero(k);
  f.muscle_moment_Nm.setZero(k);
  f.reserve_Nm.setZero(k);
  return f;
}

void StaticOptimization::solve(const mjModel& m, const mjData& d, const double* tau_Nm,
                               StaticOptimizationFrame* frame) {
  const int n = set_.size(), k = static_cast<int>(set_.covered_dofs().size());
  set_.moment_arms(m, d, &R_);
  for (int i = 0; i < n; ++i) {
    // Rigid tendon: F = A a + P exactly, at the path's length and velocity.
    const ForceAffine f =
        rigid_tendon_affine(set_.params(i), set_.length(d, i), set_.velocity(d, i));
    A_(i) = f.active_N;
    P_(i) = f.passive_N;
  }
  for (int row = 0; row < k; ++row) {
    frame->tau_Nm(row) = tau_Nm[set_.covered_dofs()[static_cast<std::size_t>(row)]];
  }
  // minimise a'a + (c - B a)' W (c - B a): 1/2 a'Ha + g'a with H = I + B'WB, g = -B'Wc (halved),
  // computed as B and c scaled by sqrt(W).
  c_ = frame->tau_Nm;
  c_.noalias() -= R_ * P_;
  c_.array() *= sqrt_weight_.array();
  B_.noalias() = sqrt_weight_.asDiagonal() * R_ * A_.asDiagonal();
  H_.noalias() = B_.transpose() * B_;
  H_.diagonal().array() += 1.0;
  g_.noalias() = -B_.transpose() * c_;
  const BoxQpResult r = qp_.solve(H_, g_, lo_, hi_, &frame->activation);
  frame->iterations = r.iterations;
  frame->converged = r.converged;
  frame->force_N = A_.cwiseProduct(frame->activation) + P_;
  frame->muscle_moment_Nm.noalias() = R_ * frame->force_N;
  frame->reserve_Nm = frame->tau_Nm - frame->muscle_moment_Nm;
}

StaticOptimizationResult static_optimization(const mjModel& m, StaticOptimization* so,
                                             const Eigen::MatrixXd& qpos,
                                             const Eigen::MatrixXd& qvel,
                                             const Eigen::MatrixXd& tau_Nm,
                                             const std::function<void(double)>& progress) {
  const Eigen::Index frames = qpos.rows();
  check_shape(qpos, frames, m.nq, "qpos");
  check_shape(qvel, frames, m.nv, "qvel");
  check_shape(tau_Nm, frames, m.nv, "tau_Nm");
  const int n = so->set().size(), k = static_cast<int>(so->set().covered_dofs().size());
  StaticOptimizationResult out;
  out.activation.resize(frames, n);
  out.force_N.resize(frames, n);
  out.tau_Nm.resize(frames, k);
  out.muscle_moment_Nm.resize(frames, k);
  out.reserve_Nm.resize(frames, k);
  // Kinematics only: no contacts or constraints (the ground is in tau_ID already).
  const std::unique_ptr<mjModel, sim::ModelDeleter> model(mj_copyModel(nullptr, &m));
  model->opt.disableflags |= mjDSBL_CONSTRAINT;
  sim::Data data(*model);
  mjData* d = data.get();
  StaticOptimizationFrame frame = so->make_frame();
  // Row-major copies so each frame's state and torques are contiguous.
  using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  const RowMajor q = qpos, v = qvel, tau = tau_Nm;
  for (Eigen::Index first = 0; first < frames; first += kProgressChunkFrames) {
    const Eigen::Index last = std::min<Eigen::Index>(frames, first + kProgressChunkFrames);
    const auto start = std::chrono::steady_clock::now();
    for (Eigen::Index f = first; f < last; ++f) {
      std::copy_n(q.row(f).data(), m.nq, d->qpos);
      std::copy_n(v.row(f).data(), m.nv, d->qvel);
      mj_fwdPosition(model.get(), d);
      mj_fwdVelocity(model.get(), d);
      so->solve(*model, *d, tau.row(f).data(), &frame);
      out.activation.row(f) = frame.activation.transpose();
      out.force_N.row(f) = frame.force_N.transpose();
      out.tau_Nm.row(f) = frame.tau_Nm.transpose();
      out.muscle_moment_Nm.row(f) = frame.muscle_moment_Nm.transpose();
      out.reserve_Nm.row(f) = frame.reserve_Nm.transpose();
      out.qp_iterations += frame.iterations;
      out.qp_failures += frame.converged ? 0 : 1;
    }
    out.solve_time_s +=
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (progress) progress(static_cast<double>(last) / static_cast<double>(frames));
  }
  return out;
}

}  // namespace biodyn::muscles
