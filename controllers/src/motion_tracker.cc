// Tracking a captured motion with the joint controllers (motion_tracker.h).
#include "biodyn/controllers/motion_tracker.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>

#include "biodyn/controllers/ankle_window.h"
#include "biodyn/controllers/gait_core.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/model.h"
#include "biodyn/sim/queries.h"

namespace biodyn::controllers {
namespace {

Eigen::Quaterniond quat_at(const double* q) {
  return Eigen::Quaterniond(q[0], q[1], q[2], q[3]).normalized();
}

// Each foot's sole boxes (the foot's and the toes' box geoms) and their lowest point.
struct Soles {
  std::array<std::vector<int>, 2> geoms;
  Soles(const mjModel& m, const models::Rig& rig) {
    for (int s = 0; s < 2; ++s) {
      for (int g = 0; g < m.ngeom; ++g) {
        if ((m.geom_bodyid[g] == rig.leg(s).foot || m.geom_bodyid[g] == rig.leg(s).toes) &&
            m.geom_type[g] == mjGEOM_BOX) {
          geoms[static_cast<std::size_t>(s)].push_back(g);
        }
      }
    }
  }
  // World height of foot s's lowest box corner (after mj_kinematics).
  double lowest(const mjModel& m, const mjData& d, int s) const {
    double low = 1e9;
    for (int g : geoms[static_cast<std::size_t>(s)])
      low = std::min(low, sim::geom_lowest_z(m, d, g));
    return low;
  }
};

// TrackedMotion::start_swing_lift_rad: for each foot the motion has off the floor at its first
// frame, its lowest point under kSwingClearance_m and not leaving the floor (rising less than
// kSwingClearance_m over kVelocityWindow_s: a toe pushing off is a support, not a trip), the
// smallest dorsiflexion (1 degree steps over the whole of kSwingLiftMax_rad and the ankle's
// range: the lowest point may first dip) that lifts it there, else the one that lifts it
// highest; none if none raises it (a heel about to strike). Then the motion is floored again
// on the stance feet of the lifted first pose, and the lifted feet's clearance kept.
void lift_swinging_feet_at_start(const mjModel& m, const models::Rig& rig, const Soles& soles,
                                 const std::vector<std::array<double, 2>>& lowest, mjData* scratch,
                                 TrackedMotion* motion) {
  constexpr double kStep_rad = M_PI / 180;
  const std::size_t f1 = motion->frame_at(TrackedMotion::kVelocityWindow_s);
  const auto load_first_pose = [&] {
    for (int k = 0; k < m.nq; ++k) scratch->qpos[k] = motion->qpos(0, k);
  };
  const auto ankle_joint = [&](int s) {  // the dorsiflexion hinge
    return m.dof_jntid[rig.groups()[static_cast<std::size_t>(rig.leg(s).ankle)].dof_begin];
  };
  for (int s = 0; s < 2; ++s) {
    const auto side = static_cast<std::size_t>(s);
    if (motion->stance[0][side] || lowest[0][side] >= TrackedMotion::kSwingClearance_m ||
        lowest[f1][side] - lowest[0][side] >= TrackedMotion::kSwingClearance_m) {
      continue;
    }
    load_first_pose();
    const int joint = ankle_joint(s), adr = m.jnt_qposadr[joint];
    const double angle = scratch->qpos[adr];
    const double most = std::min(TrackedMotion::kSwingLiftMax_rad,
                                 m.jnt_limited[joint] ? m.jnt_range[2 * joint + 1] - angle : 1e9);
    double best = lowest[0][side], best_lift = 0;
    for (double lift = kStep_rad; lift <= most + 1e-9; lift += kStep_rad) {
      scratch->qpos[adr] = angle + lift;
      mj_kinematics(&m, scratch);
      const double low = soles.lowest(m, *scratch, s);
      if (low > best) {
        best = low;
        best_lift = lift;
      }
      if (low >= TrackedMotion::kSwingClearance_m) break;  // the smallest that clears it
    }
    motion->start_swing_lift_rad[side] = best_lift;
  }
  if (motion->start_swing_lift_rad[0] == 0 && motion->start_swing_lift_rad[1] == 0) return;
  // The lifted first pose, floored again on its feet in stance (the first flooring may have
  // been on the lifted toe, leaving the stance foot above the floor, to drop at the start).
  load_first_pose();
  for (int s = 0; s < 2; ++s) {
    scratch->qpos[m.jnt_qposadr[ankle_joint(s)]] +=
        motion->start_swing_lift_rad[static_cast<std::size_t>(s)];
  }
  mj_kinematics(&m, scratch);
  double low[2] = {soles.lowest(m, *scratch, 0), soles.lowest(m, *scratch, 1)};
  double gap = 1e9;  // none without a foot in stance
  for (std::size_t side = 0; side < 2; ++side) {
    if (motion->stance[0][side]) gap = std::min(gap, low[side]);
  }
  if (gap > 0 && gap < 1e9 && m.njnt > 0 && m.jnt_type[0] == mjJNT_FREE) {
    motion->qpos.col(m.jnt_qposadr[0] + 2).array() -= gap;
    motion->start_lift_m -= gap;
    for (Eigen::Vector3d& com : motion->com_W) com.z() -= gap;
    low[0] -= gap;
    low[1] -= gap;
  }
  for (std::size_t side = 0; side < 2; ++side) {
    if (motion->start_swing_lift_rad[side] > 0) motion->start_swing_clearance_m[side] = low[side];
  }
}

}  // namespace

TrackedMotion make_tracked_motion(const mjModel& m, const models::Rig& rig,
                                  const std::vector<double>& times_s, const Eigen::MatrixXd& qpos) {
  if (times_s.size() < 2 || static_cast<Eigen::Index>(times_s.size()) != qpos.rows()) {
    throw sim::InvalidArgument("tracked motion: needs at least 2 frames with a time each, got " +
                               std::to_string(times_s.size()) + " times for " +
                               std::to_string(qpos.rows()) + " frames");
  }
  if (qpos.cols() != m.nq) {
    throw sim::InvalidArgument("tracked motion: frames have " + std::to_string(qpos.cols()) +
                               " qpos values, the model " + std::to_string(m.nq));
  }
  for (std::size_t f = 1; f < times_s.size(); ++f) {
    if (!(times_s[f] > times_s[f - 1])) {
      throw sim::InvalidArgument("tracked motion: frame " + std::to_string(f) + " time " +
                                 std::to_string(times_s[f]) + " s is not after the previous one");
    }
  }
  TrackedMotion motion;
  motion.times_s = times_s;
  motion.qpos = qpos;
  rig.require_legs("tracked motion");
  int foot_body[2];
  for (int s = 0; s < 2; ++s) foot_body[s] = rig.leg(s).foot;
  const Soles soles(m, rig);
  sim::Data scratch(m);
  mjData& d = *scratch;
  const auto lowest_sole = [&](int s) { return soles.lowest(m, d, s); };
  // Captured roots are rarely at the simulated floor's height: the whole motion is raised or
  // lowered so the first frame's lowest sole point touches the floor, before the feet's
  // contacts are read from it.
  if (m.njnt > 0 && m.jnt_type[0] == mjJNT_FREE) {
    for (int k = 0; k < m.nq; ++k) d.qpos[k] = qpos(0, k);
    mj_kinematics(&m, &d);
    motion.start_lift_m = -std::min(lowest_sole(0), lowest_sole(1));
    motion.qpos.col(m.jnt_qposadr[0] + 2).array() += motion.start_lift_m;
  }
  motion.com_W.resize(times_s.size());
  motion.ankle_W.resize(times_s.size());
  std::vector<std::array<double, 2>> lowest(times_s.size());
  for (std::size_t f = 0; f < times_s.size(); ++f) {
    for (int k = 0; k < m.nq; ++k) d.qpos[k] = motion.qpos(static_cast<Eigen::Index>(f), k);
    mj_kinematics(&m, &d);
    mj_comPos(&m, &d);
    motion.com_W[f] = Eigen::Vector3d(d.subtree_com[3], d.subtree_com[4],
                                      d.subtree_com[5]);  // body 1: the root's tree
    for (int s = 0; s < 2; ++s) {
      lowest[f][static_cast<std::size_t>(s)] = lowest_sole(s);
      motion.ankle_W[f][static_cast<std::size_t>(s)] =
          Eigen::Vector2d(d.xpos[3 * foot_body[s]], d.xpos[3 * foot_body[s] + 1]);
    }
  }
  // Velocities over +-kVelocityWindow_s: captured and retargeted frames jitter by millimetres
  // to centimetres, which frame-to-frame differences at 120 Hz turn into metres per second.
  const std::size_t n = times_s.size();
  motion.com_velocity_W.resize(n);
  motion.stance.resize(n);
  for (std::size_t f = 0; f < n; ++f) {
    const std::size_t a = motion.frame_at(times_s[f] - TrackedMotion::kVelocityWindow_s);
    const std::size_t b = motion.frame_at(times_s[f] + TrackedMotion::kVelocityWindow_s);
    const double span = b > a ? times_s[b] - times_s[a] : 1.0;
    motion.com_velocity_W[f] = b > a ? Eigen::Vector3d((motion.com_W[b] - motion.com_W[a]) / span)
                                     : Eigen::Vector3d::Zero();
    for (std::size_t s = 0; s < 2; ++s) {
      const double speed =
          b > a ? (motion.ankle_W[b][s] - motion.ankle_W[a][s]).norm() / span : 0.0;
      motion.stance[f][s] =
          lowest[f][s] < TrackedMotion::kStanceHeight_m && speed < TrackedMotion::kStanceSpeed_m_s;
    }
  }
  lift_swinging_feet_at_start(m, rig, soles, lowest, &d, &motion);
  return motion;
}

std::size_t TrackedMotion::frame_at(double t_s) const {
  if (t_s <= times_s.front()) return 0;
  const auto it = std::lower_bound(times_s.begin(), times_s.end(), t_s);
  if (it == times_s.end()) return times_s.size() - 1;
  const std::size_t f = static_cast<std::size_t>(it - times_s.begin());
  return t_s - times_s[f - 1] < times_s[f] - t_s ? f - 1 : f;
}

void motion_pose_at(const mjModel& m, const TrackedMotion& motion, double t_s, double* qpos) {
  std::size_t f0 = 0;
  double a = 0;
  sim::bracket_time(motion.times_s, t_s, &f0, &a);
  const Eigen::Index r0 = static_cast<Eigen::Index>(f0);
  sim::interpolate_qpos(m, motion.qpos.row(r0), motion.qpos.row(r0 + 1), a, qpos);
}

void MotionTrackerParams::validate() const {
  const auto check = [](bool ok, const char* field, double value) {
    if (!ok)
      throw sim::InvalidArgument(std::string("tracker ") + field + ": out of range, got " +
                                 std::to_string(value));
  };
  check(lookahead_s > 0 && lookahead_s <= 1, "lookahead_s (0, 1] s", lookahead_s);
  check(ankle_cop_margin >= 0 && ankle_cop_margin <= 1, "ankle_cop_margin [0, 1]",
        ankle_cop_margin);
  for (const auto& [name, v] : {std::pair<const char*, double>{"sagittal_cd", sagittal_cd},
                                {"sagittal_cv", sagittal_cv},
                                {"frontal_cd", frontal_cd},
                                {"frontal_cv", frontal_cv},
                                {"ankle_cd", ankle_cd},
                                {"ankle_cv", ankle_cv}}) {
    check(std::isfinite(v) && std::abs(v) <= 10, name, v);
  }
}

MotionTracker::MotionTracker(const mjModel& m, const models::Rig& rig, const TrackedMotion* motion,
                             MotionTrackerParams params)
    : rig_(&rig), motion_(motion), params_(params), pose_(static_cast<std::size_t>(m.nq)) {
  params_.validate();
  rig.require_legs("motion tracker");
  for (int s = 0; s < 2; ++s) {
    if (!rig.groups()[static_cast<std::size_t>(rig.leg(s).hip)].ball) {
      throw models::RigError(std::string("motion tracker: the model needs a ball hip") +
                             models::kSideSuffix[s]);
    }
  }
  weight_ = rig.mass_kg() * -m.opt.gravity[2];
  contacts_.reserve(64);
}

Eigen::Quaterniond MotionTracker::group_orientation(const mjModel& m, const JointGroup& g,
                                                    const double* qpos) const {
  if (g.ball) return quat_at(qpos + m.jnt_qposadr[m.dof_jntid[g.dof_begin]]);
  return orientation_from_angles(g, hinge_angles(m, g, qpos));
}

void MotionTracker::apply_offsets(const mjModel& m, ControlFrame* frame) const {
  if (offsets_.size() != m.nv) return;
  const std::vector<JointGroup>& groups = rig_->groups();
  for (std::size_t i = 0; i < groups.size(); ++i) {
    const JointGroup& g = groups[i];
    const int group = static_cast<int>(i);
    const JointTarget& t = frame->target(group);
    if (g.ball) {
      const Eigen::Vector3d r = offsets_.segment<3>(g.dof_begin);
      if (r.isZero()) continue;
      const Eigen::Quaterniond turn(Eigen::AngleAxisd(r.norm(), r.normalized()));
      frame->set_target(group, t.orientation * turn, t.reach_at_s);
    } else {
      Eigen::Vector3d angles = angles_from_orientation(g, t.orientation);
      bool any = false;
      for (int k = 0; k < g.dof_count; ++k) {
        angles[k] += offsets_(g.dof_begin + k);
        any = any || offsets_(g.dof_begin + k) != 0.0;
      }
      if (any) frame->set_joint_angles(group, angles, t.reach_at_s);
    }
  }
}

void MotionTracker::drive(const ControlInput& in, ControlFrame* frame) {
  drive_feedback(in, frame);
  apply_offsets(in.m, frame);
}

void MotionTracker::drive_feedback(const ControlInput& in, ControlFrame* frame) {
  const mjModel& m = in.m;
  const mjData& d = in.d;
  const std::vector<JointGroup>& groups = rig_->groups();
  // Targets: the motion lookahead_s from now, due then (the same at a redone step: drive()
  // depends on the state at the step's start only).
  const double due = d.time + params_.lookahead_s;
  motion_pose_at(m, *motion_, due, pose_.data());
  for (std::size_t i = 0; i < groups.size(); ++i) {
    const JointGroup& g = groups[i];
    const int group = static_cast<int>(i);
    if (g.ball) {
      frame->set_target(group, group_orientation(m, g, pose_.data()), due);
    } else {
      frame->set_joint_angles(group, hinge_angles(m, g, pose_.data()), due);
    }
  }
  // Feet: in stance while the motion has them on the floor now.
  std::size_t f0 = 0;
  double a = 0;
  sim::bracket_time(motion_->times_s, d.time, &f0, &a);
  const std::size_t now = a < 1 ? f0 : f0 + 1;
  const std::array<bool, 2>& on = motion_->stance[now];
  for (int s = 0; s < 2; ++s) frame->set_stance(s, on[static_cast<std::size_t>(s)]);
  // Every foot on the floor: its ankle torque within what the ground can return with the
  // centre of pressure inside its contacts (ankle_window.h), so a loaded foot stays flat and
  // the body rolls over it rather than the foot rocking on an edge (which it did from 0.2 s,
  // and no weld could engage). The load is the foot's ground force in the last step, capped
  // at 1.5 body weights as the walker does.
  if (params_.ankle_cop_margin > 0) {
    sim::floor_contacts(m, d, rig_->floor_geom(), &contacts_);
    for (int s = 0; s < 2; ++s) {
      const models::RigLeg& leg = rig_->leg(s);
      const double load = std::min(foot_load_N(in.last_report, s), 1.5 * weight_);
      limit_ankle_to_contacts(frame, m, d, groups[static_cast<std::size_t>(leg.ankle)], leg.foot,
                              leg.toes, contacts_, load, params_.ankle_cop_margin);
    }
  }
  if (!params_.balance) return;

  // Stance hips carry the pelvis to the motion's world orientation (a free root's qpos
  // quaternion is its body's world orientation): with the thigh where it is, the hip rotation
  // that gives it (xquat_thigh = xquat_pelvis * body_quat_thigh * q_hip).
  const Eigen::Quaterniond pelvis_wanted = quat_at(pose_.data() + m.jnt_qposadr[0] + 3);
  for (int s = 0; s < 2; ++s) {
    if (!on[static_cast<std::size_t>(s)]) continue;
    const models::RigLeg& leg = rig_->leg(s);
    const Eigen::Quaterniond thigh = quat_at(d.xquat + 4 * leg.thigh);
    const Eigen::Quaterniond hip =
        quat_at(m.body_quat + 4 * leg.thigh).conjugate() * pelvis_wanted.conjugate() * thigh;
    frame->set_target(leg.hip, hip.normalized(), due);
    if (foot_touches_floor(m, d, *rig_, s)) {
      // As the walker's stance hip (gait_controller.cc): the pelvis's world angular velocity
      // goes to e/lookahead (e its world orientation error to the motion's, due then), the
      // thigh's own rotation fed forward: the hip's velocity (thigh frame) is what turns the
      // pelvis so with the thigh turning as it does. Without it the hip only follows a
      // relative target computed for the thigh where it is, the pelvis lags the body's own
      // rotation over the stance foot, and the trunk yaws off the motion (measured: 37 deg
      // in 1 s on the body's own walk). Only with the foot on the floor: a thigh in the
      // air turns with the hip instead, and feeding its rotation forward would spin it up.
      const Eigen::Quaterniond pelvis = quat_at(d.xquat + 4 * rig_->pelvis());
      const Eigen::Vector3d w_wanted =
          rotation_vector(pelvis_wanted * pelvis.conjugate()) / params_.lookahead_s;
      const Eigen::Vector3d w_thigh(d.cvel[6 * leg.thigh], d.cvel[6 * leg.thigh + 1],
                                    d.cvel[6 * leg.thigh + 2]);
      frame->set_velocity(leg.hip, thigh.conjugate() * (w_thigh - w_wanted));
    }
  }
  if (!on[0] && !on[1]) return;  // flight: nothing to push against
  // The CoM relative to the stance ankle(s), and the same in the motion, in the pelvis's
  // heading frame (its x axis on the floor).
  const sim::CenterOfMass com = sim::center_of_mass(m, d);
  Eigen::Vector2d ankle = Eigen::Vector2d::Zero(), ankle_ref = Eigen::Vector2d::Zero();
  int stance_feet = 0;
  for (int s = 0; s < 2; ++s) {
    if (!on[static_cast<std::size_t>(s)]) continue;
    ankle += Eigen::Vector2d(d.xpos[3 * rig_->leg(s).foot], d.xpos[3 * rig_->leg(s).foot + 1]);
    ankle_ref += motion_->ankle_W[now][static_cast<std::size_t>(s)];
    ++stance_feet;
  }
  ankle /= stance_feet;
  ankle_ref /= stance_feet;
  const Eigen::Vector2d dd =
      (com.position_W.head<2>() - ankle) - (motion_->com_W[now].head<2>() - ankle_ref);
  const Eigen::Vector2d dv = com.velocity_W.head<2>() - motion_->com_velocity_W[now].head<2>();
  const mjtNum* R = d.xmat + 9 * rig_->pelvis();
  Eigen::Vector2d along(R[0], R[3]);
  if (along.norm() < 1e-6) return;
  along.normalize();
  const Eigen::Vector2d left(-along.y(), along.x());
  if (on[0] && on[1]) {
    // Double support: the ankles lean the body back towards the motion's CoM.
    const double lean = -(params_.ankle_cd * dd.dot(along) + params_.ankle_cv * dv.dot(along));
    for (int s = 0; s < 2; ++s) {
      const int ankle_group = rig_->leg(s).ankle;
      Eigen::Vector3d angles =
          hinge_angles(m, groups[static_cast<std::size_t>(ankle_group)], pose_.data());
      angles[0] += lean;  // dorsiflexion leans the shank forward
      frame->set_joint_angles(ankle_group, angles, due);
    }
    return;
  }
  // Single support: the swing foot lands further along where the CoM is ahead of, or faster
  // than, the motion's (SIMBICON's c_d d + c_v v on the deviations).
  const int stance = on[0] ? 0 : 1, swing = 1 - stance;
  const double sagittal = params_.sagittal_cd * dd.dot(along) + params_.sagittal_cv * dv.dot(along);
  const double frontal = params_.frontal_cd * dd.dot(left) + params_.frontal_cv * dv.dot(left);
  const int hip_group = rig_->leg(swing).hip;
  const JointGroup& hip = groups[static_cast<std::size_t>(hip_group)];
  Eigen::Vector3d angles = angles_from_orientation(hip, group_orientation(m, hip, pose_.data()));
  angles[0] += sagittal;                             // flexion: the thigh forward
  angles[1] += (swing == 0 ? 1.0 : -1.0) * frontal;  // abduction: left leg to the left
  frame->set_target(hip_group, orientation_from_angles(hip, angles), due);
}

MotionTracker::Error MotionTracker::error(const mjModel& m, const mjData& d) const {
  std::vector<double>& pose = pose_;
  motion_pose_at(m, *motion_, d.time, pose.data());
  Error e;
  double sq = 0;
  const std::vector<JointGroup>& groups = rig_->groups();
  for (const JointGroup& g : groups) {
    const Eigen::Quaterniond want = group_orientation(m, g, pose.data());
    const Eigen::Quaterniond have = group_orientation(m, g, d.qpos);
    const double angle = rotation_angle(have.conjugate() * want);
    sq += angle * angle;
  }
  e.joint_rms_rad = groups.empty() ? 0.0 : std::sqrt(sq / static_cast<double>(groups.size()));
  // The root: the free joint's position (the first joint of a generated character).
  const int adr = m.jnt_qposadr[0];
  e.root_horizontal_m = std::hypot(d.qpos[adr] - pose[static_cast<std::size_t>(adr)],
                                   d.qpos[adr + 1] - pose[static_cast<std::size_t>(adr + 1)]);
  return e;
}

}  // namespace biodyn::controllers
