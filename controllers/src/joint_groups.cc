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

// Body-name stem -> anatomical joint name (models/src/character.cc builds these bodies).
const std::pair<const char*, const char*> kJointNames[] = {
    {"trunk", "trunk"},   {"lumbar", "lumbar"},   {"thorax", "thorax"},      {"neck", "neck"},
    {"head", "head"},     {"clavicle", "clavicle"}, {"upper_arm", "shoulder"}, {"forearm", "elbow"},
    {"hand", "wrist"},    {"thigh", "hip"},       {"shank", "knee"},         {"foot", "ankle"},
    {"toes", "toe"}};

Quaterniond axis_angle(double angle, const Vector3d& axis) {
  return Quaterniond(Eigen::AngleAxisd(angle, axis));
}

Vector3d unit(int index) { return Vector3d::Unit(index); }

}  // namespace

std::string joint_name_for_body(const std::string& body_name) {
  std::string stem = body_name, suffix;
  if (stem.size() > 2 && (stem.substr(stem.size() - 2) == "_l" || stem.substr(stem.size() - 2) == "_r")) {
    suffix = stem.substr(stem.size() - 2);
    stem = stem.substr(0, stem.size() - 2);
  }
  for (const auto& [body, joint] : kJointNames) {
    if (stem == body) return joint + suffix;
  }
  return body_name;  // not a generated character's body: keep its own name
}

std::vector<JointGroup> find_joint_groups(const mjModel& m) {
  std::vector<JointGroup> groups;
  for (int b = 1; b < m.nbody; ++b) {
    if (m.body_jntnum[b] == 0) continue;
    const int first_joint = m.body_jntadr[b];
    if (m.jnt_type[first_joint] == mjJNT_FREE) continue;  // the root
    const char* body_name = mj_id2name(&m, mjOBJ_BODY, b);
    JointGroup g;
    g.body_name = body_name ? body_name : "body" + std::to_string(b);
    g.name = joint_name_for_body(g.body_name);
    g.body = b;
    g.dof_begin = m.body_dofadr[b];
    g.dof_count = m.body_dofnum[b];
    const std::size_t n = g.name.size();
    g.side = (n > 2 && g.name.compare(n - 2, 2, "_l") == 0)   ? 1
             : (n > 2 && g.name.compare(n - 2, 2, "_r") == 0) ? -1
                                                              : 0;
    for (int j = first_joint; j < first_joint + m.body_jntnum[b]; ++j) {
      const char* jn = mj_id2name(&m, mjOBJ_JOINT, j);
      const std::string joint_name = jn ? jn : "joint" + std::to_string(j);
      if (m.jnt_type[j] == mjJNT_BALL) {
        if (m.body_jntnum[b] != 1) {
          throw sim::InvalidArgument("joint groups: body '" + g.body_name +
                                     "' mixes a ball joint with other joints");
        }
        g.ball = true;
        for (int k = 0; k < 3; ++k) {
          g.dof_names.push_back(joint_name + "_" + "xyz"[k]);
          g.axes_B.push_back(unit(k));
        }
      } else if (m.jnt_type[j] == mjJNT_HINGE) {
        g.dof_names.push_back(joint_name);
        const double inf = std::numeric_limits<double>::infinity();
        g.range_rad.push_back(m.jnt_limited[j] ? Eigen::Vector2d(m.jnt_range[2 * j], m.jnt_range[2 * j + 1])
                                               : Eigen::Vector2d(-inf, inf));
        g.axes_B.push_back(Vector3d(m.jnt_axis[3 * j], m.jnt_axis[3 * j + 1],
                                    m.jnt_axis[3 * j + 2]).normalized());
      } else {
        throw sim::InvalidArgument("joint groups: joint '" + joint_name +
                                   "' is neither a hinge nor a ball joint");
      }
    }
    if (!g.ball && g.dof_count > 2) {
      throw sim::InvalidArgument("joint groups: body '" + g.body_name + "' has " +
                                 std::to_string(g.dof_count) +
                                 " hinges (at most 2; use a ball joint for 3 DOF)");
    }
    if (g.ball) {
      // Limbs hang down (thigh, upper arm): flexion moves them forward = rotation about -y,
      // abduction away from the midline = about +x on the left, internal rotation = about
      // -z on the left. The head points up: flexion about +y, bending left about -x,
      // rotation left about +z.
      const bool points_up = g.body_name.rfind("head", 0) == 0;
      const double s = g.side == 0 ? 1.0 : g.side;
      g.ball_signs = points_up ? Vector3d(1, -1, 1) : Vector3d(-1, s, -s);
    }
    groups.push_back(std::move(g));
  }
  return groups;
}

int find_group(const std::vector<JointGroup>& groups, const std::string& name) {
  for (std::size_t i = 0; i < groups.size(); ++i) {
    if (groups[i].name == name) return static_cast<int>(i);
  }
  return -1;
}

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
  for (int k = 0; k < g.dof_count; ++k) q = q * axis_angle(angles[k], g.axes_B[static_cast<std::size_t>(k)]);
  return q.normalized();
}

Vector3d hinge_angles(const mjModel& m, const JointGroup& g, const double* qpos) {
  Vector3d angles = Vector3d::Zero();
  for (int k = 0; k < g.dof_count; ++k) angles[k] = qpos[m.jnt_qposadr[m.dof_jntid[g.dof_begin + k]]];
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
