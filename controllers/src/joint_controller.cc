#include "biodyn/controllers/joint_controller.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "biodyn/sim/errors.h"
#include "biodyn/sim/queries.h"

namespace biodyn::controllers {
namespace {

using Eigen::Quaterniond;
using Eigen::Vector3d;

std::size_t idx(int i) { return static_cast<std::size_t>(i); }

bool in_subtree(const mjModel& m, int body, int root) {
  for (int b = body; b > 0; b = m.body_parentid[b])
    if (b == root) return true;
  return false;
}

// Moment of inertia about the axis of DOF `dof` (a line through the joint's anchor) of the
// side of the body the joint moves: its own subtree, or, when that subtree holds a support
// (a stance foot), everything else. MuJoCo's qM diagonal is always the subtree's inertia —
// a stance ankle would get the foot's 0.01 kg m^2 instead of the body's ~80 kg m^2 it
// actually turns, and a PD on that gain cannot even hold the body up.
double pd_inertia(const mjModel& m, const mjData& d, int joint_body, int dof,
                  const int* support_bodies, int n_supports) {
  const int j = m.dof_jntid[dof];
  const Vector3d p(d.xanchor[3 * j], d.xanchor[3 * j + 1], d.xanchor[3 * j + 2]);
  // Axis: a hinge's own; a ball DOF's body-frame axis.
  Vector3d a;
  if (m.jnt_type[j] == mjJNT_BALL) {
    const int k = dof - m.jnt_dofadr[j];
    a = Vector3d(d.xmat[9 * joint_body + k], d.xmat[9 * joint_body + 3 + k], d.xmat[9 * joint_body + 6 + k]);
  } else {
    a = Vector3d(d.xaxis[3 * j], d.xaxis[3 * j + 1], d.xaxis[3 * j + 2]);
  }
  bool support_below = false;
  for (int s = 0; s < n_supports; ++s)
    support_below = support_below || in_subtree(m, support_bodies[s], joint_body);
  double inertia = 0;
  for (int b = 1; b < m.nbody; ++b) {
    if (in_subtree(m, b, joint_body) == support_below) continue;
    const Vector3d c(d.xipos[3 * b], d.xipos[3 * b + 1], d.xipos[3 * b + 2]);
    const Eigen::Map<const Eigen::Matrix<mjtNum, 3, 3, Eigen::RowMajor>> R(d.ximat + 9 * b);
    const Vector3d a_B = R.transpose() * a;
    const Vector3d I_B(m.body_inertia[3 * b], m.body_inertia[3 * b + 1], m.body_inertia[3 * b + 2]);
    inertia += m.body_mass[b] * a.cross(c - p).squaredNorm() + a_B.cwiseProduct(a_B).dot(I_B);
  }
  return inertia + m.dof_armature[dof];
}

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
  window_lo_.assign(nv, -std::numeric_limits<double>::infinity());
  window_hi_.assign(nv, std::numeric_limits<double>::infinity());
  compliant_kp_.assign(nv, 0.0);
  compliant_kd_.assign(nv, 0.0);
  velocity_once_.assign(nv, 0.0);
  has_velocity_once_.assign(nv, 0);
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

void JointController::limit_torque_once(int dof, double lo, double hi) {
  window_lo_[idx(dof)] = std::max(window_lo_[idx(dof)], lo);
  window_hi_[idx(dof)] = std::min(window_hi_[idx(dof)], hi);
}

void JointController::set_compliant_once(int group, double stiffness, double damping) {
  const JointGroup& g = groups_[idx(group)];
  for (int k = 0; k < g.dof_count; ++k) {
    compliant_kp_[idx(g.dof_begin + k)] = std::max(stiffness, 0.0);
    compliant_kd_[idx(g.dof_begin + k)] = std::max(damping, 0.0);
  }
}

void JointController::set_velocity_once(int group, const Vector3d& w_body) {
  const JointGroup& g = groups_[idx(group)];
  if (!g.ball) return;
  for (int k = 0; k < 3; ++k) {
    velocity_once_[idx(g.dof_begin + k)] = w_body[k];
    has_velocity_once_[idx(g.dof_begin + k)] = 1;
  }
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

void JointController::update_pd_gains(const mjModel& m, const mjData& d, const int* support_bodies,
                                      int n_supports) {
  // PD gains from natural frequency and damping ratio with the inertia each DOF moves now.
  for (std::size_t gi = 0; gi < groups_.size(); ++gi) {
    const JointGroup& g = groups_[gi];
    const JointParams& p = params_.joints[gi];
    const double wn = 2 * M_PI * p.pd_natural_frequency_hz;
    for (int k = 0; k < g.dof_count; ++k) {
      const int i = g.dof_begin + k;
      const double inertia = pd_inertia(m, d, g.body, i, support_bodies, n_supports);
      kp_[idx(i)] = inertia * wn * wn;
      kd_[idx(i)] = 2 * p.pd_damping_ratio * wn * inertia;
    }
  }
}

void JointController::reset(const mjModel& m, mjData& d, const std::vector<int>& support_bodies) {
  for (std::size_t gi = 0; gi < groups_.size(); ++gi) {
    targets_[gi].orientation = sim::relative_orientation(m, d, groups_[gi].body);
    targets_[gi].reach_at_s = d.time;
  }
  update_pd_gains(m, d, support_bodies.data(), static_cast<int>(support_bodies.size()));
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
    // A window from limit_torque_once: intersect, or the muscle's nearest reachable torque.
    const mjtNum w_lo = window_lo_[k], w_hi = window_hi_[k];
    if (w_lo > lo_[k] || w_hi < hi_[k]) {
      if (w_lo > hi_[k]) {
        lo_[k] = hi_[k];
      } else if (w_hi < lo_[k]) {
        hi_[k] = lo_[k];
      } else {
        lo_[k] = std::max(lo_[k], w_lo);
        hi_[k] = std::min(hi_[k], w_hi);
      }
    }
    window_lo_[k] = -std::numeric_limits<double>::infinity();
    window_hi_[k] = std::numeric_limits<double>::infinity();
    // A compliant DOF: its spring-damper torque, held to the bounds, is given to the solve.
    if (compliant_kp_[k] > 0 || compliant_kd_[k] > 0) {
      const mjtNum tau = std::clamp(compliant_kp_[k] * error_dof_[k] - compliant_kd_[k] * d.qvel[i], lo_[k], hi_[k]);
      lo_[k] = hi_[k] = tau;
      compliant_kp_[k] = compliant_kd_[k] = 0;
    }
  }
  JointControlStatus status;
  if (kind_ == ControllerKind::kVelocity) {
    for (const JointGroup& g : groups_) {
      for (int k = 0; k < g.dof_count; ++k) {
        const auto i = idx(g.dof_begin + k);
        const mjtNum w = has_velocity_once_[i] ? velocity_once_[i] : vel_dof_[i];
        qacc_des_[i] = (w - d.qvel[i]) / params_.velocity_horizon_s;
      }
    }
    // Every actuated DOF torque-specified (a torque driver such as TorqueGait): the solve's
    // answer is its bounds, so skip it (it is most of the step's cost).
    bool all_specified = true;
    for (int i = 0; i < nv_ && all_specified; ++i) {
      const auto k = idx(i);
      all_specified = !actuated_[k] || lo_[k] == hi_[k];
    }
    if (all_specified) {
      for (int i = 0; i < nv_; ++i) {
        const auto k = idx(i);
        tau_[k] = actuated_[k] ? lo_[k] : 0.0;
      }
      std::fill(qacc_pred_.begin(), qacc_pred_.end(), std::numeric_limits<double>::quiet_NaN());
    } else {
      const sim::HybridDynamicsResult r =
          solver_.solve(m, d, actuated_.data(), qacc_des_.data(), lo_.data(), hi_.data(),
                        qfrc_other, tau_.data(), qacc_pred_.data());
      status.solver_iterations = r.newton_iterations;
      status.converged = r.converged;
    }
  } else {
    for (int i = 0; i < nv_; ++i) {
      const auto k = idx(i);
      tau_[k] = actuated_[k] ? std::clamp(kp_[k] * error_dof_[k] - kd_[k] * d.qvel[i], lo_[k], hi_[k])
                             : 0.0;
    }
  }
  std::fill(has_velocity_once_.begin(), has_velocity_once_.end(), 0);
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
