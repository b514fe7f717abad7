// `biodyn walk` and `push`: a walking scenario run to its end under its observers (walk.h).
#include "biodyn/scenarios/walk.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <optional>
#include <sstream>

#include "biodyn/scenarios/walk_scenario.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/queries.h"
#include "biodyn/sim/units.h"
#include "checks.h"

namespace biodyn::scenarios {
namespace {

using controllers::JointGroup;
using Eigen::Vector2d;
using Eigen::Vector3d;

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

Vector2d com_xy(const mjModel& m, const mjData& d) {
  return sim::center_of_mass(m, d).position_W.head<2>();
}

// Per-angle [min, max] of the legs and the lower back (the lumbar, or the gait model's trunk).
struct AngleRanges {
  struct Entry {
    std::string name;
    int group = -1, component = 0;
    double lo = 1e9, hi = -1e9;
  };
  std::vector<Entry> entries;

  explicit AngleRanges(const models::Rig& rig) {
    const std::vector<JointGroup>& groups = rig.groups();
    const int back = rig.lower_back();
    for (std::size_t g = 0; g < groups.size(); ++g) {
      const std::string& n = groups[g].name;
      const bool wanted = n.rfind("hip", 0) == 0 || n.rfind("knee", 0) == 0 ||
                          n.rfind("ankle", 0) == 0 || n.rfind("toe", 0) == 0 ||
                          static_cast<int>(g) == back;
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
        a = controllers::angles_from_orientation(
            g, sim::relative_orientation(m, d, g.body))[e.component];
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
  double slip = 0;   // this stance
  double air_s = 0;  // time off the floor before the current touch
};

// The gait's figures (WalkRunResult), measured after every step.
class WalkMetrics : public StepObserver {
 public:
  WalkMetrics(const WalkScenario& s, WalkRunResult* r)
      : r_(r),
        ranges_(s.rig()),
        load_meter_(s.simulation().model(),
                    models::judged_tau_max(s.simulation().model(), s.rig().groups())) {
    const mjModel& m = s.simulation().model();
    const mjData& d = s.simulation().data();
    for (int side = 0; side < 2; ++side) {
      feet_[side].foot = s.rig().leg(side).foot;
      feet_[side].toes = s.rig().leg(side).toes;
      feet_[side].sole = s.rig().leg(side).sole;
      knee_dof_[side] =
          s.rig().groups()[static_cast<std::size_t>(s.rig().leg(side).knee)].dof_begin;
    }
    start_heading_ =
        Vector2d(std::cos(s.walker().heading_rad()), std::sin(s.walker().heading_rad()));
    com_start_ = com_last_strike_ = com_xy(m, d);
  }

  void on_step(const Scenario& scenario) override {
    const WalkScenario& s = static_cast<const WalkScenario&>(scenario);
    const mjModel& m = s.simulation().model();
    const mjData& d = s.simulation().data();
    const controllers::StepReport& rep = s.pipeline()->last_report();
    ++r_->sim_steps;
    r_->warnings += rep.status.new_warnings;
    r_->max_torque_ratio = std::max(r_->max_torque_ratio, rep.joints.max_torque_ratio);
    load_meter_.measure(m, d, &load_);
    if (rep.weld_tension) ++r_->weld_tension_steps;
    r_->weld_redone_steps += rep.redone > 0 ? 1 : 0;
    for (std::size_t side = 0; side < 2; ++side)
      r_->max_weld_force_N = std::max(r_->max_weld_force_N, rep.weld[side].force_W.norm());
    for (int k = 0; k < 6; ++k)
      r_->max_root_force_N = std::max(r_->max_root_force_N, std::abs(d.qfrc_applied[k]));
    const bool steady = d.time >= kWalkStartup_s;
    if (s.walker().strike_count() != strikes_seen_) on_strike(s, m, d, steady);
    watch_feet(m, d, s.rig().floor_geom());
    // Swing knee peak, angle ranges (after the start-up).
    if (steady) {
      const int swing = 1 - s.walker().stance_side();
      const double knee = d.qpos[m.jnt_qposadr[m.dof_jntid[knee_dof_[swing]]]];
      knee_peak_now_ = std::max(knee_peak_now_, knee);
      ranges_.sample(m, d, s.rig().groups());
    }
    for (std::size_t side = 0; side < 2; ++side)
      feet_down_[side] = feet_[side].touching || rep.weld_active[side];
  }

  // The figures over the whole run, at its end.
  void finish(const WalkScenario& s) {
    const mjModel& m = s.simulation().model();
    const mjData& d = s.simulation().data();
    const sim::CenterOfMass com = sim::center_of_mass(m, d);
    // After a divergence the data is MuJoCo's reset: the walk is measured to its last strike.
    const bool diverged = s.diverged_at_s() >= 0;
    r_->final_com_speed_m_s = diverged ? 0.0 : com.velocity_W.head<2>().norm();
    // The diverging step is not measured (on_step), but its warning (bad qpos/qvel/qacc) counts.
    if (diverged) r_->warnings = s.simulation().warnings();
    r_->joint_load = joint_load_report(m, load_);
    r_->standing_at_end = r_->stopped_at_s >= 0 && !r_->fallen &&
                          r_->final_com_speed_m_s < kStandingSpeed_m_s && feet_down_[0] &&
                          feet_down_[1];
    r_->steps = s.walker().strike_count();
    const double heading = s.walker().heading_rad();
    const Vector2d com_end = diverged ? com_last_strike_ : Vector2d(com.position_W.head<2>());
    r_->distance_m +=
        (com_end - com_last_strike_).dot(Vector2d(std::cos(heading), std::sin(heading)));
    r_->mean_speed_m_s = r_->simulated_s > 0 ? r_->distance_m / r_->simulated_s : 0;
    const Vector2d travel = com_end - com_start_;
    r_->lateral_drift_m = -start_heading_.y() * travel.x() + start_heading_.x() * travel.y();
    if (steady_strikes_ > 0 && steady_last_t_ > steady_first_t_) {
      r_->steady_speed_m_s = steady_path_ / (steady_last_t_ - steady_first_t_);
      r_->cadence_steps_per_min = steady_strikes_ / (steady_last_t_ - steady_first_t_) * 60.0;
      r_->mean_step_length_m = step_length_sum_ / steady_strikes_;
    }
    for (const AngleRanges::Entry& e : ranges_.entries)
      if (e.hi >= e.lo) r_->joint_ranges_deg[e.name] = {e.lo * kDegPerRad, e.hi * kDegPerRad};
    r_->swing_knee_peak_deg = swing_count_ > 0 ? knee_peak_sum_ / swing_count_ * kDegPerRad : 0;
    r_->heel_strike_fraction =
        touchdowns_ > 0 ? static_cast<double>(heel_strikes_) / touchdowns_ : 0;
    r_->base_polygon_steps = s.walker().base_polygon_steps();
    r_->mean_foot_slip_m = stances_ > 0 ? slip_sum_ / stances_ : 0;
  }

 private:
  // Strikes: step length, width, path, knee peaks.
  void on_strike(const WalkScenario& s, const mjModel& m, const mjData& d, bool steady) {
    strikes_seen_ = s.walker().strike_count();
    const controllers::TorqueWalkerStrike& st = s.walker().last_strike();
    r_->step_lengths_m.push_back(st.step_length_m);
    r_->step_widths_m.push_back(st.step_width_m);
    r_->step_times_s.push_back(st.time_s);
    const Vector2d c = com_xy(m, d);
    const Vector2d heading(std::cos(s.walker().heading_rad()), std::sin(s.walker().heading_rad()));
    const double progress_m =
        (c - com_last_strike_).dot(heading);  // signed: backwards counts against
    r_->distance_m += progress_m;
    if (steady) {
      if (steady_first_t_ < 0) {
        steady_first_t_ = st.time_s;
      } else {
        steady_path_ += progress_m;
        steady_last_t_ = st.time_s;
        ++steady_strikes_;
        step_length_sum_ += st.step_length_m;
      }
    }
    com_last_strike_ = c;
    if (steady && knee_peak_now_ > 0) {  // the swing that just ended
      knee_peak_sum_ += knee_peak_now_;
      ++swing_count_;
    }
    knee_peak_now_ = 0;
  }

  // Feet: touch-down (heel first?), flat-foot slip within a stance.
  void watch_feet(const mjModel& m, const mjData& d, int floor) {
    const double dt = m.opt.timestep;
    for (FootWatch& f : feet_) {
      const int on_foot = sim::floor_contact_count(m, d, floor, f.foot);
      const int on_toes = f.toes >= 0 ? sim::floor_contact_count(m, d, floor, f.toes) : 0;
      const bool touching = on_foot + on_toes > 0;
      if (touching && !f.touching) {
        if (f.air_s > 0.1) {  // a real touch-down after a swing, not a flicker
          ++touchdowns_;
          if (first_contact_behind_centre(m, d, f)) ++heel_strikes_;
        }
        f.flat = false;
        f.slip = 0;
      }
      if (!touching && f.touching && f.flat) {  // lift-off ends the stance
        slip_sum_ += f.slip;
        ++stances_;
        r_->max_foot_slip_m = std::max(r_->max_foot_slip_m, f.slip);
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
  }

  // First contact points in the foot frame: behind the sole centre = heel strike.
  static bool first_contact_behind_centre(const mjModel& m, const mjData& d, const FootWatch& f) {
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
    return n > 0 && x_sum / n < f.sole.centre_B().x();
  }

  WalkRunResult* r_;
  FootWatch feet_[2];
  int knee_dof_[2] = {0, 0};
  AngleRanges ranges_;
  sim::JointLoadMeter load_meter_;
  sim::JointLoadStats load_;
  Vector2d start_heading_, com_start_, com_last_strike_;
  int strikes_seen_ = 0;
  double steady_first_t_ = -1, steady_last_t_ = 0, steady_path_ = 0;
  int steady_strikes_ = 0;
  double step_length_sum_ = 0;
  int swing_count_ = 0;
  double knee_peak_sum_ = 0, knee_peak_now_ = 0;
  int heel_strikes_ = 0, touchdowns_ = 0;
  double slip_sum_ = 0;
  int stances_ = 0;
  bool feet_down_[2] = {true, true};  // on the floor: touching it or welded to it (glue)
};

// One CSV line per step (WalkRunParams::trace).
class WalkTrace : public StepObserver {
 public:
  explicit WalkTrace(std::ostream* out) : out_(out) {
    *out_ << "time_s,com_x,com_y,com_z,com_vx,com_vy,pelvis_z,heading_deg,stance,state,strikes,"
             "base_polygon_rule,"
             "contacts_l,contacts_r,weld_l,weld_r,knee_l_deg,knee_r_deg,max_torque_ratio,push_fx,"
             "push_fy,foot_l_x,foot_l_y,foot_l_z,foot_r_x,foot_r_y,foot_r_z\n";
  }
  void on_step(const Scenario& scenario) override {
    const WalkScenario& s = static_cast<const WalkScenario&>(scenario);
    const mjModel& m = s.simulation().model();
    const mjData& d = s.simulation().data();
    const controllers::StepReport& rep = s.pipeline()->last_report();
    const controllers::TorqueWalker& w = s.walker();
    const sim::CenterOfMass com = sim::center_of_mass(m, d);
    const int push_body = s.push_body();
    const mjtNum* xf = push_body >= 0 ? d.xfrc_applied + 6 * push_body : nullptr;
    bool touching[2];
    for (int side = 0; side < 2; ++side) {
      const models::RigLeg& leg = s.rig().leg(side);
      touching[side] =
          sim::floor_contact_count(m, d, s.rig().floor_geom(), leg.foot) +
              (leg.toes >= 0 ? sim::floor_contact_count(m, d, s.rig().floor_geom(), leg.toes) : 0) >
          0;
    }
    const auto knee_deg = [&](int side) {
      const int dof = s.rig().groups()[static_cast<std::size_t>(s.rig().leg(side).knee)].dof_begin;
      return d.qpos[m.jnt_qposadr[m.dof_jntid[dof]]] * kDegPerRad;
    };
    *out_ << d.time << ',' << com.position_W.x() << ',' << com.position_W.y() << ','
          << com.position_W.z() << ',' << com.velocity_W.x() << ',' << com.velocity_W.y() << ','
          << d.xpos[3 * s.rig().pelvis() + 2] << ',' << w.heading_rad() * kDegPerRad << ','
          << w.stance_side() << ',' << w.phase() << ',' << w.strike_count() << ','
          << w.base_polygon_rule_active() << ',' << static_cast<int>(touching[0]) << ','
          << static_cast<int>(touching[1]) << ',' << rep.weld_active[0] << ',' << rep.weld_active[1]
          << ',' << knee_deg(0) << ',' << knee_deg(1) << ',' << rep.joints.max_torque_ratio << ','
          << (xf ? xf[0] : 0.0) << ',' << (xf ? xf[1] : 0.0);
    // Each foot's origin (the ankle), world: where the steps land against the CoM.
    for (int side = 0; side < 2; ++side) {
      const mjtNum* p = d.xpos + 3 * s.rig().leg(side).foot;
      *out_ << ',' << p[0] << ',' << p[1] << ',' << p[2];
    }
    *out_ << '\n';
  }

 private:
  std::ostream* out_;
};

// The push protocol (references.md): the speed before the push from the strides before it, the
// strides after it, done once 4 strides after the push have ended (or the watch is long over).
class PushJudge : public StepObserver {
 public:
  PushJudge(const WalkScenario& s, WalkPushOutcome* o)
      : o_(o), watch_s_(s.config().walk_push->watch_s) {
    const WalkPush& p = *s.config().walk_push;
    o->force_N = p.force_N;
    o->duration_s = p.duration_s;
    o->direction_deg = p.direction_deg;
    o->body = mj_id2name(&s.simulation().model(), mjOBJ_BODY, s.push_body());
    o->impulse_N_s = o->force_N * o->duration_s;
    o->delta_v_m_s = o->impulse_N_s / s.rig().mass_kg();
  }

  void on_step(const Scenario& scenario) override {
    const WalkScenario& s = static_cast<const WalkScenario&>(scenario);
    const mjData& d = s.simulation().data();
    if (s.walker().strike_count() != strikes_seen_) {
      strikes_seen_ = s.walker().strike_count();
      if (s.walker().last_strike().side == 0) {
        left_strike_times_.push_back(s.walker().last_strike().time_s);
        left_strike_com_.push_back(com_xy(s.simulation().model(), d));
      }
    }
    if (!scheduled_ && !std::isnan(s.push_onset_s())) {
      // Scheduled at this left strike, once the strides before it were steady.
      scheduled_ = true;
      o_->onset_s = s.push_onset_s();
      o_->end_s = s.push_end_s();
      o_->speed_before_m_s = s.push_speed_before_m_s();
      o_->strides_before = s.push_after_strides();
    }
    if (!scheduled_ && s.push_abandoned()) done_ = true;  // no push will come
    if (scheduled_ && d.time >= o_->end_s + watch_s_) {
      std::size_t after = 0;
      for (double t : left_strike_times_)
        if (t >= o_->end_s) ++after;
      done_ = after >= static_cast<std::size_t>(kRecoveryStrides) + 1 ||
              d.time >= o_->end_s + watch_s_ + kPushJudgeCap_s;
    }
  }
  bool done() const override { return done_; }
  bool scheduled() const { return scheduled_; }

  // The outcome, once the run is over.
  void judge(const WalkRunResult& r) {
    WalkPushOutcome& o = *o_;
    o.fell = r.fallen;
    if (!scheduled_) {
      o.outcome = r.fallen ? PushOutcome::kFellBeforePush : PushOutcome::kNoSteadyStride;
      o.failure = to_string(o.outcome);
      o.survived = false;
      return;
    }
    for (std::size_t i = 0; i + 1 < left_strike_times_.size(); ++i) {
      if (left_strike_times_[i] < o.end_s) continue;
      o.stride_speeds_after_m_s.push_back((left_strike_com_[i + 1] - left_strike_com_[i]).norm() /
                                          (left_strike_times_[i + 1] - left_strike_times_[i]));
    }
    for (std::size_t k = 0;
         k < o.stride_speeds_after_m_s.size() && k < static_cast<std::size_t>(kRecoveryStrides);
         ++k) {
      if (std::abs(o.stride_speeds_after_m_s[k] - o.speed_before_m_s) <=
          kRecoveredSpeedFraction * o.speed_before_m_s) {
        o.recovery_strides = static_cast<int>(k) + 1;
        break;
      }
    }
    if (o.fell) {
      o.outcome = PushOutcome::kFell;
      std::ostringstream s;
      s << "fell at " << r.time_fallen_s << " s (" << r.time_fallen_s - o.onset_s
        << " s after the onset)";
      if (r.diverged_at_s >= 0) s << ", the simulation diverged (MuJoCo's bad qpos, qvel or qacc)";
      o.failure = s.str();
    } else if (o.recovery_strides < 0) {
      o.outcome = PushOutcome::kSpeedNotRecovered;
      o.failure = to_string(o.outcome);
    }
    o.survived = o.failure.empty();
  }

 private:
  WalkPushOutcome* o_;
  const double watch_s_;
  int strikes_seen_ = 0;
  bool scheduled_ = false, done_ = false;
  std::vector<double> left_strike_times_;
  std::vector<Vector2d> left_strike_com_;
};

}  // namespace

const char* to_string(PushOutcome outcome) {
  switch (outcome) {
    case PushOutcome::kSurvived:
      return "survived";
    case PushOutcome::kFellBeforePush:
      return "fell before the push";
    case PushOutcome::kNoSteadyStride:
      return "never steady: no 4 strides in a row within 5% of their mean speed, not pushed";
    case PushOutcome::kFell:
      return "fell";
    case PushOutcome::kSpeedNotRecovered:
      return "speed not back within 10% in 4 strides";
  }
  return "?";
}

void WalkRunParams::validate() const {
  if (!config.walking()) {
    throw sim::InvalidArgument("scenario: a walk runs the walk or stones scenario, got '" +
                               config.scenario + "'");
  }
  if (!(duration_s > 0) || !std::isfinite(duration_s) || duration_s > 3600)
    fail("duration", "must be in (0, 3600] s", duration_s);
  config.validate();
  if (!config.steps_m.empty() && !(config.steps_start_s < duration_s))
    fail("steps start", "must be in [0, duration) s", config.steps_start_s);
  if (config.stop_at_s >= 0 && !(config.stop_at_s < duration_s))
    fail("stop-at", "must be in [0, duration) s", config.stop_at_s);
}

WalkRunResult run_walk(sim::Simulation* sim, const WalkRunParams& params,
                       const std::function<void(double)>& progress) {
  params.validate();
  WalkScenario scenario(sim, params.config);
  const double dt = sim->model().opt.timestep;
  const std::optional<WalkPush>& push = params.config.walk_push;
  const long max_steps =
      std::lround((push ? kMaxSettle_s + push->duration_s + push->watch_s + kPushJudgeCap_s
                        : params.duration_s) /
                  dt);
  scenario.set_max_steps(max_steps);

  WalkRunResult r;
  r.weld = controllers::to_string(params.config.weld);
  r.speed_command_m_s = params.config.speed_m_s;
  r.heading_rate_deg_s = params.config.heading_rate_deg_s;
  const controllers::ControllerParams& cp = *scenario.controller_params();
  r.reaction_time_s = cp.joints.empty() ? 0 : cp.joints.front().reaction_time_s;
  for (const controllers::JointParams& j : cp.joints)
    if (j.reaction_time_s != r.reaction_time_s) r.reaction_time_s = -1;

  WalkMetrics metrics(scenario, &r);
  scenario.add_observer(&metrics);
  std::optional<WalkTrace> trace;
  if (params.trace) scenario.add_observer(&trace.emplace(params.trace));
  WalkPushOutcome outcome;
  std::optional<PushJudge> judge;
  if (push) scenario.add_observer(&judge.emplace(scenario, &outcome));
  for (StepObserver* o : params.observers) scenario.add_observer(o);

  const auto wall_start = std::chrono::steady_clock::now();
  while (!scenario.run_over()) {
    scenario.step();
    const long step = scenario.step_index() - 1;
    if (!progress || step % 100 != 0) continue;
    if (push) {
      const double horizon = judge->scheduled() ? outcome.end_s + push->watch_s + 1.0
                                                : push->settle_strides * 1.2 + 8.0;
      progress(std::min(0.99, sim->data().time / horizon));
    } else {
      progress(static_cast<double>(step + 1) / static_cast<double>(max_steps));
    }
  }
  r.fallen = scenario.fell_at_s() >= 0;
  r.time_fallen_s = scenario.fell_at_s();
  r.diverged_at_s = scenario.diverged_at_s();
  r.stopped_at_s = scenario.stopped_at_s();
  r.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  r.simulated_s = r.sim_steps * dt;
  r.realtime_factor = r.wall_s > 0 ? r.simulated_s / r.wall_s : 0;
  metrics.finish(scenario);
  r.muscles = muscle_report(*scenario.pipeline());

  if (!params.config.steps_m.empty()) {
    SteppingStonesResult stones;
    stones.targets_m = params.config.steps_m;
    stones.lateral_m = params.config.steps_lateral_m;
    stones.start_s = scenario.stones_start_s();
    double sq = 0;
    for (const Stone& st : scenario.stones()) {
      if (std::isnan(st.walked_m)) {
        // In swing at the end (a fall): out of reach if the leg could not reach it then.
        if (st.out_of_reach)
          stones.out_of_reach.push_back(static_cast<int>(stones.lengths_m.size()) + 1);
        continue;
      }
      const double e = st.error_m();
      stones.lengths_m.push_back(st.walked_m);
      if (st.across_planned) {
        stones.across_m.push_back(st.walked_across_m);
        stones.target_across_m.push_back(st.across_m);
      }
      if (st.out_of_reach) stones.out_of_reach.push_back(static_cast<int>(stones.lengths_m.size()));
      stones.errors_m.push_back(e);
      sq += e * e;
      stones.max_error_m = std::max(stones.max_error_m, std::abs(e));
    }
    stones.rms_error_m =
        stones.errors_m.empty() ? 0 : std::sqrt(sq / static_cast<double>(stones.errors_m.size()));
    stones.complete = stones.lengths_m.size() == stones.targets_m.size();
    r.stones = stones;
  }
  if (push) {
    judge->judge(r);
    r.push = outcome;
  }
  if (progress) progress(1.0);
  return r;
}

}  // namespace biodyn::scenarios
