#include "biodyn/scenarios/walk.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <sstream>

#include "biodyn/controllers/controller_params.h"
#include "biodyn/controllers/foot_contact.h"
#include "biodyn/controllers/poses.h"
#include "biodyn/controllers/control_pipeline.h"
#include "biodyn/controllers/torque_walker.h"
#include "biodyn/models/rig.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/queries.h"
#include "fall_watch.h"

namespace biodyn::scenarios {
namespace {

using controllers::JointGroup;
using Eigen::Vector2d;
using Eigen::Vector3d;

constexpr double kRadToDeg = 180.0 / M_PI;
// references.md: upright while walking = pelvis >= 0.7 x nominal height.
constexpr double kFallenPelvisFraction = 0.7;
// A foot is flat with at least this many floor contact points on its (hind)foot body.
constexpr int kFlatFootContacts = 3;
// Push survival: the stride speed back within this fraction of the speed before, by stride 4.
constexpr double kRecoveredSpeedFraction = 0.10;
constexpr int kRecoveryStrides = 4;
// A push run that has not been judged this long after the push ended stops (cannot happen
// with a walking character: 4 strides take about 4 s).
constexpr double kPushJudgeCap_s = 20.0;
// Standing after a stop: the CoM's horizontal speed below this.
constexpr double kStandingSpeed_m_s = 0.05;
// Strides to find the push onset in before giving up (the walker stopped striking).
constexpr double kMaxSettle_s = 120.0;

void fail(const std::string& field, const std::string& rule, double v) {
  std::ostringstream s;
  s << field << ": " << rule << ", got " << v;
  throw sim::InvalidArgument(s.str());
}

Vector2d com_xy(const mjModel& m, const mjData& d) { return sim::center_of_mass(m, d).position_W.head<2>(); }

// The body a push goes through: "trunk" is the rig's trunk body (thorax, or the gait model's
// trunk), any other name that body.
int push_body_id(const models::Rig& rig, const std::string& body) {
  const int id = body == "trunk" && rig.trunk_body() >= 0 ? rig.trunk_body() : rig.body(body);
  if (id < 0) throw sim::InvalidArgument("push body: no body named '" + body + "'");
  return id;
}

// Per-angle [min, max] of the legs and the lumbar joint.
struct AngleRanges {
  struct Entry {
    std::string name;
    int group = -1, component = 0;
    double lo = 1e9, hi = -1e9;
  };
  std::vector<Entry> entries;

  explicit AngleRanges(const std::vector<JointGroup>& groups) {
    for (std::size_t g = 0; g < groups.size(); ++g) {
      const std::string& n = groups[g].name;
      const bool wanted = n.rfind("hip", 0) == 0 || n.rfind("knee", 0) == 0 || n.rfind("ankle", 0) == 0 ||
                          n.rfind("toe", 0) == 0 || n == "lumbar";
      if (!wanted) continue;
      for (int k = 0; k < groups[g].dof_count; ++k) {
        static const char* const kBall[3] = {"_flexion", "_abduction", "_rotation"};
        Entry e;
        e.name = groups[g].ball ? n + kBall[k] : groups[g].dof_names[static_cast<std::size_t>(k)];
        e.group = static_cast<int>(g);
        e.component = k;
        entries.push_back(e);
      }
    }
  }
  void sample(const mjModel& m, const mjData& d, const std::vector<JointGroup>& groups) {
    for (Entry& e : entries) {
      const JointGroup& g = groups[static_cast<std::size_t>(e.group)];
      double a;
      if (g.ball) {
        a = controllers::angles_from_orientation(g, sim::relative_orientation(m, d, g.body))[e.component];
      } else {
        a = d.qpos[m.jnt_qposadr[m.dof_jntid[g.dof_begin + e.component]]];
      }
      e.lo = std::min(e.lo, a);
      e.hi = std::max(e.hi, a);
    }
  }
};

// One foot's stance, for slip and heel-strike read-outs.
struct FootWatch {
  int foot = -1, toes = -1;
  models::Sole sole;
  bool touching = false;  // foot or toes on the floor
  bool flat = false;      // flat in this stance at least once
  Vector2d flat_at = Vector2d::Zero();
  double slip = 0;        // this stance
  double air_s = 0;       // time off the floor before the current touch
};

}  // namespace

void WalkRunParams::validate() const {
  if (!(duration_s > 0) || !std::isfinite(duration_s) || duration_s > 3600)
    fail("duration", "must be in (0, 3600] s", duration_s);
  if (!(speed_m_s >= 0.3 && speed_m_s <= 2.0)) fail("speed", "must be in [0.3, 2] m/s", speed_m_s);
  if (!(std::abs(heading_rate_deg_s) <= 90)) fail("heading-rate", "must be within +-90 deg/s", heading_rate_deg_s);
  if (reaction_time_s != 0 && !(reaction_time_s >= 0.001 && reaction_time_s <= 2.0))
    fail("reaction-time", "must be in [0.001, 2] s", reaction_time_s);
  if (push) {
    const WalkPush& p = *push;
    if (!(p.force_N >= 0) || !std::isfinite(p.force_N)) fail("push force", "must be >= 0 N", p.force_N);
    if (!(p.duration_s > 0) || !(p.duration_s <= 10)) fail("push duration", "must be in (0, 10] s", p.duration_s);
    if (!std::isfinite(p.direction_deg)) fail("push direction", "must be finite", p.direction_deg);
    if (!(p.onset_phase >= 0 && p.onset_phase < 1)) fail("push onset-phase", "must be in [0, 1)", p.onset_phase);
    if (!(p.settle_strides >= 1 && p.settle_strides <= 100))
      fail("push settle strides", "must be in [1, 100]", p.settle_strides);
    if (!(p.watch_s >= 0 && p.watch_s <= 60)) fail("push watch", "must be in [0, 60] s", p.watch_s);
  }
  if (!steps_m.empty()) {
    if (push) throw sim::InvalidArgument("steps: stepping stones and a push cannot be combined in one run");
    if (steps_m.size() > 1000) fail("steps", "at most 1000 step lengths", static_cast<double>(steps_m.size()));
    for (std::size_t i = 0; i < steps_m.size(); ++i)
      if (!(steps_m[i] >= 0 && steps_m[i] <= 1.5)) fail("steps[" + std::to_string(i + 1) + "]", "must be in [0, 1.5] m", steps_m[i]);
    if (!(steps_start_s >= 0 && steps_start_s < duration_s))
      fail("steps start", "must be in [0, duration) s", steps_start_s);
  }
  if (stop_at_s >= 0 || !std::isfinite(stop_at_s)) {
    if (push) throw sim::InvalidArgument("stop: stopping and a push cannot be combined in one run");
    if (!(stop_at_s >= 0 && stop_at_s < duration_s)) fail("stop-at", "must be in [0, duration) s", stop_at_s);
  }
}

WalkRunResult run_walk(sim::Simulation* sim, const WalkRunParams& params,
                       const std::function<void(double)>& progress) {
  params.validate();
  const mjModel& m = sim->model();
  mjData& d = sim->data();
  const models::Rig rig(m);
  const std::vector<JointGroup>& groups = rig.groups();
  controllers::ControllerParams cp = controllers::default_params(m, groups);
  if (!params.controller_json.empty()) {
    controllers::apply_params_file_json(params.controller_json, params.controller_source, groups,
                                        m.opt.timestep, &cp);
  }
  if (params.reaction_time_s > 0) {
    for (controllers::JointParams& j : cp.joints) j.reaction_time_s = params.reaction_time_s;
  }
  controllers::TorqueWalkerParams gp;
  if (!params.gait_json.empty()) controllers::apply_torque_walker_json(params.gait_json, params.gait_source, &gp);

  sim->reset();
  controllers::ControlPipelineConfig config;
  config.weld.mode = params.weld;
  controllers::ControlPipeline ctrl(sim, rig, cp, config);
  const controllers::Pose stand_pose = controllers::pose_scenario("stand", groups, 0)[0];
  ctrl.reset_in_pose(stand_pose);
  controllers::TorqueWalker gait(rig, gp);
  gait.reset(d);
  gait.set_heading_rate(params.heading_rate_deg_s / kRadToDeg);
  gait.set_speed(params.speed_m_s);
  ctrl.set_driver(&gait);

  WalkRunResult r;
  r.weld = controllers::to_string(params.weld);
  r.speed_command_m_s = params.speed_m_s;
  r.heading_rate_deg_s = params.heading_rate_deg_s;
  r.reaction_time_s = cp.joints.empty() ? 0 : cp.joints.front().reaction_time_s;
  for (const controllers::JointParams& j : cp.joints)
    if (j.reaction_time_s != r.reaction_time_s) r.reaction_time_s = -1;

  const FallWatch fall(d, rig, kFallenPelvisFraction);
  const int pelvis = rig.pelvis();
  const double body_mass = rig.mass_kg();
  FootWatch feet[2];
  for (int s = 0; s < 2; ++s) {
    feet[s].foot = rig.leg(s).foot;
    feet[s].toes = rig.leg(s).toes;
    feet[s].sole = rig.leg(s).sole;
  }
  int knee_dof[2];
  for (int s = 0; s < 2; ++s) knee_dof[s] = groups[static_cast<std::size_t>(rig.leg(s).knee)].dof_begin;
  AngleRanges ranges(groups);

  const int push_body = params.push ? push_body_id(rig, params.push->body) : -1;

  const double dt = m.opt.timestep;
  const Vector3d start_heading(std::cos(gait.heading_rad()), std::sin(gait.heading_rad()), 0);
  const Vector2d com_start = com_xy(m, d);
  Vector2d com_last_strike = com_start;
  std::vector<double> left_strike_times;
  std::vector<Vector2d> left_strike_com;
  int strikes_seen = 0;
  double steady_first_t = -1, steady_last_t = 0, steady_path = 0;
  int steady_strikes = 0;
  double step_length_sum = 0;
  int swing_count = 0;
  double knee_peak_sum = 0, knee_peak_now = 0;
  int heel_strikes = 0, touchdowns = 0;
  double slip_sum = 0;
  int stances = 0;
  bool push_scheduled = false;
  bool steps_planned = false;
  bool feet_down[2] = {true, true};  // on the floor: touching it or welded to it (glue)
  SteppingStonesResult stones;
  stones.targets_m = params.steps_m;
  WalkPushOutcome outcome;
  if (params.push) {
    outcome.force_N = params.push->force_N;
    outcome.duration_s = params.push->duration_s;
    outcome.direction_deg = params.push->direction_deg;
    outcome.body = mj_id2name(&m, mjOBJ_BODY, push_body);
    outcome.impulse_N_s = outcome.force_N * outcome.duration_s;
    outcome.delta_v_m_s = outcome.impulse_N_s / body_mass;
  }
  const auto wall_start = std::chrono::steady_clock::now();
  if (params.trace) {
    *params.trace << "time_s,com_x,com_y,com_z,com_vx,com_vy,pelvis_z,heading_deg,stance,state,strikes,base_polygon_rule,"
                     "contacts_l,contacts_r,weld_l,weld_r,knee_l_deg,knee_r_deg,max_torque_ratio,push_fx,push_fy\n";
  }
  const int max_steps = static_cast<int>(std::lround(
      (params.push ? kMaxSettle_s + params.push->duration_s + params.push->watch_s + kPushJudgeCap_s
                   : params.duration_s) / dt));
  for (int step = 0; step < max_steps; ++step) {
    const controllers::StepReport rep = ctrl.step();
    ++r.sim_steps;
    r.warnings += rep.status.new_warnings;
    r.max_torque_ratio = std::max(r.max_torque_ratio, rep.joints.max_torque_ratio);
    if (rep.weld_tension) ++r.weld_tension_steps;
    r.weld_redone_steps += rep.redone > 0 ? 1 : 0;
    for (int s = 0; s < 2; ++s)
      r.max_weld_force_N = std::max(r.max_weld_force_N, rep.weld[static_cast<std::size_t>(s)].force_W.norm());
    for (int k = 0; k < 6; ++k) r.max_root_force_N = std::max(r.max_root_force_N, std::abs(d.qfrc_applied[k]));
    const bool steady = d.time >= kWalkStartup_s;

    // Stopping: the walker plans its last steps; once the feet are side by side the
    // standing controller (pose and balance) takes over with both feet in stance.
    if (params.stop_at_s >= 0 && d.time >= params.stop_at_s && !gait.stopping()) gait.request_stop();
    if (gait.stopped() && ctrl.driver() == &gait) {
      ctrl.set_driver(nullptr);
      ctrl.set_stance(0, true);
      ctrl.set_stance(1, true);
      ctrl.set_pose(stand_pose);
      r.stopped_at_s = d.time;
    }

    // Strikes: step length, width, path, strides; stepping stones.
    if (gait.strike_count() != strikes_seen) {
      strikes_seen = gait.strike_count();
      const controllers::TorqueWalkerStrike& st = gait.last_strike();
      if (!std::isnan(st.target_length_m)) {
        stones.lengths_m.push_back(st.step_length_m);
        stones.errors_m.push_back(st.step_length_m - st.target_length_m);
      }
      if (!params.steps_m.empty() && !steps_planned && d.time >= params.steps_start_s) {
        gait.plan_steps(params.steps_m);  // from the swing that starts now
        steps_planned = true;
        stones.start_s = d.time;
      }
      r.step_lengths_m.push_back(st.step_length_m);
      r.step_widths_m.push_back(st.step_width_m);
      r.step_times_s.push_back(st.time_s);
      const Vector2d c = com_xy(m, d);
      const Vector2d heading(std::cos(gait.heading_rad()), std::sin(gait.heading_rad()));
      const double progress_m = (c - com_last_strike).dot(heading);  // signed: backwards counts against
      r.distance_m += progress_m;
      if (steady) {
        if (steady_first_t < 0) {
          steady_first_t = st.time_s;
        } else {
          steady_path += progress_m;
          steady_last_t = st.time_s;
          ++steady_strikes;
          step_length_sum += st.step_length_m;
        }
      }
      com_last_strike = c;
      if (steady && knee_peak_now > 0) {  // the swing that just ended
        knee_peak_sum += knee_peak_now;
        ++swing_count;
      }
      knee_peak_now = 0;
      if (st.side == 0) {
        left_strike_times.push_back(st.time_s);
        left_strike_com.push_back(c);
        // The push: at onset_phase of the stride after settle_strides strides.
        const std::size_t n = left_strike_times.size();
        if (params.push && !push_scheduled && n >= static_cast<std::size_t>(params.push->settle_strides) + 1) {
          const double stride_s = left_strike_times[n - 1] - left_strike_times[n - 2];
          const double a = gait.heading_rad() + params.push->direction_deg / kRadToDeg;
          sim::Push push;
          push.body = push_body;
          push.force_W = params.push->force_N * Vector3d(std::cos(a), std::sin(a), 0);
          push.start_s = d.time + params.push->onset_phase * stride_s;
          // Whole steps: the push is on for round(duration / dt) steps from the first step at
          // or after its start (simulation.h).
          push.start_s = std::ceil(push.start_s / dt - 1e-9) * dt;
          push.duration_s = params.push->duration_s;
          sim->schedule_push(push);
          push_scheduled = true;
          outcome.onset_s = push.start_s;
          outcome.end_s = push.start_s + push.duration_s;
          // Speed before: the strides before this one (at most 4).
          const std::size_t k = std::min<std::size_t>(4, n - 1);
          outcome.speed_before_m_s = (left_strike_com[n - 1] - left_strike_com[n - 1 - k]).norm() /
                                     (left_strike_times[n - 1] - left_strike_times[n - 1 - k]);
        }
      }
    }

    // Feet: touch-down (heel first?), flat-foot slip within a stance.
    for (int s = 0; s < 2; ++s) {
      FootWatch& f = feet[s];
      const int on_foot = sim::floor_contact_count(m, d, fall.floor_geom(), f.foot);
      const int on_toes = f.toes >= 0 ? sim::floor_contact_count(m, d, fall.floor_geom(), f.toes) : 0;
      const bool touching = on_foot + on_toes > 0;
      if (touching && !f.touching) {
        if (f.air_s > 0.1) {  // a real touch-down after a swing, not a flicker
          ++touchdowns;
          // First contact points in the foot frame: behind the sole centre = heel strike.
          double x_sum = 0;
          int n = 0;
          const Eigen::Map<const Eigen::Matrix<mjtNum, 3, 3, Eigen::RowMajor>> R(d.xmat + 9 * f.foot);
          const Vector3d origin(d.xpos[3 * f.foot], d.xpos[3 * f.foot + 1], d.xpos[3 * f.foot + 2]);
          for (int c = 0; c < d.ncon; ++c) {
            const mjContact& con = d.contact[c];
            if (con.dist > 0) continue;
            const int b1 = m.geom_bodyid[con.geom1], b2 = m.geom_bodyid[con.geom2];
            if (b1 != f.foot && b2 != f.foot && b1 != f.toes && b2 != f.toes) continue;
            const Vector3d p_B = R.transpose() * (Vector3d(con.pos[0], con.pos[1], con.pos[2]) - origin);
            x_sum += p_B.x();
            ++n;
          }
          if (n > 0 && x_sum / n < f.sole.centre_B().x()) ++heel_strikes;
        }
        f.flat = false;
        f.slip = 0;
      }
      if (!touching && f.touching && f.flat) {  // lift-off ends the stance
        slip_sum += f.slip;
        ++stances;
        r.max_foot_slip_m = std::max(r.max_foot_slip_m, f.slip);
      }
      f.air_s = touching ? 0.0 : f.air_s + dt;
      f.touching = touching;
      if (on_foot >= kFlatFootContacts) {
        const Vector2d p(d.xpos[3 * f.foot], d.xpos[3 * f.foot + 1]);
        if (!f.flat) {
          f.flat = true;
          f.flat_at = p;
        }
        f.slip = std::max(f.slip, (p - f.flat_at).norm());
      }
    }

    // Swing knee peak, angle ranges (after the start-up).
    if (steady) {
      const int swing = 1 - gait.stance_side();
      const double knee = d.qpos[m.jnt_qposadr[m.dof_jntid[knee_dof[swing]]]];
      knee_peak_now = std::max(knee_peak_now, knee);
      ranges.sample(m, d, groups);
    }

    if (params.trace) {
      const sim::CenterOfMass com = sim::center_of_mass(m, d);
      const mjtNum* xf = push_body >= 0 ? d.xfrc_applied + 6 * push_body : nullptr;
      *params.trace << d.time << ',' << com.position_W.x() << ',' << com.position_W.y() << ','
                    << com.position_W.z() << ',' << com.velocity_W.x() << ',' << com.velocity_W.y() << ','
                    << d.xpos[3 * pelvis + 2] << ',' << gait.heading_rad() * kRadToDeg
                    << ',' << gait.stance_side() << ',' << gait.phase() << ',' << gait.strike_count() << ','
                    << gait.base_polygon_rule_active() << ','
                    << static_cast<int>(feet[0].touching) << ',' << static_cast<int>(feet[1].touching) << ','
                    << rep.weld_active[0] << ',' << rep.weld_active[1] << ','
                    << d.qpos[m.jnt_qposadr[m.dof_jntid[knee_dof[0]]]] * kRadToDeg << ','
                    << d.qpos[m.jnt_qposadr[m.dof_jntid[knee_dof[1]]]] * kRadToDeg << ','
                    << rep.joints.max_torque_ratio << ',' << (xf ? xf[0] : 0.0) << ',' << (xf ? xf[1] : 0.0) << '\n';
    }

    for (int s = 0; s < 2; ++s) feet_down[s] = feet[s].touching || rep.weld_active[static_cast<std::size_t>(s)];
    if (fall.down(m, d)) {
      r.fallen = true;
      r.time_fallen_s = d.time;
      break;
    }
    if (params.push) {
      if (push_scheduled && d.time >= outcome.end_s + params.push->watch_s) {
        // Judged once 4 strides after the push have ended (or the watch is long over).
        std::size_t after = 0;
        for (double t : left_strike_times)
          if (t >= outcome.end_s) ++after;
        if (after >= static_cast<std::size_t>(kRecoveryStrides) + 1 ||
            d.time >= outcome.end_s + params.push->watch_s + kPushJudgeCap_s)
          break;
      }
      if (progress && step % 100 == 0) {
        const double horizon = push_scheduled ? outcome.end_s + params.push->watch_s + 1.0
                                              : params.push->settle_strides * 1.2 + 8.0;
        progress(std::min(0.99, d.time / horizon));
      }
    } else if (progress && (step % 100 == 0)) {
      progress(static_cast<double>(step + 1) / max_steps);
    }
  }
  ctrl.set_driver(nullptr);
  {
    const sim::CenterOfMass com = sim::center_of_mass(m, d);
    r.final_com_speed_m_s = com.velocity_W.head<2>().norm();
    r.standing_at_end = r.stopped_at_s >= 0 && !r.fallen && r.final_com_speed_m_s < kStandingSpeed_m_s &&
                        feet_down[0] && feet_down[1];
  }
  r.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  r.simulated_s = r.sim_steps * dt;
  r.realtime_factor = r.wall_s > 0 ? r.simulated_s / r.wall_s : 0;
  r.steps = gait.strike_count();
  const Vector2d com_end = com_xy(m, d);
  r.distance_m += (com_end - com_last_strike).dot(Vector2d(std::cos(gait.heading_rad()), std::sin(gait.heading_rad())));
  r.mean_speed_m_s = r.simulated_s > 0 ? r.distance_m / r.simulated_s : 0;
  const Vector2d travel = com_end - com_start;
  r.lateral_drift_m = -start_heading.y() * travel.x() + start_heading.x() * travel.y();
  if (steady_strikes > 0 && steady_last_t > steady_first_t) {
    r.steady_speed_m_s = steady_path / (steady_last_t - steady_first_t);
    r.cadence_steps_per_min = steady_strikes / (steady_last_t - steady_first_t) * 60.0;
    r.mean_step_length_m = step_length_sum / steady_strikes;
  }
  for (const AngleRanges::Entry& e : ranges.entries)
    if (e.hi >= e.lo) r.joint_ranges_deg[e.name] = {e.lo * kRadToDeg, e.hi * kRadToDeg};
  r.swing_knee_peak_deg = swing_count > 0 ? knee_peak_sum / swing_count * kRadToDeg : 0;
  r.heel_strike_fraction = touchdowns > 0 ? static_cast<double>(heel_strikes) / touchdowns : 0;
  r.base_polygon_steps = gait.base_polygon_steps();
  r.mean_foot_slip_m = stances > 0 ? slip_sum / stances : 0;

  if (!params.steps_m.empty()) {
    double sq = 0;
    for (double e : stones.errors_m) {
      sq += e * e;
      stones.max_error_m = std::max(stones.max_error_m, std::abs(e));
    }
    stones.rms_error_m = stones.errors_m.empty() ? 0 : std::sqrt(sq / static_cast<double>(stones.errors_m.size()));
    stones.complete = stones.lengths_m.size() == stones.targets_m.size();
    r.stones = stones;
  }
  if (params.push) {
    WalkPushOutcome& o = outcome;
    if (!push_scheduled) {
      o.fell = r.fallen;
      o.failure = r.fallen ? "fell before the push" : "no steady stride to push in";
    } else {
      for (std::size_t i = 0; i + 1 < left_strike_times.size(); ++i) {
        if (left_strike_times[i] < o.end_s) continue;
        o.stride_speeds_after_m_s.push_back((left_strike_com[i + 1] - left_strike_com[i]).norm() /
                                            (left_strike_times[i + 1] - left_strike_times[i]));
      }
      for (std::size_t k = 0; k < o.stride_speeds_after_m_s.size() && k < static_cast<std::size_t>(kRecoveryStrides); ++k) {
        if (std::abs(o.stride_speeds_after_m_s[k] - o.speed_before_m_s) <= kRecoveredSpeedFraction * o.speed_before_m_s) {
          o.recovery_strides = static_cast<int>(k) + 1;
          break;
        }
      }
      o.fell = r.fallen;
      if (o.fell) {
        std::ostringstream s;
        s << "fell at " << r.time_fallen_s << " s (" << r.time_fallen_s - o.onset_s << " s after the onset)";
        o.failure = s.str();
      } else if (o.recovery_strides < 0) {
        o.failure = "speed not back within 10% in 4 strides";
      }
    }
    o.survived = o.failure.empty();
    r.push = o;
  }
  if (progress) progress(1.0);
  return r;
}

}  // namespace biodyn::scenarios

namespace biodyn::scenarios {

WalkingPushCell scan_walking_push(sim::Simulation* sim, const WalkRunParams& base, double direction_deg,
                                  double duration_s, double onset_phase, const WalkingPushScanSettings& scan) {
  if (!(scan.resolution_N > 0)) fail("push scan resolution", "must be > 0 N", scan.resolution_N);
  if (!(scan.max_force_N >= scan.resolution_N)) fail("push scan max force", "must be >= the resolution", scan.max_force_N);
  WalkingPushCell cell;
  cell.direction_deg = direction_deg;
  cell.duration_s = duration_s;
  cell.onset_phase = onset_phase;
  WalkRunParams run = base;
  run.trace = nullptr;
  WalkPush push = base.push.value_or(WalkPush{});
  push.direction_deg = direction_deg;
  push.duration_s = duration_s;
  push.onset_phase = onset_phase;
  const auto survives = [&](double force) {
    push.force_N = force;
    run.push = push;
    const WalkRunResult r = run_walk(sim, run);
    ++cell.runs;
    if (r.push && r.push->failure == "fell before the push") cell.fell_before_push = true;
    return std::make_pair(r.push && r.push->survived, r.push ? r.push->failure : std::string("no push"));
  };
  const int n = static_cast<int>(std::floor(scan.max_force_N / scan.resolution_N + 1e-9));
  for (int i = 1; i <= n; ++i) {
    const double force = i * scan.resolution_N;
    const auto [ok, why] = survives(force);
    if (cell.fell_before_push) return cell;
    if (!ok) {
      cell.first_failure_N = force;
      cell.failure = why;
      break;
    }
    cell.max_survived_N = force;
  }
  if (scan.bisect) {
    // Bisection on the resolution grid between a survived 0 N and max_force_N, as if survival
    // were monotonic in force.
    int lo = 0, hi = n + 1;  // lo survived, hi failed (n + 1: beyond the range)
    if (survives(n * scan.resolution_N).first) {
      lo = n;
    } else {
      hi = n;
      while (hi - lo > 1) {
        const int mid = (lo + hi) / 2;
        if (survives(mid * scan.resolution_N).first) lo = mid;
        else hi = mid;
      }
    }
    cell.bisection_N = lo * scan.resolution_N;
  }
  return cell;
}

}  // namespace biodyn::scenarios
