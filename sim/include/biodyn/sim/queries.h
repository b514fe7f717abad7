#pragma once
/// Read-outs every controller needs. All take (model, data) and read derived fields, so call
/// them after mj_forward, inside a Simulation::step controller (after mj_step1), or after a
/// step (contacts and forces then belong to the state at the start of that step).
/// Frames: _W world. Quaternions (w, x, y, z) as in MuJoCo.

#include <mujoco/mujoco.h>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>
#include <vector>

namespace biodyn::sim {

/// The 3-vector at `v` (a row of xpos, xipos, cvel, body_pos, ...), as Eigen.
inline Eigen::Vector3d vec3_at(const mjtNum* v) { return {v[0], v[1], v[2]}; }
/// The quaternion (w, x, y, z) at `q` (a row of xquat, qpos, body_quat, ...), as it is.
inline Eigen::Quaterniond quat_at(const mjtNum* q) { return {q[0], q[1], q[2], q[3]}; }

/// Whole-body centre of mass.
struct CenterOfMass {
  Eigen::Vector3d position_W = Eigen::Vector3d::Zero();  ///< m, world frame
  Eigen::Vector3d velocity_W = Eigen::Vector3d::Zero();  ///< m/s, world frame
  double mass = 0.0;                                     ///< kg, sum of all body masses
};

/// Centre of mass of all bodies and its velocity (mass-weighted body-CoM velocities from
/// mj_objectVelocity). Needs positions and velocities computed (mj_forward / mj_step1).
CenterOfMass center_of_mass(const mjModel& m, const mjData& d);

/// One contact between a geom and the floor geom.
struct FloorContact {
  int geom = -1;                                                 ///< the non-floor geom
  int body = -1;                                                 ///< its body
  Eigen::Vector3d position_W = Eigen::Vector3d::Zero();          ///< m, contact point, world
  Eigen::Vector3d normal_W = Eigen::Vector3d::UnitZ();           ///< unit, from floor into body
  double normal_force = 0.0;                                     ///< N, >= 0, pushes body away
  Eigen::Vector3d tangential_force_W = Eigen::Vector3d::Zero();  ///< N, friction on the body
  double distance = 0.0;  ///< m, signed distance (negative = penetration)
};

/// Whether `geom` is ground: `floor_geom` itself, or (with a floor) any other geom fixed to the
/// world body, the terrain beside the floor (models::Terrain).
inline bool is_ground(const mjModel& m, int geom, int floor_geom) {
  return geom == floor_geom || (floor_geom >= 0 && geom >= 0 && m.geom_bodyid[geom] == 0 &&
                                m.geom_bodyid[floor_geom] == 0);
}

/// Appends to `out` (after clearing it) every active contact between `floor_geom` and another
/// geom, with the contact force acting on the non-floor body. Reuses `out`'s capacity: no
/// allocation once it has grown to the contact count.
void floor_contacts(const mjModel& m, const mjData& d, int floor_geom,
                    std::vector<FloorContact>* out);

/// Number of contacts between `floor_geom` and the geoms of `body` whose signed distance is
/// at most `max_distance_m` (0: touching or penetrating; larger counts contacts MuJoCo keeps
/// within the geoms' margin). No allocation.
int floor_contact_count(const mjModel& m, const mjData& d, int floor_geom, int body,
                        double max_distance_m = 0.0);

/// Whether a foot touches `floor_geom`: `foot` or its `toes` body (-1: none) has a contact at
/// distance <= 0. No allocation.
bool foot_touches_floor(const mjModel& m, const mjData& d, int floor_geom, int foot, int toes);

/// Pose of a body frame in the world.
struct Pose {
  Eigen::Vector3d position_W = Eigen::Vector3d::Zero();  ///< m
  Eigen::Quaterniond orientation_W = Eigen::Quaterniond::Identity();
};

/// World pose of `body`'s frame (xpos, xquat).
Pose body_pose(const mjModel& m, const mjData& d, int body);

/// Orientation of `body` relative to its parent body: conj(q_parent) * q_body. For a body with
/// one ball joint and no offset rotation this equals the joint's qpos quaternion.
Eigen::Quaterniond relative_orientation(const mjModel& m, const mjData& d, int body);

/// The qpos quaternion of a ball or free joint (for a free joint: its orientation part).
/// Throws InvalidArgument for other joint types.
Eigen::Quaterniond joint_quaternion(const mjModel& m, const mjData& d, int joint);

/// World height of geom g's lowest point, m (after mj_kinematics): its centre less its extent
/// along z for boxes, capsules and spheres; +inf for planes and other types.
double geom_lowest_z(const mjModel& m, const mjData& d, int g);

/// m: how far from `from_W` towards `to_W` the first visible geom (any body's, the floor's) is
/// hit, or +infinity when nothing is hit before `to_W` (mj_ray; needs mj_kinematics). A line of
/// sight: a camera at `from_W` sees a point at `to_W`.
double first_hit_m(const mjModel& m, const mjData& d, const Eigen::Vector3d& from_W,
                   const Eigen::Vector3d& to_W);

/// rad: how far joint j of pose `b` is from pose `a` (nq values each, indexable): a hinge's or
/// slide's difference, a ball's or the free root's rotation angle between the orientations.
template <class A, class B>
double joint_distance(const mjModel& m, int j, const A& a, const B& b) {
  const int adr = m.jnt_qposadr[j];
  if (m.jnt_type[j] == mjJNT_HINGE || m.jnt_type[j] == mjJNT_SLIDE)
    return std::abs(a[adr] - b[adr]);
  const int o = m.jnt_type[j] == mjJNT_FREE ? adr + 3 : adr;
  const Eigen::Quaterniond qa(a[o], a[o + 1], a[o + 2], a[o + 3]);
  const Eigen::Quaterniond qb(b[o], b[o + 1], b[o + 2], b[o + 3]);
  return qa.normalized().angularDistance(qb.normalized());
}

/// Where time t falls in increasing `times` (at least 2): the frame at or before it (`f0`) and
/// the fraction `alpha` (0..1) of the way to the next; t is clamped to the ends. No allocation.
void bracket_time(const std::vector<double>& times, double t, std::size_t* f0, double* alpha);

/// The pose `alpha` (0..1) of the way from q0 to q1 (nq values each, indexable: a pointer or
/// an Eigen row) into `out`: hinges, slides and the free root's position linearly, ball joints
/// and the root's orientation by slerp of the normalised quaternions. No allocation.
template <class Q0, class Q1>
void interpolate_qpos(const mjModel& m, const Q0& q0, const Q1& q1, double alpha, double* out) {
  const auto lerp = [&](int k) { out[k] = (1 - alpha) * q0[k] + alpha * q1[k]; };
  const auto slerp = [&](int k) {
    const Eigen::Quaterniond a =
        Eigen::Quaterniond(q0[k], q0[k + 1], q0[k + 2], q0[k + 3]).normalized();
    const Eigen::Quaterniond b =
        Eigen::Quaterniond(q1[k], q1[k + 1], q1[k + 2], q1[k + 3]).normalized();
    const Eigen::Quaterniond q = a.slerp(alpha, b);
    out[k] = q.w();
    out[k + 1] = q.x();
    out[k + 2] = q.y();
    out[k + 3] = q.z();
  };
  for (int j = 0; j < m.njnt; ++j) {
    const int adr = m.jnt_qposadr[j];
    switch (m.jnt_type[j]) {
      case mjJNT_FREE:
        for (int k = 0; k < 3; ++k) lerp(adr + k);
        slerp(adr + 3);
        break;
      case mjJNT_BALL:
        slerp(adr);
        break;
      default:
        lerp(adr);
    }
  }
}

/// Total mechanical energy, J: kinetic (every body's translation and rotation about its CoM,
/// plus the armature's 0.5*a*qvel^2, i.e. 0.5 qvel' M qvel) + gravitational potential + hinge/
/// slide spring potential. Computed from cvel/xipos, so it needs mj_forward or mj_step1 first.
/// (2.2.2's mj_energyPos/Vel return 0 unless the model enables the energy flag.)
double mechanical_energy(const mjModel& m, const mjData& d);

/// Per DOF (nv): the torque its joint motor can give, ctrlrange x |gear| (a ball joint's three
/// motors turn it about x, y, z by their gears); -1 for a DOF without a limited motor.
std::vector<double> motor_limits_per_dof(const mjModel& m);

/// Row `r` (< d.nefc) of the constraint Jacobian efc_J as a dense row of nv values in `out`,
/// whichever storage the model uses (<option jacobian>: dense rows, or 2.2.2's compressed
/// rows efc_J_rownnz/rowadr/colind). No allocation.
void efc_jacobian_row(const mjModel& m, const mjData& d, int r, mjtNum* out);

/// Per DOF (nv) into `out`: the generalized force the joints' range stops (MuJoCo's joint-limit
/// constraint rows) apply now, J^T f over those rows. `row` is nv scratch. No allocation. The
/// stops are passive structure, not muscle: a result that leans on them should say so.
void joint_stop_torques(const mjModel& m, const mjData& d, mjtNum* row, mjtNum* out);

}  // namespace biodyn::sim
