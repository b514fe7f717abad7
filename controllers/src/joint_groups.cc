#include "biodyn/controllers/joint_groups.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "biodyn/sim/errors.h"

namespace biodyn::controllers {
namespace {

using Eigen::Quaterniond;
using Eigen::Vector3d;

Quaterniond axis_angle(double angle, const Vector3d& axis) {
  return Quaterniond(Eigen::AngleAxisd(angle, axis));
}

Vector3d unit(int index) { return Vector3d::Unit(index); }

}  // namespace

Vector3d clamp_to_range(const JointGroup& g, Vector3d angles, double margin_rad) {
  if (g.ball) return angles;
  for (int k = 0; k < g.dof_count; ++k) {
    const Eigen::Vector2d& r = g.range_rad[static_cast<std::size_t>(k)];
    const double margin = std::min(margin_rad, 0.25 * (r[1] - r[0]));
    angles[k] = std::clamp(angles[k], r[0] + margin, r[1] - margin);
  }
  return angles;
}

Quaterniond orientation_from_angles(const JointGroup& g, const Vector3d& angles) {
  if (g.ball) {
    // R_y(a) R_x(b) R_z(c) with anatomical angle = sign * Euler angle.
    return (axis_angle(g.ball_signs[0] * angles[0], unit(1)) *
            axis_angle(g.ball_signs[1] * angles[1], unit(0)) *
            axis_angle(g.ball_signs[2] * angles[2], unit(2)))
        .normalized();
  }
  Quaterniond q = Quaterniond::Identity();
  // MuJoCo composes a body's hinges in model order, each about its local axis.
  for (int k = 0; k < g.dof_count; ++k)
    q = q * axis_angle(angles[k], g.axes_B[static_cast<std::size_t>(k)]);
  return q.normalized();
}

Vector3d hinge_angles(const mjModel& m, const JointGroup& g, const double* qpos) {
  Vector3d angles = Vector3d::Zero();
  for (int k = 0; k < g.dof_count; ++k)
    angles[k] = qpos[m.jnt_qposadr[m.dof_jntid[g.dof_begin + k]]];
  return angles;
}

Vector3d angles_from_orientation(const JointGroup& g, const Quaterniond& q) {
  const Eigen::Matrix3d R = q.normalized().toRotationMatrix();
  Vector3d out = Vector3d::Zero();
  if (g.ball) {
    const double b = std::asin(std::clamp(-R(1, 2), -1.0, 1.0));
    const double a = std::atan2(R(0, 2), R(2, 2));
    const double c = std::atan2(R(1, 0), R(1, 1));
    return Vector3d(g.ball_signs[0] * a, g.ball_signs[1] * b, g.ball_signs[2] * c);
  }
  const Vector3d& a1 = g.axes_B[0];
  if (g.dof_count == 1) {
    // Twist of q about the hinge axis.
    const Vector3d v = q.vec();
    out[0] = 2.0 * std::atan2(v.dot(a1), q.w());
    if (out[0] > M_PI) out[0] -= 2 * M_PI;
    if (out[0] < -M_PI) out[0] += 2 * M_PI;
    return out;
  }
  // Two hinges: R = R_a1(t1) R_a2(t2); R a2 = R_a1(t1) a2 gives t1, then R_a1(t1)' R a1 gives t2.
  const Vector3d& a2 = g.axes_B[1];
  const Vector3d Ra2 = R * a2;
  out[0] = std::atan2(Ra2.dot(a1.cross(a2)), Ra2.dot(a2));
  const Eigen::Matrix3d R2 = Eigen::AngleAxisd(-out[0], a1).toRotationMatrix() * R;
  const Vector3d R2a1 = R2 * a1;
  out[1] = std::atan2(R2a1.dot(a2.cross(a1)), R2a1.dot(a1));
  return out;
}

double rotation_angle(const Quaterniond& q) {
  const double s = q.vec().norm();
  return 2.0 * std::atan2(s, std::abs(q.w()));
}

Vector3d rotation_vector(Quaterniond q) {
  if (q.w() < 0) q.coeffs() = -q.coeffs();
  const double s = q.vec().norm();
  if (s < 1e-12) return 2.0 * q.vec();  // small-angle limit
  return (2.0 * std::atan2(s, q.w()) / s) * q.vec();
}

}  // namespace biodyn::controllers
