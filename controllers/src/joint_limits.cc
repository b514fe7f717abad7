#include "biodyn/controllers/joint_limits.h"

#include <algorithm>
#include <cmath>

#include "biodyn/sim/queries.h"

namespace biodyn::controllers {
namespace {

using Eigen::Quaterniond;
using Eigen::Vector3d;

// q = swing * twist with twist about z.
void split(Quaterniond q, Quaterniond* swing, double* twist_angle) {
  if (q.w() < 0) q.coeffs() = -q.coeffs();
  const double n = std::hypot(q.w(), q.z());
  const Quaterniond twist = n > 1e-9 ? Quaterniond(q.w() / n, 0, 0, q.z() / n)
                                     : Quaterniond::Identity();  // swing of 180 deg
  *twist_angle = 2.0 * std::atan2(twist.z(), twist.w());
  *swing = q * twist.conjugate();
}

}  // namespace

SwingTwistAngles swing_twist_angles(const JointGroup& g, const Quaterniond& q) {
  Quaterniond swing;
  double twist = 0;
  split(q.normalized(), &swing, &twist);
  const Vector3d s = rotation_vector(swing);
  // ball_signs map body-frame rotations about y, x, z to flexion, abduction, internal rotation.
  return {g.ball_signs[0] * s.y(), g.ball_signs[1] * s.x(), g.ball_signs[2] * twist};
}

double swing_ratio(const SwingTwistLimits& lim, const SwingTwistAngles& a) {
  const double lf = a.flexion >= 0 ? lim.flexion_rad : lim.extension_rad;
  const double la = a.abduction >= 0 ? lim.abduction_rad : lim.adduction_rad;
  return std::sqrt((a.flexion / lf) * (a.flexion / lf) + (a.abduction / la) * (a.abduction / la));
}

SwingTwistLimiter::SwingTwistLimiter(const std::vector<JointGroup>& groups,
                                     const ControllerParams& params)
    : groups_(groups) {
  set_params(params);
}

void SwingTwistLimiter::set_params(const ControllerParams& params) {
  entries_.clear();
  for (std::size_t g = 0; g < groups_.size(); ++g) {
    if (groups_[g].ball && params.joints[g].swing_twist) {
      entries_.push_back({static_cast<int>(g), *params.joints[g].swing_twist});
    }
  }
}

int SwingTwistLimiter::compute(const mjModel& m, const mjData& d, mjtNum* qfrc) const {
  int outside = 0;
  const double w = kLimitFrequency_rad_s;
  for (const Entry& e : entries_) {
    const JointGroup& g = groups_[static_cast<std::size_t>(e.group)];
    const Quaterniond q_rel = sim::relative_orientation(m, d, g.body);
    const SwingTwistAngles a = swing_twist_angles(g, q_rel);
    const Vector3d omega_B(d.qvel[g.dof_begin], d.qvel[g.dof_begin + 1], d.qvel[g.dof_begin + 2]);
    const Eigen::Matrix3d R_PB = q_rel.toRotationMatrix();
    // Inertia from the mass matrix diagonal of this ball joint: the swing axes' mean for the
    // swing limit, the bone axis's own for the twist. The twist inertia of a thigh is a tenth
    // of its swing inertia: damping sized by the mean made the explicit twist damper unstable
    // (2 zeta w_eff dt > 2) and the limit torque grew without bound in walking.
    const double swing_inertia =
        (d.qM[m.dof_Madr[g.dof_begin]] + d.qM[m.dof_Madr[g.dof_begin + 1]]) / 2.0;
    const double twist_inertia = d.qM[m.dof_Madr[g.dof_begin + 2]];
    const double stiffness = swing_inertia * w * w, damping = 2.0 * swing_inertia * w;
    const double twist_stiffness = twist_inertia * w * w, twist_damping = 2.0 * twist_inertia * w;
    Vector3d torque_P = Vector3d::Zero();
    Vector3d torque_B = Vector3d::Zero();
    bool out = false;

    const double rho = swing_ratio(e.limits, a);
    if (rho > 1.0) {
      out = true;
      // Swing direction in the parent's x-y plane (body frame axes at rest).
      const Vector3d s_P(a.abduction / g.ball_signs[1], a.flexion / g.ball_signs[0], 0.0);
      const double depth = s_P.norm() * (1.0 - 1.0 / rho);
      const Vector3d dir = s_P.normalized();
      const double outward_speed = (R_PB * omega_B).dot(dir);
      const double push = std::max(0.0, stiffness * depth + damping * outward_speed);
      torque_P -= push * dir;
    }
    const double over_internal = a.internal_rotation - e.limits.internal_rotation_rad;
    const double over_external = -a.internal_rotation - e.limits.external_rotation_rad;
    const double internal_speed = g.ball_signs[2] * omega_B.z();
    if (over_internal > 0) {
      out = true;
      const double push =
          std::max(0.0, twist_stiffness * over_internal + twist_damping * internal_speed);
      torque_B.z() -= g.ball_signs[2] * push;
    } else if (over_external > 0) {
      out = true;
      const double push =
          std::max(0.0, twist_stiffness * over_external - twist_damping * internal_speed);
      torque_B.z() += g.ball_signs[2] * push;
    }
    torque_B += R_PB.transpose() * torque_P;
    for (int k = 0; k < 3; ++k) qfrc[g.dof_begin + k] += torque_B[k];
    if (out) ++outside;
  }
  return outside;
}

}  // namespace biodyn::controllers
