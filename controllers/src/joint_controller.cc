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
    a = Vector3d(d.xmat[9 * joint_body + k], d.xmat[9 * joint_body + 3 + k],
                 d.xmat[9 * joint_body + 6 + k]);
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

// The bounds of one DOF for this step: the muscle limits (|tau| <= tau_max, rate limit from
// tau_prev), narrowed by the command's window (or, if the window misses the muscle's reachable
// range, the end of that range nearest to it), then a spring's torque or kFree's zero.
void apply_command(const DofCommand& c, mjtNum error, mjtNum qvel, mjtNum* lo, mjtNum* hi) {
  const mjtNum w_lo = c.torque_min_Nm, w_hi = c.torque_max_Nm;
  if (w_lo > *lo || w_hi < *hi) {
    if (w_lo > *hi) {
      *lo = *hi;
    } else if (w_hi < *lo) {
      *hi = *lo;
    } else {
      *lo = std::max(*lo, w_lo);
      *hi = std::min(*hi, w_hi);
    }
  }
  if (c.mode == DofMode::kSpring && (c.stiffness_Nm_per_rad > 0 || c.damping_Nm_s_per_rad > 0)) {
    const mjtNum tau =
        std::clamp(c.stiffness_Nm_per_rad * error - c.damping_Nm_s_per_rad * qvel, *lo, *hi);
    *lo = *hi = tau;
  }
  if (c.mode == DofMode::kFree) *lo = *hi = 0;
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

JointController::JointController(const mjModel& m, const models::Rig& rig, ControllerParams params,
                                 ControllerKind kind)
    : rig_(&rig),
      params_(std::move(params)),
      kind_(kind),
      solver_(m),
      nv_(m.nv),
      timestep_(m.opt.timestep) {
  if (params_.joints.size() != groups().size()) {
    throw sim::InvalidArgument("joint controller: parameters for " +
                               std::to_string(params_.joints.size()) + " joints, model has " +
                               std::to_string(groups().size()));
  }
  params_.validate(m.opt.timestep);
  const auto nv = idx(m.nv);
  actuated_.assign(nv, 0);
  for (auto* v : {&state_.tau_prev, &state_.tau, &tau_max_, &rate_, &lo_, &hi_, &qacc_des_,
                  &qacc_pred_, &error_dof_, &vel_dof_, &kp_, &kd_, &zero_})
    v->assign(nv, 0.0);
  for (const JointGroup& g : groups())
    for (int k = 0; k < g.dof_count; ++k) actuated_[idx(g.dof_begin + k)] = 1;
  refresh_limits(m.opt.timestep);
}

void JointController::set_params(const ControllerParams& params) {
  if (params.joints.size() != groups().size()) {
    throw sim::InvalidArgument("joint controller: parameters for " +
                               std::to_string(params.joints.size()) + " joints, expected " +
                               std::to_string(groups().size()));
  }
  params.validate(timestep_);
  params_ = params;
  refresh_limits(timestep_);
}

void JointController::restore(const JointControlState& state) {
  std::copy(state.tau_prev.begin(), state.tau_prev.end(), state_.tau_prev.begin());
  std::copy(state.tau.begin(), state.tau.end(), state_.tau.begin());
}

void JointController::refresh_limits(double timestep) {
  const std::vector<JointGroup>& gs = groups();
  for (std::size_t g = 0; g < gs.size(); ++g) {
    const JointParams& p = params_.joints[g];
    for (int k = 0; k < gs[g].dof_count; ++k) {
      const auto i = idx(gs[g].dof_begin + k);
      tau_max_[i] = p.tau_max_Nm[k];
      // Paper §3.2: the torque may change by at most tau_max * dt / t_r per step.
      rate_[i] = p.tau_max_Nm[k] * timestep / p.reaction_time_s;
    }
  }
}

double orientation_error(const mjModel& m, const mjData& d, const JointGroup& group,
                         const JointTarget& target) {
  const Quaterniond q_c = sim::relative_orientation(m, d, group.body);
  return rotation_angle(q_c.conjugate() * target.orientation);
}

void JointController::desired_motion(const mjModel& m, const mjData& d, const ControlFrame& frame) {
  const std::vector<JointGroup>& gs = groups();
  for (std::size_t gi = 0; gi < gs.size(); ++gi) {
    const JointGroup& g = gs[gi];
    const JointTarget& target = frame.target(static_cast<int>(gi));
    const Quaterniond q_c = sim::relative_orientation(m, d, g.body);
    // Paper §3.2: q_t = conj(q_c) * q_d; theta v is its rotation vector (body frame).
    const Vector3d e_B = rotation_vector(q_c.conjugate() * target.orientation);
    const double t_go = std::max(target.reach_at_s - d.time, params_.min_time_to_go_s);
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
      A.col(k) =
          R_WB.transpose() * Vector3d(d.xaxis[3 * j], d.xaxis[3 * j + 1], d.xaxis[3 * j + 2]);
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
  const std::vector<JointGroup>& gs = groups();
  for (std::size_t gi = 0; gi < gs.size(); ++gi) {
    const JointGroup& g = gs[gi];
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

void JointController::reset(const mjModel& m, mjData& d, ControlFrame* frame,
                            const std::vector<int>& support_bodies) {
  const std::vector<JointGroup>& gs = groups();
  for (std::size_t gi = 0; gi < gs.size(); ++gi) {
    frame->set_target(static_cast<int>(gi), sim::relative_orientation(m, d, gs[gi].body), d.time);
  }
  update_pd_gains(m, d, support_bodies.data(), static_cast<int>(support_bodies.size()));
  // Holding torques: the whole-body solve for zero acceleration, without the rate limit.
  for (int i = 0; i < nv_; ++i) {
    qacc_des_[idx(i)] = 0;
    lo_[idx(i)] = -tau_max_[idx(i)];
    hi_[idx(i)] = tau_max_[idx(i)];
  }
  solver_.solve(m, d, actuated_.data(), qacc_des_.data(), lo_.data(), hi_.data(), zero_.data(),
                state_.tau_prev.data(), qacc_pred_.data());
  state_.tau = state_.tau_prev;
}

JointControlStatus JointController::compute(const mjModel& m, mjData& d, const ControlFrame& frame,
                                            const mjtNum* qfrc_other, mjtNum* torque) {
  desired_motion(m, d, frame);
  std::vector<mjtNum>& tau_prev = state_.tau_prev;
  std::vector<mjtNum>& tau = state_.tau;
  for (int i = 0; i < nv_; ++i) {
    const auto k = idx(i);
    lo_[k] = std::max(-tau_max_[k], tau_prev[k] - rate_[k]);
    hi_[k] = std::min(tau_max_[k], tau_prev[k] + rate_[k]);
    qacc_des_[k] = 0;
    apply_command(frame.command(i), error_dof_[k], d.qvel[i], &lo_[k], &hi_[k]);
  }
  JointControlStatus status;
  if (kind_ == ControllerKind::kVelocity) {
    for (const JointGroup& g : groups()) {
      for (int k = 0; k < g.dof_count; ++k) {
        const auto i = idx(g.dof_begin + k);
        const DofCommand& c = frame.command(static_cast<int>(i));
        const mjtNum w = c.has_velocity ? c.velocity_rad_s : vel_dof_[i];
        qacc_des_[i] = (w - d.qvel[i]) / params_.velocity_horizon_s;
      }
    }
    // Every actuated DOF torque-specified (a torque driver such as the torque walker): the
    // solve's answer is its bounds, so skip it (it is most of the step's cost).
    bool all_specified = true;
    for (int i = 0; i < nv_ && all_specified; ++i) {
      const auto k = idx(i);
      all_specified = !actuated_[k] || lo_[k] == hi_[k];
    }
    if (all_specified) {
      for (int i = 0; i < nv_; ++i) {
        const auto k = idx(i);
        tau[k] = actuated_[k] ? lo_[k] : 0.0;
      }
      std::fill(qacc_pred_.begin(), qacc_pred_.end(), std::numeric_limits<double>::quiet_NaN());
    } else {
      const sim::HybridDynamicsResult r =
          solver_.solve(m, d, actuated_.data(), qacc_des_.data(), lo_.data(), hi_.data(),
                        qfrc_other, tau.data(), qacc_pred_.data());
      status.solver_iterations = r.newton_iterations;
      status.converged = r.converged;
    }
  } else {
    for (int i = 0; i < nv_; ++i) {
      const auto k = idx(i);
      tau[k] = actuated_[k]
                   ? std::clamp(kp_[k] * error_dof_[k] - kd_[k] * d.qvel[i], lo_[k], hi_[k])
                   : 0.0;
    }
  }
  for (int i = 0; i < nv_; ++i) {
    const auto k = idx(i);
    torque[i] = tau[k];
    if (!actuated_[k]) continue;
    if (tau_max_[k] > 0)
      status.max_torque_ratio = std::max(status.max_torque_ratio, std::abs(tau[k]) / tau_max_[k]);
    if (tau[k] <= lo_[k] || tau[k] >= hi_[k]) ++status.saturated_dofs;
  }
  return status;
}

void JointController::commit() { state_.tau_prev = state_.tau; }

}  // namespace biodyn::controllers
