#include "biodyn/controllers/gait_controller.h"

#include <algorithm>
#include <cmath>

#include "biodyn/controllers/ankle_window.h"
#include "biodyn/controllers/foot_contact.h"
#include "biodyn/controllers/support_polygon.h"
#include "biodyn/sim/errors.h"

namespace biodyn::controllers {
namespace {

using Eigen::Quaterniond;
using Eigen::Vector2d;
using Eigen::Vector3d;

constexpr double kGravity = 9.81;
constexpr double kDeg = M_PI / 180.0;
const char* const kSide[2] = {"_l", "_r"};
// s, how soon the swing foot's level sole and the clearance knee are due: short, as they
// follow the leg from step to step (the sole within a few degrees, the knee before the foot
// reaches the floor).
constexpr double kSoleTracking_s = 0.05;
constexpr double kClearanceTracking_s = 0.03;

Vector3d vec_at(const mjtNum* p) { return {p[0], p[1], p[2]}; }
Quaterniond quat_at(const mjtNum* q) { return {q[0], q[1], q[2], q[3]}; }

Vector2d rotate(const Vector2d& v, double angle) {
  const double c = std::cos(angle), s = std::sin(angle);
  return {c * v.x() - s * v.y(), s * v.x() + c * v.y()};
}

}  // namespace

LegTriangle solve_leg_triangle(double l1, double l2, const Vector3d& r, double sigma, double min_knee_rad,
                               double max_knee_rad) {
  LegTriangle out;
  const double reach_max = std::sqrt(l1 * l1 + l2 * l2 + 2 * l1 * l2 * std::cos(min_knee_rad));
  const double reach_min =
      std::max(0.3 * (l1 + l2), std::sqrt(l1 * l1 + l2 * l2 + 2 * l1 * l2 * std::cos(max_knee_rad)));
  const double wanted = r.norm();
  const double len = std::clamp(wanted, reach_min, reach_max);
  out.reachable = wanted >= reach_min && wanted <= reach_max;
  // Law of cosines: the knee's interior angle is pi - flexion. Beyond reach the knee is at its
  // least flexion exactly (the cosine there is +-1 up to rounding).
  out.knee_flexion_rad =
      wanted >= reach_max
          ? min_knee_rad
          : M_PI - std::acos(std::clamp((l1 * l1 + l2 * l2 - len * len) / (2 * l1 * l2), -1.0, 1.0));
  // alpha: the thigh's angle in front of the hip-ankle line (the knee bends backwards, so the
  // thigh leans forward).
  const double k = out.knee_flexion_rad;
  const double alpha = std::atan2(l2 * std::sin(k), l1 + l2 * std::cos(k));
  out.hip_flexion_rad = std::atan2(r.x(), -r.z()) + alpha;
  out.hip_abduction_rad = std::atan2(sigma * r.y(), -r.z());
  return out;
}

double base_polygon_step(double com_from_rear, double foot_length) {
  const double gap = 4.0 * com_from_rear / 3.0 - 2.0 * foot_length;
  return gap + foot_length;
}

void GaitCommand::validate() const {
  if (!(speed_m_s >= 0 && speed_m_s <= 3))
    throw sim::InvalidArgument("gait command: speed must be in [0, 3] m/s, got " + std::to_string(speed_m_s));
  if (!(std::abs(heading_rate_rad_s) <= 3))
    throw sim::InvalidArgument("gait command: heading rate must be within +-3 rad/s, got " +
                               std::to_string(heading_rate_rad_s));
  for (std::size_t i = 0; i < step_lengths_m.size(); ++i) {
    if (!(step_lengths_m[i] >= -0.5 && step_lengths_m[i] <= 2.0))
      throw sim::InvalidArgument("gait command: step length " + std::to_string(i + 1) +
                                 " must be in [-0.5, 2] m, got " + std::to_string(step_lengths_m[i]));
  }
}

GaitController::GaitController(const mjModel& m, const std::vector<JointGroup>& groups,
                               GaitParams params)
    : params_(std::move(params)), groups_(groups) {
  params_.validate();
  for (int s = 0; s < 2; ++s) {
    hip_[s] = find_group(groups_, std::string("hip") + kSide[s]);
    knee_[s] = find_group(groups_, std::string("knee") + kSide[s]);
    ankle_[s] = find_group(groups_, std::string("ankle") + kSide[s]);
    foot_[s] = mj_name2id(&m, mjOBJ_BODY, (std::string("foot") + kSide[s]).c_str());
    toes_[s] = mj_name2id(&m, mjOBJ_BODY, (std::string("toes") + kSide[s]).c_str());
    thigh_[s] = mj_name2id(&m, mjOBJ_BODY, (std::string("thigh") + kSide[s]).c_str());
    if (hip_[s] < 0 || knee_[s] < 0 || ankle_[s] < 0 || foot_[s] < 0 || thigh_[s] < 0) {
      throw sim::InvalidArgument(std::string("gait: the model needs joints hip, knee, ankle and bodies ") +
                                 "thigh, foot on both sides (a generated character)");
    }
  }
  pelvis_ = mj_name2id(&m, mjOBJ_BODY, "pelvis");
  floor_geom_ = mj_name2id(&m, mjOBJ_GEOM, "floor");
  if (pelvis_ < 0 || floor_geom_ < 0)
    throw sim::InvalidArgument("gait: the model needs a body 'pelvis' and a geom 'floor'");
  // Leg geometry from the rest pose (body frames are parallel at rest).
  const int shank = groups_[static_cast<std::size_t>(knee_[0])].body;
  const int foot = foot_[0];
  l_thigh_ = vec_at(m.body_pos + 3 * shank).norm();
  l_shank_ = vec_at(m.body_pos + 3 * foot).norm();
  const Sole sole = find_sole(m, foot);
  ankle_height_ = -sole.z;
  foot_length_ = sole.x_max - sole.x_min;
  foot_width_ = sole.y_max - sole.y_min;
  weight_ = 0;
  for (int b = 1; b < m.nbody; ++b) weight_ += m.body_mass[b];
  weight_ *= -m.opt.gravity[2];
  hip_spacing_ = std::abs(m.body_pos[3 * thigh_[0] + 1] - m.body_pos[3 * thigh_[1] + 1]);
  compile_roles();
  contacts_.reserve(64);
  points_.reserve(64);
  hull_.reserve(128);
  tolerance_.reserve(128);
}

void GaitController::set_params(const GaitParams& params) {
  params.validate();
  const GaitParams old = params_;
  params_ = params;
  try {
    compile_roles();
  } catch (...) {
    params_ = old;
    compile_roles();
    throw;
  }
  if (state_ >= static_cast<int>(params_.states.size())) state_ = 0;
}

void GaitController::set_command(const GaitCommand& command) {
  command.validate();
  command_ = command;
  stones_used_ = 0;
}

void GaitController::compile_roles() {
  const std::size_t n = params_.states.size();
  std::vector<std::array<std::vector<RoleTarget>, 2>> roles(n);
  std::vector<Vector3d> swing_hip(n, Vector3d::Zero());
  std::vector<bool> has_swing_hip(n, false);
  for (std::size_t i = 0; i < n; ++i) {
    const GaitState& st = params_.states[i];
    for (int stance = 0; stance < 2; ++stance) {
      const int swing = 1 - stance;
      std::vector<Vector3d> angles(groups_.size(), Vector3d::Zero());
      for (const auto& [role, a] : st.targets_rad) {
        if (role == "swing_hip") {
          swing_hip[i] = a;
          has_swing_hip[i] = true;
          continue;
        }
        std::string name = role;
        if (role.rfind("stance_", 0) == 0) name = role.substr(7) + kSide[stance];
        else if (role.rfind("swing_", 0) == 0) name = role.substr(6) + kSide[swing];
        const int g = find_group(groups_, name);
        if (g < 0) {
          throw sim::InvalidArgument("gait.states[" + std::to_string(i) + "] (" + st.name +
                                     ").targets_deg." + role + ": the model has no joint '" + name + "'");
        }
        angles[static_cast<std::size_t>(g)] = a;
      }
      for (std::size_t g = 0; g < groups_.size(); ++g) {
        const int gi = static_cast<int>(g);
        if (gi == hip_[0] || gi == hip_[1]) continue;  // posture and swing placement
        roles[i][static_cast<std::size_t>(stance)].push_back({gi, angles[g]});
      }
    }
  }
  roles_ = std::move(roles);
  swing_hip_ = std::move(swing_hip);
  has_swing_hip_ = std::move(has_swing_hip);
}

double GaitController::state_duration(int state) const {
  const double scale = params_.posture.reference_cadence_steps_per_min / params_.cadence(speed_now_);
  return params_.states[static_cast<std::size_t>(state)].duration_s * scale;
}

Quaterniond GaitController::heading_rotation() const {
  return Quaterniond(Eigen::AngleAxisd(heading_, Vector3d::UnitZ()));
}

void GaitController::reset(const mjModel& m, const mjData& d) {
  // From standing the first step starts with the lift: a push-off from a foot beside the
  // other would only push the body back.
  stance_ = 0;
  state_ = 0;
  while (state_ + 1 < static_cast<int>(params_.states.size()) &&
         params_.states[static_cast<std::size_t>(state_)].swing_foot_down)
    ++state_;
  state_start_s_ = d.time;
  last_time_s_ = d.time;
  const sim::CenterOfMass com = sim::center_of_mass(m, d);
  const Quaterniond q_pelvis = quat_at(d.xquat + 4 * pelvis_);
  const Vector3d forward = q_pelvis * Vector3d::UnitX();
  heading_ = std::atan2(forward.y(), forward.x());
  speed_now_ = std::max(0.0, rotate(com.velocity_W.head<2>(), -heading_).x());
  strike_count_ = 0;
  stones_used_ = 0;
  last_strike_ = StrikeEvent{};
  planned_foot_W_ = vec_at(d.xpos + 3 * foot_[1]);
  planned_length_ = 0;
  rule_active_ = false;
}

void GaitController::advance(const mjData& d) {
  const double dt = d.time - last_time_s_;
  heading_ += command_.heading_rate_rad_s * dt;
  const double ramp = params_.posture.speed_ramp_m_s2 * dt;
  speed_now_ += std::clamp(command_.speed_m_s - speed_now_, -ramp, ramp);

  const GaitState& st = params_.states[static_cast<std::size_t>(state_)];
  const double in_state = d.time - state_start_s_;
  const double duration = state_duration(state_);
  if (!st.ends_at_strike) {
    if (in_state >= duration) {
      state_ = (state_ + 1) % static_cast<int>(params_.states.size());
      state_start_s_ = d.time;
    }
    return;
  }
  const int swing = 1 - stance_;
  const bool touched = in_state >= params_.placement.min_swing_fraction * duration && foot_touches_now_[swing];
  const bool timed_out = in_state >= params_.placement.max_swing_factor * duration;
  if (!touched && !timed_out) return;
  // The swing foot struck: it becomes the stance foot.
  StrikeEvent e;
  e.index = static_cast<int>(strike_count_);
  e.time_s = d.time;
  e.side = swing;
  e.foot_W = vec_at(d.xpos + 3 * foot_[swing]);
  e.other_W = vec_at(d.xpos + 3 * foot_[stance_]);
  const Vector2d delta = rotate((e.foot_W - e.other_W).head<2>(), -heading_);
  e.step_length_m = delta.x();
  e.step_width_m = std::abs(delta.y());
  e.planned_length_m = planned_length_;
  e.timed_out = !touched;
  last_strike_ = e;
  ++strike_count_;
  if (stones_used_ < command_.step_lengths_m.size()) ++stones_used_;
  stance_ = swing;
  state_ = 0;
  state_start_s_ = d.time;
}

void GaitController::support_polygons(const mjModel& m, const mjData& d) {
  sim::floor_contacts(m, d, floor_geom_, &contacts_);
  const int feet[4] = {foot_[0], foot_[1], toes_[0], toes_[1]};
  contact_support_polygon(contacts_, feet, 4, &points_, &hull_);
  controllers::tolerance_polygon(hull_, params_.placement.tolerance_fraction, &tolerance_);
}

void GaitController::plan_foot(const mjData& d, const sim::CenterOfMass& com) {
  const FootPlacementParams& fp = params_.placement;
  const int swing = 1 - stance_;
  const double sigma = swing == 0 ? 1.0 : -1.0;  // +1: the swing foot is the left one (+y)
  const double height = std::max(com.position_W.z(), 0.3);
  const double omega0 = std::sqrt(kGravity / height);
  const double step_time = 60.0 / params_.cadence(speed_now_);
  const double lip = 1.0 - std::tanh(omega0 * step_time / 2);
  const Vector2d c = rotate(com.position_W.head<2>(), -heading_);
  const Vector2d v = rotate(com.velocity_W.head<2>(), -heading_);
  const Vector2d s = rotate(vec_at(d.xpos + 3 * foot_[stance_]).head<2>(), -heading_);
  const double width = fp.step_width_fraction * hip_spacing_;

  double x = c.x() + fp.capture_gain * v.x() / omega0 - speed_now_ / omega0 * lip;
  double y = c.y() + fp.capture_gain * v.y() / omega0 + sigma * width / 2 * lip;
  if (stones_used_ < command_.step_lengths_m.size()) x = s.x() + command_.step_lengths_m[stones_used_];

  rule_active_ = false;
  if (fp.base_polygon_rule && hull_.size() >= 3 &&
      !inside_convex(tolerance_, com.position_W.head<2>())) {
    // Paper §4.3 in the heading frame: b_P the polygon's rear (or, moving back, front) edge.
    double rear = 1e9, front = -1e9, right = 1e9, left = -1e9, cx = 0;
    for (const Vector2d& p : hull_) {
      const Vector2d q = rotate(p, -heading_);
      rear = std::min(rear, q.x());
      front = std::max(front, q.x());
      right = std::min(right, q.y());
      left = std::max(left, q.y());
      cx += q.x();
    }
    cx /= static_cast<double>(hull_.size());
    const double reach_tol = params_.placement.tolerance_fraction * (front - rear);
    if (c.x() > cx + reach_tol) {
      const double min_x = s.x() + base_polygon_step(c.x() - rear, foot_length_);  // heel to heel
      if (min_x > x && stones_used_ >= command_.step_lengths_m.size()) {
        x = min_x;
        rule_active_ = true;
      }
    } else if (c.x() < cx - reach_tol) {
      const double max_x = s.x() - base_polygon_step(front - c.x(), foot_length_);
      if (max_x < x && stones_used_ >= command_.step_lengths_m.size()) {
        x = max_x;
        rule_active_ = true;
      }
    }
    // Frontal counterpart: the outer edge on the stance side, the foot width.
    const double outer = sigma > 0 ? right : left;
    const double lateral = sigma * (c.y() - outer);
    if (lateral > 0) {
      // Same rule across: the new polygon spans stance outer edge to new foot's outer edge.
      const double min_width = base_polygon_step(lateral, foot_width_);
      if (sigma * (y - s.y()) < min_width) {
        y = s.y() + sigma * min_width;
        rule_active_ = true;
      }
    }
  }
  const double min_width = fp.min_width_fraction * hip_spacing_;
  if (sigma * (y - s.y()) < min_width) y = s.y() + sigma * min_width;
  const Vector2d target = rotate(Vector2d(x, y), heading_);
  planned_foot_W_ = Vector3d(target.x(), target.y(), 0.0);
  planned_length_ = x - s.x();
}

void GaitController::set_targets(CharacterController& c, const mjData& d) {
  const GaitState& st = params_.states[static_cast<std::size_t>(state_)];
  const double reach_at = state_start_s_ + st.reach_fraction * state_duration(state_);
  for (const RoleTarget& r : roles_[static_cast<std::size_t>(state_)][static_cast<std::size_t>(stance_)])
    c.set_joint_angles(r.group, r.angles, reach_at);

  const Quaterniond q_heading = heading_rotation();
  const double tracking_at = d.time + params_.posture.world_tracking_time_s;
  // Stance hip: the pelvis to its world posture (paper §4.1).
  const double pitch = (params_.posture.pelvis_pitch_deg + params_.posture.pelvis_pitch_deg_per_m_s * speed_now_) * kDeg;
  const Quaterniond q_pelvis_goal = q_heading * Quaterniond(Eigen::AngleAxisd(pitch, Vector3d::UnitY()));
  const Quaterniond q_stance_thigh = quat_at(d.xquat + 4 * thigh_[stance_]);
  c.set_joint_target(hip_[stance_], q_pelvis_goal.conjugate() * q_stance_thigh, tracking_at);
  const Quaterniond q_pelvis = quat_at(d.xquat + 4 * pelvis_);
  const Vector3d w_pelvis = vec_at(d.cvel + 6 * pelvis_);  // world angular velocities
  if (foot_touches_now_[stance_]) {
    // The pelvis's world angular velocity goes to e/t (e its world orientation error); the
    // hip's relative velocity that gives it feeds the thigh's own rotation forward. Only
    // with the stance foot on the floor: a thigh in the air turns with the hip instead, and
    // feeding its rotation forward would spin it up.
    const Vector3d w_wanted = rotation_vector(q_pelvis_goal * q_pelvis.conjugate()) /
                              params_.posture.world_tracking_time_s;
    const Vector3d w_thigh = vec_at(d.cvel + 6 * thigh_[stance_]);
    c.set_velocity_once(hip_[stance_], q_stance_thigh.conjugate() * (w_thigh - w_wanted));
  }

  // Swing hip: the swing thigh in the heading frame.
  const int swing = 1 - stance_;
  const JointGroup& hip = groups_[static_cast<std::size_t>(hip_[swing])];
  Vector3d thigh_angles = Vector3d::Zero();
  bool have = false;
  if (st.foot_placement) {
    // Paper §4.2: the IK triangle hip - knee - ankle for the planned strike.
    const double sigma = swing == 0 ? 1.0 : -1.0;
    const Vector3d hip_W = vec_at(d.xpos + 3 * thigh_[swing]);
    Vector3d r = planned_foot_W_ + Vector3d(0, 0, ankle_height_) - hip_W;
    const Vector2d r_h = rotate(r.head<2>(), -heading_);
    r = Vector3d(r_h.x(), r_h.y(), r.z());
    const LegTriangle leg =
        solve_leg_triangle(l_thigh_, l_shank_, r, sigma, params_.placement.strike_knee_deg * kDeg);
    thigh_angles = Vector3d(leg.hip_flexion_rad, leg.hip_abduction_rad, 0.0);
    const double knee = leg.knee_flexion_rad;
    c.set_joint_angles(knee_[swing], Vector3d(knee, 0, 0), reach_at);
    have = true;
  } else if (has_swing_hip_[static_cast<std::size_t>(state_)]) {
    thigh_angles = swing_hip_[static_cast<std::size_t>(state_)];
    have = true;
  }
  if (!st.swing_foot_down && !foot_touches_now_[swing]) {
    // The swing foot level in the heading frame (toes up by a few degrees), whatever the
    // shank does: a foot that followed the shank back would scuff with its toes.
    const double toe_up = params_.placement.swing_toe_up_deg * kDeg;
    const int shank = groups_[static_cast<std::size_t>(knee_[swing])].body;
    const Quaterniond q_shank = quat_at(d.xquat + 4 * shank);
    const Quaterniond q_foot_goal = q_heading * Quaterniond(Eigen::AngleAxisd(-toe_up, Vector3d::UnitY()));
    const JointGroup& ankle = groups_[static_cast<std::size_t>(ankle_[swing])];
    c.set_joint_angles(ankle_[swing], angles_from_orientation(ankle, q_shank.conjugate() * q_foot_goal),
                       d.time + kSoleTracking_s);
  }
  if (!st.swing_foot_down) {
    // Foot clearance: the swing knee bends at least enough that the ankle stays `clearance`
    // above its standing height for the thigh where it is now (a leg swinging through the
    // vertical with its knee already straight would scuff the floor). The clearance goes to
    // zero over the state that ends at the strike.
    const double c0 = params_.placement.swing_clearance_m;
    const double phase = std::clamp((d.time - state_start_s_) / state_duration(state_), 0.0, 1.0);
    const double clearance = st.ends_at_strike ? c0 * (1 - phase) : c0;
    const Vector3d hip_W = vec_at(d.xpos + 3 * thigh_[swing]);
    const int shank = groups_[static_cast<std::size_t>(knee_[swing])].body;
    const Vector3d knee_W = vec_at(d.xpos + 3 * shank);
    const Vector2d thigh_h = rotate((knee_W - hip_W).head<2>(), -heading_);
    const double alpha = std::atan2(thigh_h.x(), hip_W.z() - knee_W.z());
    const double ratio = (knee_W.z() - ankle_height_ - clearance) / l_shank_;
    if (ratio < 1) {
      const double knee_min = alpha + std::acos(std::max(ratio, -1.0));
      const JointTarget& now = c.joints().target(knee_[swing]);
      const double knee_target = rotation_angle(now.orientation);
      if (knee_min > knee_target) c.set_joint_angles(knee_[swing], Vector3d(knee_min, 0, 0), d.time + kClearanceTracking_s);
    }
  }
  if (have) {
    const Quaterniond q_thigh_goal = q_heading * orientation_from_angles(hip, thigh_angles);
    c.set_joint_target(hip_[swing], q_pelvis.conjugate() * q_thigh_goal, reach_at);
    // Same in the world frame: the thigh's world velocity to e/t_go, the pelvis's fed forward.
    const Quaterniond q_thigh = quat_at(d.xquat + 4 * thigh_[swing]);
    const double t_go = std::max(reach_at - d.time, params_.posture.world_tracking_time_s);
    const Vector3d w_wanted = rotation_vector(q_thigh_goal * q_thigh.conjugate()) / t_go;
    c.set_velocity_once(hip_[swing], q_thigh.conjugate() * (w_wanted - w_pelvis));
  } else {
    c.set_joint_angles(hip_[swing], Vector3d::Zero(), reach_at);
  }
}

void GaitController::limit_ankles(CharacterController& c, const mjModel& m, const mjData& d) {
  const GaitState& st = params_.states[static_cast<std::size_t>(state_)];
  const double phase = std::clamp((d.time - state_start_s_) / state_duration(state_), 0.0, 1.0);
  const double margin = params_.posture.cop_margin;
  for (int s = 0; s < 2; ++s) {
    const bool stance = s == stance_;
    // Every foot on the floor (a swing foot too, until it has left it): a loaded foot whose
    // ankle followed an angle target would push the body around with it.
    const Eigen::Vector2d& cop = stance ? st.stance_cop : st.trailing_cop;
    const double cop_fraction = cop[0] + phase * (cop[1] - cop[0]);
    // The foot's load in the last step, capped at 1.5 body weights: a torque that grows with
    // the load it creates would launch the body (positive feedback through the push-off).
    const double load = std::clamp(c.last_report().weld[static_cast<std::size_t>(s)].ground_force_W.z(), 0.0,
                                   1.5 * weight_);
    limit_ankle_to_contacts(c, m, d, groups_[static_cast<std::size_t>(ankle_[s])], foot_[s], toes_[s], contacts_, load,
                            margin, params_.posture.cop_torque ? cop_fraction : -1.0);
  }
}

void GaitController::apply_compliance(CharacterController& c) const {
  const LegComplianceParams& k = params_.compliance;
  const double mgl = weight_ * (l_thigh_ + l_shank_);  // N m per rad at k = 1
  const auto spring = [&](int group, double stiffness) {
    if (stiffness > 0) c.set_compliant_once(group, stiffness * mgl, stiffness * mgl * k.damping_time_s);
  };
  // Only with the foot on the floor: a leg in the air has the small inertia of its own
  // segments, and a spring stiff enough to carry the body would be unstable on it.
  if (foot_touches_now_[stance_]) {
    spring(knee_[stance_], k.stance_knee);
    spring(ankle_[stance_], k.stance_ankle);
  }
  const int swing = 1 - stance_;
  if (foot_touches_now_[swing]) {
    spring(hip_[swing], k.trailing_leg);
    spring(knee_[swing], k.trailing_leg);
    spring(ankle_[swing], k.trailing_leg);
  }
}

void GaitController::drive(CharacterController& c, const mjModel& m, const mjData& d) {
  for (int s = 0; s < 2; ++s) foot_touches_now_[s] = sim::foot_touches_floor(m, d, floor_geom_, foot_[s], toes_[s]);
  if (d.time > last_time_s_ + 1e-12) {
    advance(d);
    last_time_s_ = d.time;
  }
  support_polygons(m, d);
  const sim::CenterOfMass com = sim::center_of_mass(m, d);
  plan_foot(d, com);
  set_targets(c, d);
  limit_ankles(c, m, d);
  apply_compliance(c);
  const int swing = 1 - stance_;
  c.set_stance(stance_, true);
  c.set_stance(swing, params_.states[static_cast<std::size_t>(state_)].swing_foot_down);
}

}  // namespace biodyn::controllers
