#include "biodyn/mocap_io/inverse_dynamics.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <memory>

#include "biodyn/models/rig.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/model.h"
#include "biodyn/sim/units.h"
#include "plate_assignment.h"

namespace biodyn::mocap_io {
namespace {

/// Timing tolerance for "evenly spaced" frames, relative to the step.
constexpr double kUnevenTolerance = 1e-3;

bool is_quaternion_start(const mjModel& m, int q, int* joint) {
  for (int j = 0; j < m.njnt; ++j) {
    const int a = m.jnt_qposadr[j];
    if ((m.jnt_type[j] == mjJNT_BALL && q == a) || (m.jnt_type[j] == mjJNT_FREE && q == a + 3)) {
      *joint = j;
      return true;
    }
  }
  return false;
}

/// s: the mean frame step of `motion`. Throws sim::InvalidArgument for fewer than 2 * trim + 1
/// frames, a frame without a pose or frames not evenly spaced.
double checked_frame_step(const Motion& motion, int trim) {
  const int frames = motion.frame_count();
  if (frames < 2 * trim + 1) {
    throw sim::InvalidArgument("inverse dynamics: needs at least " + std::to_string(2 * trim + 1) +
                               " frames, got " + std::to_string(frames));
  }
  for (int f = 0; f < frames; ++f) {
    if (!motion.qpos.row(f).allFinite()) {
      throw sim::InvalidArgument("inverse dynamics: frame " + std::to_string(f) +
                                 " (t = " + std::to_string(motion.times_s[static_cast<size_t>(f)]) +
                                 " s) has no pose (an unsolved IK frame); give a motion without "
                                 "gaps (see longest_solved_span)");
    }
  }
  const double dt = (motion.times_s.back() - motion.times_s.front()) / (frames - 1);
  for (int f = 1; f < frames; ++f) {
    const double step =
        motion.times_s[static_cast<size_t>(f)] - motion.times_s[static_cast<size_t>(f - 1)];
    if (std::abs(step - dt) > kUnevenTolerance * dt) {
      throw sim::InvalidArgument("inverse dynamics: frames must be evenly spaced; frame " +
                                 std::to_string(f) + " steps " + std::to_string(step) +
                                 " s, the mean step is " + std::to_string(dt) + " s");
    }
  }
  return dt;
}

/// The model ID runs on: no joint limits, welds or contacts (the ground is measured, estimated
/// or left in the residual) and, unless asked, no armature or joint damping.
std::unique_ptr<mjModel, sim::ModelDeleter> model_for_inverse_dynamics(
    const mjModel& model, const InverseDynamicsOptions& options) {
  std::unique_ptr<mjModel, sim::ModelDeleter> m(mj_copyModel(nullptr, &model));
  m->opt.disableflags |= mjDSBL_CONSTRAINT;
  if (!options.include_armature_damping) {
    for (int v = 0; v < m->nv; ++v) {
      m->dof_armature[v] = 0.0;
      m->dof_damping[v] = 0.0;
    }
  }
  return m;
}

/// The positions `qpos` (frames x nq) low-passed; quaternions are kept in one hemisphere first
/// (a sign flip is no rotation but would be filtered as one) and renormalised after.
Eigen::MatrixXd filtered_positions(const mjModel& m, const Eigen::MatrixXd& qpos, double dt,
                                   const LowPassFilter& filter) {
  const int frames = static_cast<int>(qpos.rows());
  Eigen::MatrixXd q = qpos;
  for (int c = 0; c < m.nq; ++c) {
    int joint = -1;
    if (!is_quaternion_start(m, c, &joint)) continue;
    for (int f = 1; f < frames; ++f) {
      if (q.row(f).segment<4>(c).dot(q.row(f - 1).segment<4>(c)) < 0) q.row(f).segment<4>(c) *= -1;
    }
  }
  low_pass(&q, 1.0 / dt, filter);
  for (int c = 0; c < m.nq; ++c) {
    int joint = -1;
    if (!is_quaternion_start(m, c, &joint)) continue;
    for (int f = 0; f < frames; ++f) q.row(f).segment<4>(c).normalize();
  }
  return q;
}

/// The body of `side`'s foot that a plate's force `grf` at `cop` acts on: the toes when its line
/// of action would turn them up about their joint (push-off: the load is under the toes), else
/// the foot. The floor can only push the toes up, so the toe joint's torque is then a flexion
/// demand, and it is zero where the rule switches (the line passes through the joint's axis):
/// continuous. The ankle and every joint above it get the same torque either way.
int loaded_foot_body(const mjModel& m, const mjData& d, const models::Rig& rig, int side,
                     const Eigen::Vector3d& cop, const Eigen::Vector3d& grf) {
  const models::RigLeg& leg = rig.leg(side);
  if (leg.toes < 0 || m.body_jntnum[leg.toes] < 1) return leg.foot;
  const int joint = m.body_jntadr[leg.toes];  // the toes' one hinge (positive: dorsiflexion)
  const Eigen::Vector3d anchor(d.xanchor + 3 * joint), axis(d.xaxis + 3 * joint);
  return axis.dot((cop - anchor).cross(grf)) > 0 ? leg.toes : leg.foot;
}

/// The force plates' ground reaction at time `t_s` on the pose in `d` (kinematics done): each
/// loaded plate's force and free moment, applied at its centre of pressure to the foot standing
/// on it (plate_assignment.h; to its toes when the force's line would turn them up),
/// is added to `qfrc_ground` (nv); `plate_foot` (one per plate) gets the side, kPlateUnloaded or
/// kPlateUnassigned. Returns the sum of the forces applied, N, world.
Eigen::Vector3d apply_force_plates(const mjModel& m, mjData* d,
                                   const std::vector<ForcePlate>& plates, double plate_rate_hz,
                                   double t_s, const plate_internal::PlateFeet& feet,
                                   const models::Rig& rig, std::vector<mjtNum>* qfrc_ground,
                                   int* plate_foot) {
  Eigen::Vector3d total = Eigen::Vector3d::Zero();
  for (size_t i = 0; i < plates.size(); ++i) {
    const ForcePlate& p = plates[i];
    plate_foot[i] = kPlateUnloaded;
    // ForcePlate holds the ground reaction: the force on the subject.
    const plate_internal::PlateSample sample = plate_internal::plate_sample(p, plate_rate_hz, t_s);
    const Eigen::Vector3d &grf = sample.force_N, &cop = sample.cop_m;
    const Eigen::Vector3d& free_moment = sample.free_moment_Nm;
    if (std::abs(grf.z()) < plate_internal::kMinPlateLoad_N) continue;
    if (!cop.allFinite() || !free_moment.allFinite()) continue;
    const int side = feet.foot_for(*d, p, cop);
    plate_foot[i] = side < 0 ? kPlateUnassigned : side;
    if (side < 0) continue;  // left in the root residual, reported
    mjtNum force[3] = {grf.x(), grf.y(), grf.z()};
    mjtNum torque[3] = {free_moment.x(), free_moment.y(), free_moment.z()};
    mjtNum point[3] = {cop.x(), cop.y(), cop.z()};
    mj_applyFT(&m, d, force, torque, point, loaded_foot_body(m, *d, rig, side, cop, grf),
               qfrc_ground->data());
    total += grf;
  }
  return total;
}

/// Row i of the root's residual force and moment (world) from the generalised force: zero
/// without a free root joint.
void root_residual(const mjModel& m, const mjData* d, int root_joint, int i,
                   InverseDynamicsResult* r) {
  if (root_joint >= 0) {
    const int v0 = m.jnt_dofadr[root_joint];
    const int body = m.jnt_bodyid[root_joint];
    const Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> r_WB(d->xmat + 9 * body);
    r->residual_force_N.row(i) = r->generalized_force.row(i).segment<3>(v0);
    // Free-joint rotational DOFs are in the body frame (MuJoCo): rotate to the world.
    r->residual_moment_Nm.row(i) =
        (r_WB * r->generalized_force.row(i).segment<3>(v0 + 3).transpose()).transpose();
  } else {
    r->residual_force_N.row(i).setZero();
    r->residual_moment_Nm.row(i).setZero();
  }
}

/// GroundForces::kEstimated: the ground forces estimated from the whole motion's kinematics and
/// required forces (r's generalized_force, no ground yet) are taken off the generalised forces;
/// the root residuals are what is left.
void apply_estimate(const mjModel& m, mjData* d, int root_joint,
                    const InverseDynamicsOptions& options, InverseDynamicsResult* r) {
  r->ground_estimate =
      estimate_ground_forces(m, r->qpos, r->qvel, r->generalized_force, options.estimate);
  r->generalized_force -= r->ground_estimate.generalized_force;
  r->ground_force_N = r->ground_estimate.force_N[0] + r->ground_estimate.force_N[1];
  for (int i = 0; i < static_cast<int>(r->qpos.rows()); ++i) {
    for (int k = 0; k < m.nq; ++k) d->qpos[k] = r->qpos(i, k);
    mj_kinematics(&m, d);
    root_residual(m, d, root_joint, i, r);
  }
}

}  // namespace

std::vector<std::string> dof_names(const mjModel& m) {
  std::vector<std::string> names;
  for (int j = 0; j < m.njnt; ++j) {
    const char* jn = mj_id2name(&m, mjOBJ_JOINT, j);
    const std::string joint = jn ? jn : "joint" + std::to_string(j);
    switch (m.jnt_type[j]) {
      case mjJNT_FREE:
        for (const char* s : {"root_tx", "root_ty", "root_tz", "root_rx", "root_ry", "root_rz"}) {
          names.push_back(s);
        }
        break;
      case mjJNT_BALL:
        for (const char* s : {"_x", "_y", "_z"}) names.push_back(joint + s);
        break;
      default:
        names.push_back(joint);
    }
  }
  return names;
}

InverseDynamicsResult inverse_dynamics(const mjModel& model, const Motion& motion,
                                       const InverseDynamicsOptions& options,
                                       const std::vector<ForcePlate>& plates,
                                       double plate_rate_hz) {
  check_motion_matches(motion, model, "motion");
  const int frames = motion.frame_count();
  const int trim = std::max(options.trim_frames, 1);
  const double dt = checked_frame_step(motion, trim);
  if (options.ground == GroundForces::kForcePlates && (plates.empty() || !(plate_rate_hz > 0))) {
    throw sim::InvalidArgument(
        "inverse dynamics: ground from force plates, but the capture has "
        "no force plates");
  }
  const std::unique_ptr<mjModel, sim::ModelDeleter> m = model_for_inverse_dynamics(model, options);
  sim::Data data(*m);
  mjData* d = data.get();
  const int nq = m->nq, nv = m->nv;
  const Eigen::MatrixXd q = filtered_positions(*m, motion.qpos, dt, options.filter);

  // Velocities (central) and accelerations (second difference) on the configuration manifold.
  std::vector<mjtNum> qa(static_cast<size_t>(nq)), qb(static_cast<size_t>(nq)),
      v_back(static_cast<size_t>(nv)), v_fwd(static_cast<size_t>(nv));
  auto diff = [&](int f0, int f1, std::vector<mjtNum>* out) {
    for (int k = 0; k < nq; ++k) {
      qa[static_cast<size_t>(k)] = q(f0, k);
      qb[static_cast<size_t>(k)] = q(f1, k);
    }
    mj_differentiatePos(m.get(), out->data(), dt, qa.data(), qb.data());
  };
  const int out_frames = frames - 2 * trim;
  InverseDynamicsResult r;
  r.dof_names = dof_names(*m);
  r.qpos = q.middleRows(trim, out_frames);
  r.qvel.resize(out_frames, nv);
  r.qacc.resize(out_frames, nv);
  r.generalized_force.resize(out_frames, nv);
  r.residual_force_N.resize(out_frames, 3);
  r.residual_moment_Nm.resize(out_frames, 3);
  r.ground_force_N = Eigen::MatrixXd::Zero(out_frames, 3);
  std::vector<mjtNum> qfrc_ground(static_cast<size_t>(nv));
  int root_joint = -1;
  for (int j = 0; j < m->njnt; ++j) {
    if (m->jnt_type[j] == mjJNT_FREE) root_joint = j;
  }
  const models::Rig rig(*m);
  const std::array<int, 2> foot_bodies = {rig.leg(models::kLeft).foot,
                                          rig.leg(models::kRight).foot};
  const plate_internal::PlateFeet plate_feet(*m, foot_bodies);
  r.plate_foot = Eigen::MatrixXi::Constant(out_frames, static_cast<Eigen::Index>(plates.size()),
                                           kPlateUnloaded);
  std::vector<int> plate_foot(plates.size(), kPlateUnloaded);
  for (int i = 0; i < out_frames; ++i) {
    const int f = i + trim;
    diff(f - 1, f, &v_back);
    diff(f, f + 1, &v_fwd);
    for (int k = 0; k < nq; ++k) d->qpos[k] = q(f, k);
    for (int v = 0; v < nv; ++v) {
      d->qvel[v] = 0.5 * (v_back[static_cast<size_t>(v)] + v_fwd[static_cast<size_t>(v)]);
      d->qacc[v] = (v_fwd[static_cast<size_t>(v)] - v_back[static_cast<size_t>(v)]) / dt;
      r.qvel(i, v) = d->qvel[v];
      r.qacc(i, v) = d->qacc[v];
    }
    mj_inverse(m.get(), d);
    std::fill(qfrc_ground.begin(), qfrc_ground.end(), 0.0);
    if (options.ground == GroundForces::kForcePlates) {
      r.ground_force_N.row(i) =
          apply_force_plates(*m, d, plates, plate_rate_hz, motion.times_s[static_cast<size_t>(f)],
                             plate_feet, rig, &qfrc_ground, plate_foot.data())
              .transpose();
      for (size_t p = 0; p < plates.size(); ++p) {
        r.plate_foot(i, static_cast<Eigen::Index>(p)) = plate_foot[p];
      }
    }
    for (int v = 0; v < nv; ++v) {
      r.generalized_force(i, v) = d->qfrc_inverse[v] - qfrc_ground[static_cast<size_t>(v)];
    }
    root_residual(*m, d, root_joint, i, &r);
    r.times_s.push_back(motion.times_s[static_cast<size_t>(f)]);
  }
  if (options.ground == GroundForces::kEstimated) apply_estimate(*m, d, root_joint, options, &r);
  return r;
}

}  // namespace biodyn::mocap_io
