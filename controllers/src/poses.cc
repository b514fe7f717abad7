#include "biodyn/controllers/poses.h"

#include <algorithm>
#include <cmath>

#include "biodyn/controllers/foot_contact.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/queries.h"
#include "biodyn/sim/units.h"

namespace biodyn::controllers {
namespace {

using Eigen::Vector2d;
using Eigen::Vector3d;

// Quiet standing: knees slightly unlocked (a straight knee sits on its limit), the shank and
// thigh angles split so the trunk stays upright.
constexpr double kStandKnee_deg = 4, kStandAnkle_deg = 2, kStandHip_deg = 2;

// Sets `joint` (or joint_l and joint_r) if the model has it.
void set_angles(Pose* p, const std::vector<JointGroup>& groups, const std::string& joint,
                const Vector3d& deg) {
  for (const std::string& name : {joint, joint + "_l", joint + "_r"}) {
    if (find_group(groups, name) >= 0) p->angles_rad[name] = deg * kRadPerDeg;
  }
}

Pose standing(const std::vector<JointGroup>& groups, const std::string& name, double duration,
              double reach) {
  Pose p;
  p.name = name;
  p.duration_s = duration;
  p.reach_time_s = reach;
  set_angles(&p, groups, "knee", Vector3d(kStandKnee_deg, 0, 0));
  set_angles(&p, groups, "ankle", Vector3d(kStandAnkle_deg, 0, 0));
  set_angles(&p, groups, "hip", Vector3d(kStandHip_deg, 0, 0));
  return p;
}

bool has(const std::vector<JointGroup>& groups, const std::string& name) {
  return find_group(groups, name) >= 0;
}

}  // namespace

std::vector<std::string> pose_scenario_names() { return {"stand", "squat", "reach", "one-leg"}; }

std::vector<Pose> pose_scenario(const std::string& name, const std::vector<JointGroup>& groups,
                                double duration_s) {
  std::vector<Pose> poses;
  if (name == "stand") {
    poses.push_back(standing(groups, "stand", 1.0, 0.3));
  } else if (name == "squat") {
    poses.push_back(standing(groups, "stand", 0.5, 0.3));
    // A deep squat with heels down: the ankle is near its 20 deg dorsiflexion stop, so the
    // trunk leans forward and the arms reach forward to keep the CoM over the feet.
    Pose down;
    down.name = "squat down";
    down.duration_s = 2.5;
    down.reach_time_s = 1.5;
    // With these angles the CoM of the default body sits 40% of the foot length in front
    // of the heel, where the balance holds it (checked statically with the feet flat).
    set_angles(&down, groups, "ankle", Vector3d(15, 0, 0));
    set_angles(&down, groups, "knee", Vector3d(70, 0, 0));
    set_angles(&down, groups, "hip", Vector3d(110, 0, 0));
    set_angles(&down, groups, "shoulder", Vector3d(90, 0, 0));
    poses.push_back(down);
    Pose up = standing(groups, "stand up", 2.5, 1.5);
    poses.push_back(up);
  } else if (name == "reach") {
    if (!has(groups, "shoulder_r")) {
      throw sim::InvalidArgument(
          "scenario reach: the model has no arms (use the full character: --detail full)");
    }
    poses.push_back(standing(groups, "stand", 0.5, 0.3));
    Pose reach = standing(groups, "reach forward", 2.5, 1.2);
    set_angles(&reach, groups, "shoulder_r", Vector3d(90, 0, 0));
    set_angles(&reach, groups, "lumbar", Vector3d(8, 0, 0));
    set_angles(&reach, groups, "thorax", Vector3d(8, 0, 0));
    poses.push_back(reach);
    poses.push_back(standing(groups, "arm down", 2.5, 1.2));
  } else if (name == "one-leg") {
    // Shift the weight onto the left leg and back. Lifting the unloaded foot is not in the
    // scenario yet: with every stance joint's acceleration prescribed, the lift's reaction
    // rocks the single stance foot about its edge (controllers/README.md, open points).
    poses.push_back(standing(groups, "stand", 0.5, 0.3));
    Pose shift = standing(groups, "weight on left", 3.0, 1.0);
    shift.support = Support::kLeft;
    poses.push_back(shift);
    poses.push_back(standing(groups, "both feet", 2.0, 1.0));
  } else {
    std::string known;
    for (const std::string& n : pose_scenario_names()) known += (known.empty() ? "" : ", ") + n;
    throw sim::InvalidArgument("scenario: must be one of " + known + ", got '" + name + "'");
  }
  double total = 0;
  for (const Pose& p : poses) total += p.duration_s;
  if (duration_s > total) poses.back().duration_s += duration_s - total;
  return poses;
}

namespace {

// Joint angles of `pose` with the stance legs leaned by `tilt` into qpos (the root is left).
void write_pose_angles(const mjModel& m, mjData& d, const std::vector<JointGroup>& groups,
                       const Pose& pose, double tilt) {
  for (const JointGroup& g : groups) {
    const auto it = pose.angles_rad.find(g.name);
    Vector3d angles = it == pose.angles_rad.end() ? Vector3d::Zero() : it->second;
    for (int s = 0; s < 2; ++s) {
      if (!pose.stance[static_cast<std::size_t>(s)]) continue;
      const std::string side = s == 0 ? "_l" : "_r";
      if (g.name == "ankle" + side) angles[0] += tilt;
      if (g.name == "hip" + side) angles[0] -= tilt;
    }
    angles = clamp_to_range(g, angles, 0.0);
    const int first_joint = m.dof_jntid[g.dof_begin];
    if (g.ball) {
      const Eigen::Quaterniond q = orientation_from_angles(g, angles);
      mjtNum* qpos = d.qpos + m.jnt_qposadr[first_joint];
      qpos[0] = q.w(), qpos[1] = q.x(), qpos[2] = q.y(), qpos[3] = q.z();
    } else {
      for (int k = 0; k < g.dof_count; ++k)
        d.qpos[m.jnt_qposadr[m.dof_jntid[g.dof_begin + k]]] = angles[k];
    }
  }
}

// The balance's support point on a sole, foot frame: `fraction` of the way from heel to toe
// tip, on the sole's centre line and plane.
Vector3d balance_point_B(const models::Sole& sole, double fraction) {
  Vector3d p = sole.centre_B();
  p.x() = sole.x_min + fraction * (sole.x_max - sole.x_min);
  return p;
}

Vector3d sole_point_W(const mjData& d, int foot, const Vector3d& point_B) {
  const Eigen::Map<const Eigen::Matrix<mjtNum, 3, 3, Eigen::RowMajor>> R(d.xmat + 9 * foot);
  return Vector3d(d.xpos[3 * foot], d.xpos[3 * foot + 1], d.xpos[3 * foot + 2]) + R * point_B;
}

}  // namespace

double place_in_pose(const mjModel& m, mjData& d, const models::Rig& rig, const Pose& pose,
                     const BalanceParams& balance) {
  balance.validate();
  rig.require_legs("place_in_pose");
  const std::vector<JointGroup>& groups = rig.groups();
  const int foot[2] = {rig.leg(models::kLeft).foot, rig.leg(models::kRight).foot};
  mjtNum* root = d.qpos + m.jnt_qposadr[rig.root_joint()];
  const double x0 = root[0], y0 = root[1];
  Vector3d point_B[2];
  for (int s = 0; s < 2; ++s)
    point_B[s] = balance_point_B(rig.leg(s).sole, balance.support_point_fraction);
  // Rest height of the soles (the model's own standing state).
  mju_copy(d.qpos, m.qpos0, m.nq);
  mj_kinematics(&m, &d);
  const double sole_z =
      std::min(sole_point_W(d, foot[0], point_B[0]).z(), sole_point_W(d, foot[1], point_B[1]).z());
  const int stance_foot = pose.stance[0] ? foot[0] : foot[1];
  // Feet that carry the body (both if the pose names none).
  const bool carries[2] = {pose.stance[0] || !pose.stance[1], pose.stance[1] || !pose.stance[0]};

  // CoM x minus support point x for a lean `tilt`, with the feet flat and on the floor.
  const auto place = [&](double tilt) {
    mju_copy(d.qpos, m.qpos0, m.nq);
    write_pose_angles(m, d, groups, pose, tilt);
    root[3] = 1, root[4] = root[5] = root[6] = 0;
    mj_kinematics(&m, &d);
    const Eigen::Quaterniond q_foot(d.xquat[4 * stance_foot], d.xquat[4 * stance_foot + 1],
                                    d.xquat[4 * stance_foot + 2], d.xquat[4 * stance_foot + 3]);
    const Eigen::Quaterniond q_root = q_foot.conjugate();  // the stance sole flat
    root[3] = q_root.w(), root[4] = q_root.x(), root[5] = q_root.y(), root[6] = q_root.z();
    mj_kinematics(&m, &d);
    double lowest = 1e9;
    Vector2d support = Vector2d::Zero();
    int n = 0;
    for (int s = 0; s < 2; ++s) {
      if (!carries[s]) continue;
      const Vector3d p = sole_point_W(d, foot[s], point_B[s]);
      lowest = std::min(lowest, p.z());
      support += p.head<2>();
      ++n;
    }
    root[0] += x0 - support.x() / n;  // support point under the old root position
    root[1] += y0 - support.y() / n;
    root[2] += sole_z - lowest;
    mj_kinematics(&m, &d);
    mj_comPos(&m, &d);
    return d.subtree_com[0] - x0;  // root body 0's subtree: the whole body
  };
  // Secant iteration on the lean (the CoM moves ~1 m per radian: a few steps suffice).
  double t0 = 0, f0 = place(t0);
  double t1 = -f0 / 1.0, f1 = place(t1);
  for (int it = 0; it < 8 && std::abs(f1) > 1e-4 && std::abs(f1 - f0) > 1e-12; ++it) {
    const double t2 =
        std::clamp(t1 - f1 * (t1 - t0) / (f1 - f0), -balance.max_tilt_rad, balance.max_tilt_rad);
    t0 = t1, f0 = f1;
    t1 = t2, f1 = place(t1);
  }
  mju_zero(d.qvel, m.nv);
  mj_forward(&m, &d);
  return t1;
}

void BalanceParams::validate() const {
  const auto fail = [](const std::string& f, const std::string& rule, double v) {
    throw sim::InvalidArgument("balance." + f + ": " + rule + ", got " + std::to_string(v));
  };
  if (!(proportional >= 0)) fail("proportional", "must be >= 0", proportional);
  if (!(integral_per_s >= 0)) fail("integral_per_s", "must be >= 0", integral_per_s);
  if (!(max_tilt_rad > 0 && max_tilt_rad < 1))
    fail("max_tilt_rad", "must be in (0, 1) rad", max_tilt_rad);
  if (!(hip_gain_rad_per_m >= 0)) fail("hip_gain_rad_per_m", "must be >= 0", hip_gain_rad_per_m);
  if (!(hip_threshold_fraction >= 0))
    fail("hip_threshold_fraction", "must be >= 0", hip_threshold_fraction);
  if (!(max_hip_rad >= 0 && max_hip_rad < 1.5))
    fail("max_hip_rad", "must be in [0, 1.5) rad", max_hip_rad);
  if (!(support_point_fraction >= 0 && support_point_fraction <= 1))
    fail("support_point_fraction", "must be in [0, 1] (heel to toe tip)", support_point_fraction);
}

StandingBalance::StandingBalance(const mjModel& m, const models::Rig& rig, BalanceParams params)
    : params_(params) {
  params_.validate();
  rig.require_legs("standing balance");
  pelvis_ = rig.pelvis();
  leg_length_ =
      m.qpos0[m.jnt_qposadr[rig.root_joint()] + 2];  // pelvis (hip-centre) height when standing
  for (int s = 0; s < 2; ++s) {
    foot_[s] = rig.leg(s).foot;
    const models::Sole& sole = rig.leg(s).sole;
    support_point_B_[s] = balance_point_B(sole, params_.support_point_fraction);
    foot_half_length_ = (sole.x_max - sole.x_min) / 2;
  }
}

void StandingBalance::set_params(const BalanceParams& params) {
  params.validate();
  params_ = params;
}

void StandingBalance::preset_sagittal_tilt(double tilt_rad) {
  state_.integral.setZero();
  if (params_.integral_per_s > 0)
    state_.integral.x() = -tilt_rad * leg_length_ / params_.integral_per_s;
  state_.last_update_s = std::numeric_limits<double>::quiet_NaN();
}

void StandingBalance::reset() {
  state_.integral.setZero();
  state_.error.setZero();
  state_.last_update_s = std::numeric_limits<double>::quiet_NaN();
}

BalanceOffsets StandingBalance::update(const mjModel& m, const mjData& d, Support support,
                                       double dt) {
  BalanceOffsets out;
  // Support centre (world, horizontal).
  Vector2d feet[2];
  for (int s = 0; s < 2; ++s) feet[s] = sole_point_W(d, foot_[s], support_point_B_[s]).head<2>();
  Vector2d& centre_ = state_.centre;
  Vector2d& error_ = state_.error;
  centre_ = support == Support::kBoth   ? Vector2d(0.5 * (feet[0] + feet[1]))
            : support == Support::kLeft ? feet[0]
                                        : feet[1];
  // Capture point xi = c + v / omega0 (Pratt et al. 2006).
  const sim::CenterOfMass cm = sim::center_of_mass(m, d);
  const Vector3d& com = cm.position_W;
  const Vector3d& vel = cm.velocity_W;
  const double omega0 = std::sqrt(std::abs(m.opt.gravity[2]) / std::max(com.z(), 0.1));
  const Vector2d xi = com.head<2>() + vel.head<2>() / omega0;
  // Heading frame: the pelvis x axis on the floor.
  const double yaw = std::atan2(d.xmat[9 * pelvis_ + 3], d.xmat[9 * pelvis_]);
  const Eigen::Rotation2Dd to_heading(-yaw);
  error_ = to_heading * (xi - centre_);
  if (!params_.enabled) return out;

  const double L = leg_length_;
  const double integral_limit = params_.max_tilt_rad * L / std::max(params_.integral_per_s, 1e-9);
  if (!(d.time == state_.last_update_s)) {  // a new step (not a redo at the same time)
    state_.integral_at_step_start = state_.integral;
    state_.last_update_s = d.time;
  }
  Vector2d& integral = state_.integral;
  integral = state_.integral_at_step_start + error_ * dt;
  integral = integral.cwiseMax(-integral_limit).cwiseMin(integral_limit);
  const Vector2d tilt = -(params_.proportional * error_ + params_.integral_per_s * integral) / L;
  out.sagittal_tilt = std::clamp(tilt.x(), -params_.max_tilt_rad, params_.max_tilt_rad);
  out.frontal_tilt = std::clamp(tilt.y(), -params_.max_tilt_rad, params_.max_tilt_rad);
  const double excess = error_.x() - params_.hip_threshold_fraction * foot_half_length_;
  if (excess > 0)
    out.hip_flexion = std::min(params_.hip_gain_rad_per_m * excess, params_.max_hip_rad);
  return out;
}

}  // namespace biodyn::controllers
