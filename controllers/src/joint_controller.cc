#include "biodyn/controllers/joint_controller.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "biodyn/sim/errors.h"
#include "biodyn/sim/queries.h"

namespace biodyn::controllers {
namespace {

using Eigen::Quaterniond;
using Eigen::Vector3d;

std::size_t idx(int i) { return static_cast<std::size_t>(i); }

}  // namespace

const char* to_string(ControllerKind kind) {
  return kind == ControllerKind::kVelocity ? "velocity" : "pd";
}

ControllerKind parse_controller_kind(const std::string& text, const std::string& field) {
  if (text == "velocity") return ControllerKind::kVelocity;
  if (text == "pd") return ControllerKind::kPd;
  throw sim::InvalidArgument(field + ": must be 'velocity' or 'pd', got '" + text + "'");
}

JointController::JointController(const mjModel& m, std::vector<JointGroup> groups,
                                 ControllerParams params, ControllerKind kind)
    : groups_(std::move(groups)),
      params_(std::move(params)),
      kind_(kind),
      targets_(groups_.size()),
      solver_(m),
      nv_(m.nv),
      timestep_(m.opt.timestep) {
  if (params_.joints.size() != groups_.size()) {
    throw sim::InvalidArgument("joint controller: parameters for " +
                               std::to_string(params_.joints.size()) + " joints, model has " +
                               std::to_string(groups_.size()));
  }
  params_.validate(m.opt.timestep);
  const auto nv = idx(m.nv);
  actuated_.assign(nv, 0);
  for (auto* v : {&tau_max_, &rate_, &tau_prev_, &tau_, &lo_, &hi_, &qacc_des_, &qacc_pred_,
                  &error_dof_, &vel_dof_, &kp_, &kd_, &zero_})
    v->assign(nv, 0.0);
  for (const JointGroup& g : groups_)
    for (int k = 0; k < g.dof_count; ++k) actuated_[idx(g.dof_begin + k)] = 1;
  refresh_limits(m.opt.timestep);
}

void JointController::set_params(const ControllerParams& params) {
  if (params.joints.size() != groups_.size()) {
    throw sim::InvalidArgument("joint controller: parameters for " +
                               std::to_string(params.joints.size()) + " joints, expected " +
                               std::to_string(groups_.size()));
  }
  params.validate(timestep_);
  params_ = params;
  refresh_limits(timestep_);
}

void JointController::refresh_limits(double timestep) {
  for (std::size_t g = 0; g < groups_.size(); ++g) {
    const JointParams& p = params_.joints[g];
    for (int k = 0; k < groups_[g].dof_count; ++k) {
      const auto i = idx(groups_[g].dof_begin + k);
      tau_max_[i] = p.tau_max_Nm[k];
      // Paper §3.2: the torque may change by at most tau_max * dt / t_r per step.
      rate_[i] = p.tau_max_Nm[k] * timestep / p.reaction_time_s;
    }
  }
}

void JointController::set_target(int group, const Quaterniond& orientation, double reach_at_s) {
  JointTarget& t = targets_[idx(group)];
  t.orientation = orientation.normalized();
  t.reach_at_s = reach_at_s;
}

double JointController::orientation_error(const mjModel& m, const mjData& d, int group) const {
  const Quaterniond q_c = sim::relative_orientation(m, d, groups_[idx(group)].body);
  return rotation_angle(q_c.conjugate() * targets_[idx(group)].orientation);
}

void JointController::desired_motion(const mjModel& m, const mjData& d) {
  for (std::size_t gi = 0; gi < groups_.size(); ++gi) {
    const JointGroup& g = groups_[gi];
    const Quaterniond q_c = sim::relative_orientation(m, d, g.body);
    // Paper §3.2: q_t = conj(q_c) * q_d; theta v is its rotation vector (body frame).
    const Vector3d e_B = rotation_vector(q_c.conjugate() * targets_[gi].orientation);
    const double t_go = std::max(targets_[gi].reach_at_s - d.time, params_.min_time_to_go_s);
    const Vector3d w_B = e_B / t_go;  // w = theta v / t
    if (g.ball) {
      for (int k = 0; k < 3; ++k) {
        error_dof_[idx(g.dof_begin + k)] = e_B[k];
        vel_dof_[idx(g.dof_begin + k)] = w_B[k];
      }
      continue;
    }
    // Hinges: least-squares share of the body-frame rotation along each hinge axis.
    const Eigen::Map<const Eigen::Matrix<mjtNum, 3, 3, Eigen::RowMajor>> R_WB(d.xmat + 9 * g.body);
    Eigen::Matrix<double, 3, 2> A = Eigen::Matrix<double, 3, 2>::Zero();
    for (int k = 0; k < g.dof_count; ++k) {
      const int j = m.dof_jntid[g.dof_begin + k];
      A.col(k) = R_WB.transpose() * Vector3d(d.xaxis[3 * j], d.xaxis[3 * j + 1], d.xaxis[3 * j + 2]);
    }
    if (g.dof_count == 1) {
      error_dof_[idx(g.dof_begin)] = A.col(0).dot(e_B);
      vel_dof_[idx(g.dof_begin)] = A.col(0).dot(w_B);
    } else {
      const Eigen::Matrix2d AtA = A.transpose() * A;
      const Eigen::Vector2d e = AtA.ldlt().solve(A.transpose() * e_B);
      for (int k = 0; k < 2; ++k) {
        error_dof_[idx(g.dof_begin + k)] = e[k];
        vel_dof_[idx(g.dof_begin + k)] = e[k] / t_go;
      }
    }
  }
}

void JointController::reset(const mjModel& m, mjData& d) {
  for (std::size_t gi = 0; gi < groups_.size(); ++gi) {
    targets_[gi].orientation = sim::relative_orientation(m, d, groups_[gi].body);
    targets_[gi].reach_at_s = d.time;
  }
  // PD gains from natural frequency and damping ratio with the joint-space inertia here.
  for (std::size_t gi = 0; gi < groups_.size(); ++gi) {
    const JointGroup& g = groups_[gi];
    const JointParams& p = params_.joints[gi];
    const double wn = 2 * M_PI * p.pd_natural_frequency_hz;
    for (int k = 0; k < g.dof_count; ++k) {
      const int i = g.dof_begin + k;
      const double inertia = d.qM[m.dof_Madr[i]];
      kp_[idx(i)] = inertia * wn * wn;
      kd_[idx(i)] = 2 * p.pd_damping_ratio * wn * inertia;
    }
  }
  // Holding torques: the whole-body solve for zero acceleration, without the rate limit.
  for (int i = 0; i < nv_; ++i) {
    qacc_des_[idx(i)] = 0;
    lo_[idx(i)] = -tau_max_[idx(i)];
    hi_[idx(i)] = tau_max_[idx(i)];
  }
  solver_.solve(m, d, actuated_.data(), qacc_des_.data(), lo_.data(), hi_.data(), zero_.data(),
                tau_prev_.data(), qacc_pred_.data());
  tau_ = tau_prev_;
}

JointControlStatus JointController::compute(const mjModel& m, mjData& d,
                                            const mjtNum* qfrc_other, mjtNum* torque) {
  desired_motion(m, d);
  for (int i = 0; i < nv_; ++i) {
    const auto k = idx(i);
    lo_[k] = std::max(-tau_max_[k], tau_prev_[k] - rate_[k]);
    hi_[k] = std::min(tau_max_[k], tau_prev_[k] + rate_[k]);
    qacc_des_[k] = 0;
  }
  JointControlStatus status;
  if (kind_ == ControllerKind::kVelocity) {
    for (const JointGroup& g : groups_) {
      for (int k = 0; k < g.dof_count; ++k) {
        const auto i = idx(g.dof_begin + k);
        qacc_des_[i] = (vel_dof_[i] - d.qvel[i]) / params_.velocity_horizon_s;
      }
    }
    const sim::HybridDynamicsResult r =
        solver_.solve(m, d, actuated_.data(), qacc_des_.data(), lo_.data(), hi_.data(),
                      qfrc_other, tau_.data(), qacc_pred_.data());
    status.solver_iterations = r.newton_iterations;
    status.converged = r.converged;
  } else {
    for (int i = 0; i < nv_; ++i) {
      const auto k = idx(i);
      tau_[k] = actuated_[k] ? std::clamp(kp_[k] * error_dof_[k] - kd_[k] * d.qvel[i], lo_[k], hi_[k])
                             : 0.0;
    }
  }
  for (int i = 0; i < nv_; ++i) {
    const auto k = idx(i);
    torque[i] = tau_[k];
    if (!actuated_[k]) continue;
    if (tau_max_[k] > 0) status.max_torque_ratio = std::max(status.max_torque_ratio, std::abs(tau_[k]) / tau_max_[k]);
    if (tau_[k] <= lo_[k] || tau_[k] >= hi_[k]) ++status.saturated_dofs;
  }
  return status;
}

void JointController::commit() { tau_prev_ = tau_; }

}  // namespace biodyn::controllers
