// The velocity-based walker (velocity_walker.h).
#include "biodyn/controllers/velocity_walker.h"

#include <algorithm>
#include <cmath>

#include "biodyn/controllers/ankle_window.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/queries.h"
#include "biodyn/sim/units.h"

namespace biodyn::controllers {
namespace {

using Eigen::Quaterniond;
using Eigen::Vector2d;
using Eigen::Vector3d;

// s, how soon the swing foot's level sole and the clearance knee are due: short, as they
// follow the leg from step to step (the sole within a few degrees, the knee before the foot
// reaches the floor).
constexpr double kSoleTracking_s = 0.05;
constexpr double kClearanceTracking_s = 0.03;

}  // namespace

void GaitCommand::validate() const {
  if (!(speed_m_s >= 0 && speed_m_s <= 3))
    throw sim::InvalidArgument("gait command: speed must be in [0, 3] m/s, got " +
                               std::to_string(speed_m_s));
  if (!(std::abs(heading_rate_rad_s) <= 3))
    throw sim::InvalidArgument("gait command: heading rate must be within +-3 rad/s, got " +
                               std::to_string(heading_rate_rad_s));
  for (std::size_t i = 0; i < step_lengths_m.size(); ++i) {
    if (!(step_lengths_m[i] >= -0.5 && step_lengths_m[i] <= 2.0))
      throw sim::InvalidArgument("gait command: step length " + std::to_string(i + 1) +
                                 " must be in [-0.5, 2] m, got " +
                                 std::to_string(step_lengths_m[i]));
  }
}

VelocityWalker::VelocityWalker(const mjModel& m, const models::Rig& rig,
                               VelocityWalkerParams params)
    : params_(std::move(params)), rig_(&rig) {
  params_.validate();
  rig.require_legs("velocity walker");
  ankle_height_ = -rig.leg(models::kLeft).sole.z;
  gravity_m_s2_ = -m.opt.gravity[2];
  weight_ = rig.mass_kg() * gravity_m_s2_;
  compile_roles();
  contacts_.reserve(64);
}

void VelocityWalker::set_params(const VelocityWalkerParams& params) {
  params.validate();
  const VelocityWalkerParams old = params_;
  params_ = params;
  try {
    compile_roles();
  } catch (...) {
    params_ = old;
    compile_roles();
    throw;
  }
  if (state_.phase >= static_cast<int>(params_.phases.size())) state_.phase = 0;
}

void VelocityWalker::set_command(const GaitCommand& command) {
  command.validate();
  command_ = command;
  state_.stones_used = 0;
}

void VelocityWalker::compile_roles() {
  const std::size_t n = params_.phases.size();
  std::vector<std::array<std::vector<RoleTarget>, 2>> roles(n);
  std::vector<Vector3d> swing_hip(n, Vector3d::Zero());
  std::vector<bool> has_swing_hip(n, false);
  for (std::size_t i = 0; i < n; ++i) {
    const VelocityWalkerPhase& st = params_.phases[i];
    for (int stance = 0; stance < 2; ++stance) {
      const int swing = 1 - stance;
      std::vector<Vector3d> angles(rig_->groups().size(), Vector3d::Zero());
      for (const auto& [role, a] : st.targets_rad) {
        if (role == "swing_hip") {
          swing_hip[i] = a;
          has_swing_hip[i] = true;
          continue;
        }
        std::string name = role;
        if (role.rfind("stance_", 0) == 0)
          name = role.substr(7) + models::kSideSuffix[stance];
        else if (role.rfind("swing_", 0) == 0)
          name = role.substr(6) + models::kSideSuffix[swing];
        const int g = rig_->group(name);
        if (g < 0) {
          throw sim::InvalidArgument("gait.states[" + std::to_string(i) + "] (" + st.name +
                                     ").targets_deg." + role + ": the model has no joint '" + name +
                                     "'");
        }
        angles[static_cast<std::size_t>(g)] = a;
      }
      for (std::size_t g = 0; g < rig_->groups().size(); ++g) {
        const int gi = static_cast<int>(g);
        if (gi == rig_->leg(models::kLeft).hip || gi == rig_->leg(models::kRight).hip)
          continue;  // posture and swing placement
        roles[i][static_cast<std::size_t>(stance)].push_back({gi, angles[g]});
      }
    }
  }
  roles_ = std::move(roles);
  swing_hip_ = std::move(swing_hip);
  has_swing_hip_ = std::move(has_swing_hip);
}

double VelocityWalker::phase_duration(int phase) const {
  const double scale =
      params_.posture.reference_cadence_steps_per_min / params_.cadence(state_.speed_now_m_s);
  return params_.phases[static_cast<std::size_t>(phase)].duration_s * scale;
}

void VelocityWalker::reset(const mjModel& m, const mjData& d) {
  VelocityWalkerState& st = state_;
  st = VelocityWalkerState{};
  // From standing the first step starts with the lift: a push-off from a foot beside the
  // other would only push the body back.
  while (st.phase + 1 < static_cast<int>(params_.phases.size()) &&
         params_.phases[static_cast<std::size_t>(st.phase)].swing_foot_down)
    ++st.phase;
  st.phase_start_s = d.time;
  st.last_time_s = d.time;
  const sim::CenterOfMass com = sim::center_of_mass(m, d);
  const Vector3d forward = sim::quat_at(d.xquat + 4 * rig_->pelvis()) * Vector3d::UnitX();
  st.heading.reset(std::atan2(forward.y(), forward.x()), d.time);
  st.speed_now_m_s = std::max(0.0, st.heading.to_heading(Vector2d(com.velocity_W.head<2>())).x());
  st.planned_foot_W = sim::vec3_at(d.xpos + 3 * rig_->leg(models::kRight).foot);
}

void VelocityWalker::advance(const mjData& d) {
  VelocityWalkerState& st = state_;
  const double dt = d.time - st.last_time_s;
  st.heading.advance(d.time, command_.heading_rate_rad_s);
  const double ramp = params_.posture.speed_ramp_m_s2 * dt;
  st.speed_now_m_s += std::clamp(command_.speed_m_s - st.speed_now_m_s, -ramp, ramp);

  const VelocityWalkerPhase& ph = params_.phases[static_cast<std::size_t>(st.phase)];
  const double in_phase = d.time - st.phase_start_s;
  const double duration = phase_duration(st.phase);
  const int swing = 1 - st.stance;
  const bool struck = st.strike.update(st.foot_touches[static_cast<std::size_t>(swing)]);
  if (!ph.ends_at_strike) {
    if (in_phase >= duration) {
      st.phase = (st.phase + 1) % static_cast<int>(params_.phases.size());
      st.phase_start_s = d.time;
    }
    return;
  }
  const bool touched = in_phase >= params_.placement.min_swing_fraction * duration && struck;
  const bool timed_out = in_phase >= params_.placement.max_swing_factor * duration;
  if (!touched && !timed_out) return;
  // The swing foot struck: it becomes the stance foot.
  StrikeEvent e;
  e.index = static_cast<int>(st.strike_count);
  e.time_s = d.time;
  e.side = swing;
  e.foot_W = sim::vec3_at(d.xpos + 3 * rig_->leg(swing).foot);
  e.other_W = sim::vec3_at(d.xpos + 3 * rig_->leg(st.stance).foot);
  const Vector2d delta = st.heading.to_heading(Vector2d((e.foot_W - e.other_W).head<2>()));
  e.step_length_m = delta.x();
  e.step_width_m = std::abs(delta.y());
  e.planned_length_m = st.planned_length_m;
  e.timed_out = !touched;
  st.last_strike = e;
  ++st.strike_count;
  if (st.stones_used < command_.step_lengths_m.size()) ++st.stones_used;
  st.stance = swing;
  st.phase = 0;
  st.strike.start_swing();
  st.phase_start_s = d.time;
}

void VelocityWalker::plan_foot(const mjData& d, const sim::CenterOfMass& com) {
  const FootPlacementParams& fp = params_.placement;
  VelocityWalkerState& st = state_;
  const int swing = 1 - st.stance;
  const double sigma = swing == 0 ? 1.0 : -1.0;  // +1: the swing foot is the left one (+y)
  const double height = std::max(com.position_W.z(), 0.3);
  const double omega0 = std::sqrt(gravity_m_s2_ / height);
  const double step_time = 60.0 / params_.cadence(st.speed_now_m_s);
  const double lip = 1.0 - std::tanh(omega0 * step_time / 2);
  const Vector2d c = st.heading.to_heading(Vector2d(com.position_W.head<2>()));
  const Vector2d v = st.heading.to_heading(Vector2d(com.velocity_W.head<2>()));
  const int stance_foot = rig_->leg(st.stance).foot;
  const Vector2d ankle_W(d.xpos[3 * stance_foot], d.xpos[3 * stance_foot + 1]);
  const Vector2d s = st.heading.to_heading(ankle_W);
  const double width = fp.step_width_fraction * rig_->hip_spacing_m();

  double x = c.x() + fp.capture_gain * v.x() / omega0 - st.speed_now_m_s / omega0 * lip;
  double y = c.y() + fp.capture_gain * v.y() / omega0 + sigma * width / 2 * lip;
  const bool stones = st.stones_used < command_.step_lengths_m.size();
  if (stones) x = s.x() + command_.step_lengths_m[st.stones_used];

  // Paper §4.3 (gait core): at least as far as the base-polygon rule asks, ahead, behind or aside.
  st.rule_active = false;
  if (fp.base_polygon_rule) {
    const models::Sole& sole = rig_->leg(models::kLeft).sole;
    const Vector3d v_H(v.x(), v.y(), 0.0);
    const BasePolygonStep rule = base_polygon_rule(
        polygons_.support(), polygons_.tolerance(), fp.tolerance_fraction, com.position_W, v_H,
        ankle_W, st.heading, swing, sole.length_m(), sole.width_m());
    if (!std::isnan(rule.length_m) && !stones) {
      const double bound = s.x() + rule.length_m;
      if (rule.length_m > 0 ? bound > x : bound < x) {
        x = bound;
        st.rule_active = true;
      }
    }
    if (!std::isnan(rule.width_m) && sigma * (y - s.y()) < rule.width_m) {
      y = s.y() + sigma * rule.width_m;
      st.rule_active = true;
    }
  }
  const double min_width = fp.min_width_fraction * rig_->hip_spacing_m();
  if (sigma * (y - s.y()) < min_width) y = s.y() + sigma * min_width;
  const Vector2d target = st.heading.to_world(Vector2d(x, y));
  st.planned_foot_W = Vector3d(target.x(), target.y(), 0.0);
  st.planned_length_m = x - s.x();
}

void VelocityWalker::set_targets(ControlFrame* f, const mjData& d) {
  const VelocityWalkerState& st = state_;
  const VelocityWalkerPhase& ph = params_.phases[static_cast<std::size_t>(st.phase)];
  const double reach_at = st.phase_start_s + ph.reach_fraction * phase_duration(st.phase);
  for (const RoleTarget& r :
       roles_[static_cast<std::size_t>(st.phase)][static_cast<std::size_t>(st.stance)])
    f->set_joint_angles(r.group, r.angles, reach_at);

  const Quaterniond q_heading = st.heading.rotation();
  const double tracking_at = d.time + params_.posture.world_tracking_time_s;
  // Stance hip: the pelvis to its world posture (paper §4.1).
  const double pitch = (params_.posture.pelvis_pitch_deg +
                        params_.posture.pelvis_pitch_deg_per_m_s * st.speed_now_m_s) *
                       kRadPerDeg;
  const Quaterniond q_pelvis_goal =
      q_heading * Quaterniond(Eigen::AngleAxisd(pitch, Vector3d::UnitY()));
  const models::RigLeg& stance_leg = rig_->leg(st.stance);
  const Quaterniond q_stance_thigh = sim::quat_at(d.xquat + 4 * stance_leg.thigh);
  f->set_target(stance_leg.hip, q_pelvis_goal.conjugate() * q_stance_thigh, tracking_at);
  const Quaterniond q_pelvis = sim::quat_at(d.xquat + 4 * rig_->pelvis());
  const Vector3d w_pelvis = sim::vec3_at(d.cvel + 6 * rig_->pelvis());  // world angular velocities
  if (st.foot_touches[static_cast<std::size_t>(st.stance)]) {
    // The pelvis's world angular velocity goes to e/t (e its world orientation error); the
    // hip's relative velocity that gives it feeds the thigh's own rotation forward. Only
    // with the stance foot on the floor: a thigh in the air turns with the hip instead, and
    // feeding its rotation forward would spin it up.
    const Vector3d w_wanted = rotation_vector(q_pelvis_goal * q_pelvis.conjugate()) /
                              params_.posture.world_tracking_time_s;
    const Vector3d w_thigh = sim::vec3_at(d.cvel + 6 * stance_leg.thigh);
    f->set_velocity(stance_leg.hip, q_stance_thigh.conjugate() * (w_thigh - w_wanted));
  }

  // Swing hip: the swing thigh in the heading frame.
  const int swing = 1 - st.stance;
  const models::RigLeg& swing_leg = rig_->leg(swing);
  const JointGroup& hip = rig_->groups()[static_cast<std::size_t>(swing_leg.hip)];
  Vector3d thigh_angles = Vector3d::Zero();
  bool have = false;
  if (ph.foot_placement) {
    // Paper §4.2: the IK triangle hip - knee - ankle for the planned strike.
    const double sigma = swing == 0 ? 1.0 : -1.0;
    const Vector3d hip_W = sim::vec3_at(d.xpos + 3 * swing_leg.thigh);
    Vector3d r = st.planned_foot_W + Vector3d(0, 0, ankle_height_) - hip_W;
    const Vector2d r_h = st.heading.to_heading(Vector2d(r.head<2>()));
    r = Vector3d(r_h.x(), r_h.y(), r.z());
    const LegTriangle leg =
        solve_leg_triangle(swing_leg.thigh_length_m, swing_leg.shank_length_m, r, sigma,
                           params_.placement.strike_knee_deg * kRadPerDeg);
    thigh_angles = Vector3d(leg.hip_flexion_rad, leg.hip_abduction_rad, 0.0);
    f->set_joint_angles(swing_leg.knee, Vector3d(leg.knee_flexion_rad, 0, 0), reach_at);
    have = true;
  } else if (has_swing_hip_[static_cast<std::size_t>(st.phase)]) {
    thigh_angles = swing_hip_[static_cast<std::size_t>(st.phase)];
    have = true;
  }
  set_swing_foot(f, d);
  if (have) {
    const Quaterniond q_thigh_goal = q_heading * orientation_from_angles(hip, thigh_angles);
    f->set_target(swing_leg.hip, q_pelvis.conjugate() * q_thigh_goal, reach_at);
    // Same in the world frame: the thigh's world velocity to e/t_go, the pelvis's fed forward.
    const Quaterniond q_thigh = sim::quat_at(d.xquat + 4 * swing_leg.thigh);
    const double t_go = std::max(reach_at - d.time, params_.posture.world_tracking_time_s);
    const Vector3d w_wanted = rotation_vector(q_thigh_goal * q_thigh.conjugate()) / t_go;
    f->set_velocity(swing_leg.hip, q_thigh.conjugate() * (w_wanted - w_pelvis));
  } else {
    f->set_joint_angles(swing_leg.hip, Vector3d::Zero(), reach_at);
  }
}

void VelocityWalker::set_swing_foot(ControlFrame* f, const mjData& d) {
  const VelocityWalkerState& st = state_;
  const VelocityWalkerPhase& ph = params_.phases[static_cast<std::size_t>(st.phase)];
  const int swing = 1 - st.stance;
  const models::RigLeg& leg = rig_->leg(swing);
  if (!ph.swing_foot_down && !st.foot_touches[static_cast<std::size_t>(swing)]) {
    // The swing sole level in the heading frame, toes up (gait core, as the torque walker's).
    const double dorsiflexion =
        level_sole_dorsiflexion(st.heading, sim::quat_at(d.xquat + 4 * leg.shank), 0.0,
                                params_.placement.swing_toe_up_deg * kRadPerDeg);
    f->set_joint_angles(leg.ankle, Vector3d(dorsiflexion, 0, 0), d.time + kSoleTracking_s);
  }
  if (!ph.swing_foot_down) {
    // Foot clearance: the swing knee bends at least enough that the ankle stays `clearance`
    // above its standing height for the thigh where it is now (a leg swinging through the
    // vertical with its knee already straight would scuff the floor). The clearance goes to
    // zero over the phase that ends at the strike.
    const double c0 = params_.placement.swing_clearance_m;
    const double phase =
        std::clamp((d.time - st.phase_start_s) / phase_duration(st.phase), 0.0, 1.0);
    const double clearance = ph.ends_at_strike ? c0 * (1 - phase) : c0;
    const Vector3d hip_W = sim::vec3_at(d.xpos + 3 * leg.thigh);
    const Vector3d knee_W = sim::vec3_at(d.xpos + 3 * leg.shank);
    const Vector2d thigh_h = st.heading.to_heading(Vector2d((knee_W - hip_W).head<2>()));
    const double alpha = std::atan2(thigh_h.x(), hip_W.z() - knee_W.z());
    const double ratio = (knee_W.z() - ankle_height_ - clearance) / leg.shank_length_m;
    if (ratio < 1) {
      const double knee_min = alpha + std::acos(std::max(ratio, -1.0));
      const double knee_target = rotation_angle(f->target(leg.knee).orientation);
      if (knee_min > knee_target)
        f->set_joint_angles(leg.knee, Vector3d(knee_min, 0, 0), d.time + kClearanceTracking_s);
    }
  }
}

void VelocityWalker::limit_ankles(ControlFrame* f, const ControlInput& in) {
  const VelocityWalkerState& st = state_;
  const VelocityWalkerPhase& ph = params_.phases[static_cast<std::size_t>(st.phase)];
  const double phase =
      std::clamp((in.d.time - st.phase_start_s) / phase_duration(st.phase), 0.0, 1.0);
  const double margin = params_.posture.cop_margin;
  sim::floor_contacts(in.m, in.d, rig_->floor_geom(), &contacts_);
  for (int s = 0; s < 2; ++s) {
    const bool stance = s == st.stance;
    // Every foot on the floor (a swing foot too, until it has left it): a loaded foot whose
    // ankle followed an angle target would push the body around with it.
    const Eigen::Vector2d& cop = stance ? ph.stance_cop : ph.trailing_cop;
    const double cop_fraction = cop[0] + phase * (cop[1] - cop[0]);
    // The foot's load in the last step, capped at 1.5 body weights: a torque that grows with
    // the load it creates would launch the body (positive feedback through the push-off).
    const double load = std::min(foot_load_N(in.last_report, s), 1.5 * weight_);
    const models::RigLeg& leg = rig_->leg(s);
    limit_ankle_to_contacts(f, in.m, in.d, rig_->groups()[static_cast<std::size_t>(leg.ankle)],
                            leg.foot, leg.toes, contacts_, load, margin,
                            params_.posture.cop_torque ? cop_fraction : -1.0);
  }
}

void VelocityWalker::apply_compliance(ControlFrame* f) const {
  const LegComplianceParams& k = params_.compliance;
  const models::RigLeg& left = rig_->leg(models::kLeft);
  const double mgl = weight_ * (left.thigh_length_m + left.shank_length_m);  // N m per rad at k = 1
  const auto spring = [&](int group, double stiffness) {
    if (stiffness > 0) f->set_spring(group, stiffness * mgl, stiffness * mgl * k.damping_time_s);
  };
  // Only with the foot on the floor: a leg in the air has the small inertia of its own
  // segments, and a spring stiff enough to carry the body would be unstable on it.
  const VelocityWalkerState& st = state_;
  const models::RigLeg& stance = rig_->leg(st.stance);
  if (st.foot_touches[static_cast<std::size_t>(st.stance)]) {
    spring(stance.knee, k.stance_knee);
    spring(stance.ankle, k.stance_ankle);
  }
  const int swing = 1 - st.stance;
  const models::RigLeg& trailing = rig_->leg(swing);
  if (st.foot_touches[static_cast<std::size_t>(swing)]) {
    spring(trailing.hip, k.trailing_leg);
    spring(trailing.knee, k.trailing_leg);
    spring(trailing.ankle, k.trailing_leg);
  }
}

void VelocityWalker::drive(const ControlInput& in, ControlFrame* frame) {
  const mjModel& m = in.m;
  const mjData& d = in.d;
  for (int s = 0; s < 2; ++s)
    state_.foot_touches[static_cast<std::size_t>(s)] = foot_touches_floor(m, d, *rig_, s);
  if (d.time > state_.last_time_s + 1e-12) {  // once per time: a redone step advances nothing
    advance(d);
    state_.last_time_s = d.time;
  }
  polygons_.update(m, d, *rig_, params_.placement.tolerance_fraction);
  const sim::CenterOfMass com = sim::center_of_mass(m, d);
  plan_foot(d, com);
  set_targets(frame, d);
  limit_ankles(frame, in);
  apply_compliance(frame);
  const int swing = 1 - state_.stance;
  frame->set_stance(state_.stance, true);
  frame->set_stance(swing, params_.phases[static_cast<std::size_t>(state_.phase)].swing_foot_down);
}

}  // namespace biodyn::controllers
