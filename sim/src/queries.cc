#include "biodyn/sim/queries.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <string>

#include "biodyn/sim/errors.h"

namespace biodyn::sim {
namespace {}  // namespace

CenterOfMass center_of_mass(const mjModel& m, const mjData& d) {
  CenterOfMass com;
  mjtNum velocity[6];  // [angular, linear] at the body CoM, world orientation
  Eigen::Vector3d weighted_position = Eigen::Vector3d::Zero();
  Eigen::Vector3d momentum = Eigen::Vector3d::Zero();
  for (int b = 1; b < m.nbody; ++b) {
    const double mass = m.body_mass[b];
    if (mass <= 0) continue;
    mj_objectVelocity(&m, &d, mjOBJ_BODY, b, velocity, 0);
    weighted_position +=
        mass * Eigen::Vector3d(d.xipos[3 * b], d.xipos[3 * b + 1], d.xipos[3 * b + 2]);
    momentum += mass * Eigen::Vector3d(velocity[3], velocity[4], velocity[5]);
    com.mass += mass;
  }
  if (com.mass > 0) {
    com.position_W = weighted_position / com.mass;
    com.velocity_W = momentum / com.mass;
  }
  return com;
}

void floor_contacts(const mjModel& m, const mjData& d, int floor_geom,
                    std::vector<FloorContact>* out) {
  out->clear();
  for (int i = 0; i < d.ncon; ++i) {
    const mjContact& c = d.contact[i];
    const bool ground1 = is_ground(m, c.geom1, floor_geom);
    if (!ground1 && !is_ground(m, c.geom2, floor_geom)) continue;
    if (c.exclude != 0 || c.efc_address < 0) continue;  // not an active constraint
    mjtNum f_local[6];
    mj_contactForce(&m, &d, i, f_local);
    // Contact frame rows: normal (geom1 -> geom2), then two tangents. Force on geom2.
    Eigen::Vector3d f_on_geom2 = Eigen::Vector3d::Zero();
    for (int r = 0; r < 3; ++r) {
      f_on_geom2 +=
          f_local[r] * Eigen::Vector3d(c.frame[3 * r], c.frame[3 * r + 1], c.frame[3 * r + 2]);
    }
    Eigen::Vector3d normal(c.frame[0], c.frame[1], c.frame[2]);
    const bool body_is_geom2 = ground1;
    FloorContact fc;
    fc.geom = body_is_geom2 ? c.geom2 : c.geom1;
    fc.body = m.geom_bodyid[fc.geom];
    fc.position_W = Eigen::Vector3d(c.pos[0], c.pos[1], c.pos[2]);
    fc.normal_W = body_is_geom2 ? normal : -normal;
    const Eigen::Vector3d f_on_body = body_is_geom2 ? f_on_geom2 : -f_on_geom2;
    fc.normal_force = f_on_body.dot(fc.normal_W);
    fc.tangential_force_W = f_on_body - fc.normal_force * fc.normal_W;
    fc.distance = c.dist;
    out->push_back(fc);
  }
}

int floor_contact_count(const mjModel& m, const mjData& d, int floor_geom, int body,
                        double max_distance_m) {
  int count = 0;
  for (int i = 0; i < d.ncon; ++i) {
    const mjContact& c = d.contact[i];
    const int other = is_ground(m, c.geom1, floor_geom)   ? c.geom2
                      : is_ground(m, c.geom2, floor_geom) ? c.geom1
                                                          : -1;
    if (other >= 0 && m.geom_bodyid[other] == body && c.dist <= max_distance_m) ++count;
  }
  return count;
}

bool foot_touches_floor(const mjModel& m, const mjData& d, int floor_geom, int foot, int toes) {
  return floor_contact_count(m, d, floor_geom, foot) > 0 ||
         (toes >= 0 && floor_contact_count(m, d, floor_geom, toes) > 0);
}

Pose body_pose(const mjModel& m, const mjData& d, int body) {
  if (body < 0 || body >= m.nbody) {
    throw InvalidArgument("body_pose: body id " + std::to_string(body) + " out of range");
  }
  Pose p;
  p.position_W = Eigen::Vector3d(d.xpos[3 * body], d.xpos[3 * body + 1], d.xpos[3 * body + 2]);
  p.orientation_W = quat_at(d.xquat + 4 * body);
  return p;
}

Eigen::Quaterniond relative_orientation(const mjModel& m, const mjData& d, int body) {
  if (body <= 0 || body >= m.nbody) {
    throw InvalidArgument("relative_orientation: body id " + std::to_string(body) +
                          " out of range [1, " + std::to_string(m.nbody) + ")");
  }
  const int parent = m.body_parentid[body];
  const Eigen::Quaterniond q_parent = quat_at(d.xquat + 4 * parent);
  const Eigen::Quaterniond q_body = quat_at(d.xquat + 4 * body);
  return (q_parent.conjugate() * q_body).normalized();
}

Eigen::Quaterniond joint_quaternion(const mjModel& m, const mjData& d, int joint) {
  if (joint < 0 || joint >= m.njnt) {
    throw InvalidArgument("joint_quaternion: joint id " + std::to_string(joint) + " out of range");
  }
  const int type = m.jnt_type[joint];
  const int adr = m.jnt_qposadr[joint];
  if (type == mjJNT_BALL) return quat_at(d.qpos + adr).normalized();
  if (type == mjJNT_FREE) return quat_at(d.qpos + adr + 3).normalized();
  throw InvalidArgument("joint_quaternion: joint " + std::to_string(joint) +
                        " is not a ball or free joint");
}

void bracket_time(const std::vector<double>& times, double t, std::size_t* f0, double* alpha) {
  if (t <= times.front()) {
    *f0 = 0;
    *alpha = 0;
    return;
  }
  if (t >= times.back()) {
    *f0 = times.size() - 2;
    *alpha = 1;
    return;
  }
  const auto it = std::upper_bound(times.begin(), times.end(), t);
  *f0 = static_cast<std::size_t>(it - times.begin()) - 1;
  *alpha = (t - times[*f0]) / (times[*f0 + 1] - times[*f0]);
}

double first_hit_m(const mjModel& m, const mjData& d, const Eigen::Vector3d& from_W,
                   const Eigen::Vector3d& to_W) {
  const Eigen::Vector3d along = to_W - from_W;
  const double length = along.norm();
  if (length <= 0) return std::numeric_limits<double>::infinity();
  const Eigen::Vector3d unit = along / length;
  int geom = -1;
  // Every group, the static floor included; invisible geoms (alpha 0) are skipped by mj_ray.
  const mjtNum hit = mj_ray(&m, &d, from_W.data(), unit.data(), nullptr, 1, -1, &geom);
  return hit >= 0 && hit <= length ? hit : std::numeric_limits<double>::infinity();
}

double geom_lowest_z(const mjModel& m, const mjData& d, int g) {
  const mjtNum* R = d.geom_xmat + 9 * g;  // row-major: R[6..8] the world z row
  const mjtNum* size = m.geom_size + 3 * g;
  const double zc = d.geom_xpos[3 * g + 2];
  switch (m.geom_type[g]) {
    case mjGEOM_BOX:
      return zc - std::abs(R[6]) * size[0] - std::abs(R[7]) * size[1] - std::abs(R[8]) * size[2];
    case mjGEOM_CAPSULE:
      return zc - std::abs(R[8]) * size[1] - size[0];
    case mjGEOM_SPHERE:
      return zc - size[0];
    default:
      return std::numeric_limits<double>::infinity();
  }
}

double mechanical_energy(const mjModel& m, const mjData& d) {
  double kinetic = 0, potential = 0;
  mjtNum vel[6];  // [angular, linear] in the body's inertial (principal) frame
  for (int b = 1; b < m.nbody; ++b) {
    const double mass = m.body_mass[b];
    mj_objectVelocity(&m, &d, mjOBJ_BODY, b, vel, 1);
    const mjtNum* I = m.body_inertia + 3 * b;
    kinetic += 0.5 * (I[0] * vel[0] * vel[0] + I[1] * vel[1] * vel[1] + I[2] * vel[2] * vel[2]);
    kinetic += 0.5 * mass * (vel[3] * vel[3] + vel[4] * vel[4] + vel[5] * vel[5]);
    potential -= mass * mju_dot3(m.opt.gravity, d.xipos + 3 * b);
  }
  for (int i = 0; i < m.nv; ++i) kinetic += 0.5 * m.dof_armature[i] * d.qvel[i] * d.qvel[i];
  for (int j = 0; j < m.njnt; ++j) {
    const int type = m.jnt_type[j];
    if (m.jnt_stiffness[j] == 0 || (type != mjJNT_HINGE && type != mjJNT_SLIDE)) continue;
    const int adr = m.jnt_qposadr[j];
    const double dq = d.qpos[adr] - m.qpos_spring[adr];
    potential += 0.5 * m.jnt_stiffness[j] * dq * dq;
  }
  return kinetic + potential;
}

void efc_jacobian_row(const mjModel& m, const mjData& d, int r, mjtNum* out) {
  const std::ptrdiff_t nv = m.nv;
  if (!mj_isSparse(&m)) {
    std::copy(d.efc_J + r * nv, d.efc_J + (r + 1) * nv, out);
    return;
  }
  std::fill(out, out + nv, 0.0);
  const int adr = d.efc_J_rowadr[r];
  for (int k = 0; k < d.efc_J_rownnz[r]; ++k) out[d.efc_J_colind[adr + k]] = d.efc_J[adr + k];
}

void joint_stop_torques(const mjModel& m, const mjData& d, mjtNum* row, mjtNum* out) {
  std::fill(out, out + m.nv, 0.0);
  for (int r = 0; r < d.nefc; ++r) {
    if (d.efc_type[r] != mjCNSTR_LIMIT_JOINT || d.efc_force[r] == 0) continue;
    efc_jacobian_row(m, d, r, row);
    for (int i = 0; i < m.nv; ++i) out[i] += row[i] * d.efc_force[r];
  }
}

std::vector<double> motor_limits_per_dof(const mjModel& m) {
  std::vector<double> tau(static_cast<std::size_t>(m.nv), -1.0);
  for (int a = 0; a < m.nu; ++a) {
    if (m.actuator_trntype[a] != mjTRN_JOINT || !m.actuator_ctrllimited[a]) continue;
    const int j = m.actuator_trnid[2 * a];
    const mjtNum* gear = m.actuator_gear + 6 * a;
    const double limit = m.actuator_ctrlrange[2 * a + 1];
    if (m.jnt_type[j] == mjJNT_BALL) {
      for (int k = 0; k < 3; ++k)
        if (gear[k] != 0)
          tau[static_cast<std::size_t>(m.jnt_dofadr[j] + k)] = limit * std::abs(gear[k]);
    } else if (m.jnt_type[j] == mjJNT_HINGE || m.jnt_type[j] == mjJNT_SLIDE) {
      tau[static_cast<std::size_t>(m.jnt_dofadr[j])] = limit * std::abs(gear[0]);
    }
  }
  return tau;
}

}  // namespace biodyn::sim
