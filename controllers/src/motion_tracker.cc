// Tracking a captured motion with the joint controllers (motion_tracker.h).
#include "biodyn/controllers/motion_tracker.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "biodyn/sim/errors.h"
#include "biodyn/sim/model.h"

namespace biodyn::controllers {
namespace {

// The frame at or before t and the fraction towards the next, t clamped to the motion.
void bracket(const std::vector<double>& times, double t, std::size_t* f0, double* alpha) {
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

Eigen::Quaterniond quat_at(const double* q) { return Eigen::Quaterniond(q[0], q[1], q[2], q[3]).normalized(); }

}  // namespace

TrackedMotion make_tracked_motion(const mjModel& m, const std::vector<double>& times_s, const Eigen::MatrixXd& qpos) {
  if (times_s.size() < 2 || static_cast<Eigen::Index>(times_s.size()) != qpos.rows()) {
    throw sim::InvalidArgument("tracked motion: needs at least 2 frames with a time each, got " +
                               std::to_string(times_s.size()) + " times for " + std::to_string(qpos.rows()) + " frames");
  }
  if (qpos.cols() != m.nq) {
    throw sim::InvalidArgument("tracked motion: frames have " + std::to_string(qpos.cols()) + " qpos values, the model " +
                               std::to_string(m.nq));
  }
  for (std::size_t f = 1; f < times_s.size(); ++f) {
    if (!(times_s[f] > times_s[f - 1])) {
      throw sim::InvalidArgument("tracked motion: frame " + std::to_string(f) + " time " + std::to_string(times_s[f]) +
                                 " s is not after the previous one");
    }
  }
  TrackedMotion motion;
  motion.times_s = times_s;
  motion.qpos = qpos;
  const char* feet[2][2] = {{"foot_l", "toes_l"}, {"foot_r", "toes_r"}};
  int foot_body[2];
  std::vector<int> sole_geoms[2];
  for (int s = 0; s < 2; ++s) {
    foot_body[s] = mj_name2id(&m, mjOBJ_BODY, feet[s][0]);
    const int toes = mj_name2id(&m, mjOBJ_BODY, feet[s][1]);
    if (foot_body[s] < 0) throw sim::InvalidArgument(std::string("tracked motion: the model has no body ") + feet[s][0]);
    for (int g = 0; g < m.ngeom; ++g) {
      if ((m.geom_bodyid[g] == foot_body[s] || m.geom_bodyid[g] == toes) && m.geom_type[g] == mjGEOM_BOX) {
        sole_geoms[s].push_back(g);
      }
    }
  }
  sim::Data scratch(m);
  mjData& d = *scratch;
  std::vector<Eigen::Vector2d> previous(2, Eigen::Vector2d::Zero());
  motion.stance.resize(times_s.size());
  for (std::size_t f = 0; f < times_s.size(); ++f) {
    for (int k = 0; k < m.nq; ++k) d.qpos[k] = qpos(static_cast<Eigen::Index>(f), k);
    mj_kinematics(&m, &d);
    for (int s = 0; s < 2; ++s) {
      double lowest = 1e9;
      for (int g : sole_geoms[s]) {
        // The box's lowest corner: centre minus the half sizes along its axes' vertical parts.
        const mjtNum* R = d.geom_xmat + 9 * g;
        const mjtNum* size = m.geom_size + 3 * g;
        lowest = std::min(lowest, d.geom_xpos[3 * g + 2] - std::abs(R[6]) * size[0] - std::abs(R[7]) * size[1] -
                                      std::abs(R[8]) * size[2]);
      }
      const Eigen::Vector2d at(d.xpos[3 * foot_body[s]], d.xpos[3 * foot_body[s] + 1]);
      const std::size_t from = f > 0 ? f - 1 : 0;
      const double speed = f > 0 ? (at - previous[static_cast<std::size_t>(s)]).norm() / (times_s[f] - times_s[from]) : 0.0;
      previous[static_cast<std::size_t>(s)] = at;
      motion.stance[f][static_cast<std::size_t>(s)] =
          lowest < TrackedMotion::kStanceHeight_m && speed < TrackedMotion::kStanceSpeed_m_s;
    }
  }
  return motion;
}

void motion_pose_at(const mjModel& m, const TrackedMotion& motion, double t_s, double* qpos) {
  std::size_t f0 = 0;
  double a = 0;
  bracket(motion.times_s, t_s, &f0, &a);
  const Eigen::Index r0 = static_cast<Eigen::Index>(f0), r1 = r0 + 1;
  for (int j = 0; j < m.njnt; ++j) {
    const int adr = m.jnt_qposadr[j];
    const auto lerp = [&](int k) { qpos[k] = (1 - a) * motion.qpos(r0, k) + a * motion.qpos(r1, k); };
    const auto slerp = [&](int k) {
      const double q0[4] = {motion.qpos(r0, k), motion.qpos(r0, k + 1), motion.qpos(r0, k + 2), motion.qpos(r0, k + 3)};
      const double q1[4] = {motion.qpos(r1, k), motion.qpos(r1, k + 1), motion.qpos(r1, k + 2), motion.qpos(r1, k + 3)};
      const Eigen::Quaterniond q = quat_at(q0).slerp(a, quat_at(q1));
      qpos[k] = q.w();
      qpos[k + 1] = q.x();
      qpos[k + 2] = q.y();
      qpos[k + 3] = q.z();
    };
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

MotionTracker::MotionTracker(const mjModel& m, std::vector<JointGroup> groups, const TrackedMotion* motion,
                             double lookahead_s)
    : groups_(std::move(groups)), motion_(motion), lookahead_s_(lookahead_s), pose_(static_cast<std::size_t>(m.nq)) {
  if (!(lookahead_s > 0) || !std::isfinite(lookahead_s)) {
    throw sim::InvalidArgument("tracking lookahead: must be > 0 s, got " + std::to_string(lookahead_s));
  }
}

Eigen::Quaterniond MotionTracker::group_orientation(const mjModel& m, const JointGroup& g, const double* qpos) const {
  if (g.ball) return quat_at(qpos + m.jnt_qposadr[m.dof_jntid[g.dof_begin]]);
  Eigen::Vector3d angles = Eigen::Vector3d::Zero();
  for (int k = 0; k < g.dof_count; ++k) angles[k] = qpos[m.jnt_qposadr[m.dof_jntid[g.dof_begin + k]]];
  return orientation_from_angles(g, angles);
}

void MotionTracker::drive(CharacterController& c, const mjModel& m, const mjData& d) {
  // Targets: the motion lookahead_s from now, due then (the same at a redone step: drive()
  // depends on the time only).
  const double due = d.time + lookahead_s_;
  motion_pose_at(m, *motion_, due, pose_.data());
  for (std::size_t i = 0; i < groups_.size(); ++i) {
    const JointGroup& g = groups_[i];
    const int group = static_cast<int>(i);
    if (g.ball) {
      c.set_joint_target(group, group_orientation(m, g, pose_.data()), due);
    } else {
      Eigen::Vector3d angles = Eigen::Vector3d::Zero();
      for (int k = 0; k < g.dof_count; ++k) angles[k] = pose_[static_cast<std::size_t>(m.jnt_qposadr[m.dof_jntid[g.dof_begin + k]])];
      c.set_joint_angles(group, angles, due);
    }
  }
  // Feet: in stance while the motion has them on the floor now.
  std::size_t f0 = 0;
  double a = 0;
  bracket(motion_->times_s, d.time, &f0, &a);
  const std::array<bool, 2>& on = motion_->stance[a < 1 ? f0 : f0 + 1];
  for (int s = 0; s < 2; ++s) c.set_stance(s, on[static_cast<std::size_t>(s)]);
}

MotionTracker::Error MotionTracker::error(const mjModel& m, const mjData& d) const {
  std::vector<double>& pose = pose_;
  motion_pose_at(m, *motion_, d.time, pose.data());
  Error e;
  double sq = 0;
  for (const JointGroup& g : groups_) {
    const Eigen::Quaterniond want = group_orientation(m, g, pose.data());
    const Eigen::Quaterniond have = group_orientation(m, g, d.qpos);
    const double angle = rotation_angle(have.conjugate() * want);
    sq += angle * angle;
  }
  e.joint_rms_rad = groups_.empty() ? 0.0 : std::sqrt(sq / static_cast<double>(groups_.size()));
  // The root: the free joint's position (the first joint of a generated character).
  const int adr = m.jnt_qposadr[0];
  e.root_horizontal_m = std::hypot(d.qpos[adr] - pose[static_cast<std::size_t>(adr)],
                                   d.qpos[adr + 1] - pose[static_cast<std::size_t>(adr + 1)]);
  return e;
}

}  // namespace biodyn::controllers
