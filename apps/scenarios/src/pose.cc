// `biodyn pose` and `stand-push`: a pose scenario run to its end under its observers (pose.h).
#include "biodyn/scenarios/pose.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <optional>
#include <sstream>

#include "biodyn/controllers/support_polygon.h"
#include "biodyn/scenarios/pose_scenario.h"
#include "biodyn/scenarios/registry.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/queries.h"
#include "biodyn/sim/units.h"

namespace biodyn::scenarios {
namespace {

using controllers::JointGroup;
using Eigen::Vector2d;

// A foot point within this gap of the floor counts as support (a welded or lightly loaded
// sole hovers a fraction of a millimetre above its contact surface in MuJoCo's soft contact).
constexpr double kSupportGap_m = 0.002;
// A push counts as survived without stepping only if no foot moved this far (a standing
// controller never steps, but a foot can slide or pivot away).
constexpr double kNoStepFootMove_m = 0.03;

// Everything PoseRunResult reports, measured after every step. Read-outs use the kinematics and
// contacts mj_step1 computed for the step (the state one step earlier than d.time): no extra
// mj_forward in the loop.
class PoseMetrics : public StepObserver {
 public:
  PoseMetrics(const PoseScenario& s, double velocity_window_s, PoseRunResult* r)
      : r_(r),
        window_steps_(std::max(1, static_cast<int>(std::lround(
                                      velocity_window_s / s.simulation().model().opt.timestep)))) {
    contact_points_.reserve(64);
  }

  void on_step(const Scenario& scenario) override {
    const PoseScenario& s = static_cast<const PoseScenario&>(scenario);
    const mjModel& m = s.simulation().model();
    const mjData& d = s.simulation().data();
    const controllers::StepReport& rep = s.pipeline()->last_report();
    ++r_->steps;
    r_->warnings += rep.status.new_warnings;
    r_->max_torque_ratio = std::max(r_->max_torque_ratio, rep.joints.max_torque_ratio);
    r_->solver_converged = r_->solver_converged && rep.joints.converged;
    if (rep.weld_tension) ++r_->weld_tension_steps;
    r_->weld_redone_steps += rep.redone > 0 ? 1 : 0;
    for (std::size_t side = 0; side < 2; ++side) {
      r_->max_weld_force_N = std::max(r_->max_weld_force_N, rep.weld[side].force_W.norm());
      if (rep.weld_active[side]) ++weld_active_steps_;
    }
    if (rep.joints_outside_limits > 0) ++r_->joints_outside_limits_steps;
    check_targets(s, m, d);
    support_polygon(s, m, d);
    const controllers::Pose& pose = s.poses()[s.pose_index()];
    for (int side = 0; side < 2; ++side) {
      if (!pose.stance[static_cast<std::size_t>(side)]) continue;
      const int foot = s.rig().leg(side).foot;
      const Vector2d now(d.xpos[3 * foot], d.xpos[3 * foot + 1]);
      r_->max_foot_displacement_m =
          std::max(r_->max_foot_displacement_m, (now - s.foot_start(side)).norm());
    }
    velocity_rms(s, d);
  }

  void finish() {
    r_->weld_active_fraction = r_->steps > 0 ? weld_active_steps_ / (2.0 * r_->steps) : 0;
  }

 private:
  // The orientation error of every joint at the pose's reach time.
  void check_targets(const PoseScenario& s, const mjModel& m, const mjData& d) {
    if (s.pose_index() != pose_checked_index_) {  // a new pose: its check is to come
      pose_checked_index_ = s.pose_index();
      checked_ = false;
    }
    const controllers::Pose& pose = s.poses()[s.pose_index()];
    const double dt = m.opt.timestep;
    if (checked_ || d.time < s.pose_start_s() + pose.reach_time_s - 0.5 * dt) return;
    checked_ = true;
    const std::vector<JointGroup>& groups = s.rig().groups();
    TargetCheck tc;
    tc.pose = pose.name;
    tc.time_s = d.time;
    for (std::size_t g = 0; g < groups.size(); ++g) {
      const double e = s.pipeline()->orientation_error(static_cast<int>(g)) * kDegPerRad;
      if (e > tc.error_deg) {
        tc.error_deg = e;
        tc.worst_joint = groups[g].name;
      }
      const auto it = pose.angles_rad.find(groups[g].name);
      const Eigen::Vector3d angles =
          it == pose.angles_rad.end() ? Eigen::Vector3d::Zero() : it->second;
      const Eigen::Quaterniond q_pose = controllers::orientation_from_angles(groups[g], angles);
      const Eigen::Quaterniond q_now = sim::relative_orientation(m, d, groups[g].body);
      tc.pose_error_deg = std::max(
          tc.pose_error_deg, controllers::rotation_angle(q_now.conjugate() * q_pose) * kDegPerRad);
    }
    r_->max_orientation_error_deg = std::max(r_->max_orientation_error_deg, tc.error_deg);
    r_->max_pose_error_deg = std::max(r_->max_pose_error_deg, tc.pose_error_deg);
    r_->targets.push_back(tc);
  }

  // The CoM against the support polygon of the actual foot contacts.
  void support_polygon(const PoseScenario& s, const mjModel& m, const mjData& d) {
    const int floor = s.rig().floor_geom();
    contact_points_.clear();
    for (int c = 0; c < d.ncon; ++c) {
      const mjContact& con = d.contact[c];
      const int other = sim::is_ground(m, con.geom1, floor)   ? con.geom2
                        : sim::is_ground(m, con.geom2, floor) ? con.geom1
                                                              : -1;
      if (other < 0 || con.dist > kSupportGap_m) continue;
      if (s.rig().is_foot_part(m.geom_bodyid[other]))
        contact_points_.emplace_back(con.pos[0], con.pos[1]);
    }
    if (contact_points_.size() < 3) return;
    controllers::convex_hull(&contact_points_, &hull_);
    const Eigen::Vector3d com = sim::center_of_mass(m, d).position_W;
    const double out = controllers::distance_outside(hull_, com.head<2>());
    if (out > 0) r_->com_outside_support_s += m.opt.timestep;
    r_->max_com_outside_support_m = std::max(r_->max_com_outside_support_m, out);
  }

  // Joint-velocity RMS per window (actuated DOFs).
  void velocity_rms(const PoseScenario& s, const mjData& d) {
    for (const JointGroup& g : s.rig().groups())
      for (int k = 0; k < g.dof_count; ++k) {
        const double v = d.qvel[g.dof_begin + k];
        window_sum_ += v * v;
        ++window_samples_;
      }
    if (s.step_index() % window_steps_ == 0 || s.step_index() == s.total_steps()) {
      r_->joint_velocity_rms.push_back(std::sqrt(window_sum_ / std::max(window_samples_, 1)));
      window_sum_ = 0;
      window_samples_ = 0;
    }
  }

  PoseRunResult* r_;
  const int window_steps_;
  std::size_t pose_checked_index_ = 0;
  bool checked_ = false;
  int weld_active_steps_ = 0;
  double window_sum_ = 0;
  int window_samples_ = 0;
  std::vector<Vector2d> contact_points_, hull_;
};

// One CSV line per step (PoseRunParams::trace).
class PoseTrace : public StepObserver {
 public:
  explicit PoseTrace(std::ostream* out) : out_(out) {
    *out_ << "time_s,pose,com_x,com_y,com_z,pelvis_z,cp_error_x,cp_error_y,"
             "sagittal_tilt_rad,frontal_tilt_rad,hip_flexion_rad,weld_l,weld_r,"
             "weld_fx_l,weld_fy_l,weld_fz_l,weld_fx_r,weld_fy_r,weld_fz_r,"
             "ground_fz_l,ground_fz_r,tension_excess_l,tension_excess_r,"
             "max_torque_ratio,saturated_dofs,redone\n";
  }
  void on_step(const Scenario& scenario) override {
    const PoseScenario& s = static_cast<const PoseScenario&>(scenario);
    const mjModel& m = s.simulation().model();
    const mjData& d = s.simulation().data();
    const controllers::StepReport& rep = s.pipeline()->last_report();
    const Eigen::Vector3d com = sim::center_of_mass(m, d).position_W;
    const Eigen::Vector2d& e = s.pipeline()->balance().capture_point_error();
    *out_ << d.time << ',' << s.poses()[s.pose_index()].name << ',' << com.x() << ',' << com.y()
          << ',' << com.z() << ',' << d.xpos[3 * s.rig().pelvis() + 2] << ',' << e.x() << ','
          << e.y() << ',' << rep.balance.sagittal_tilt << ',' << rep.balance.frontal_tilt << ','
          << rep.balance.hip_flexion << ',' << rep.weld_active[0] << ',' << rep.weld_active[1]
          << ',' << rep.weld[0].force_W.x() << ',' << rep.weld[0].force_W.y() << ','
          << rep.weld[0].force_W.z() << ',' << rep.weld[1].force_W.x() << ','
          << rep.weld[1].force_W.y() << ',' << rep.weld[1].force_W.z() << ','
          << rep.weld[0].ground_force_W.z() << ',' << rep.weld[1].ground_force_W.z() << ','
          << rep.weld[0].tension_excess_N << ',' << rep.weld[1].tension_excess_N << ','
          << rep.joints.max_torque_ratio << ',' << rep.joints.saturated_dofs << ',' << rep.redone
          << '\n';
  }

 private:
  std::ostream* out_;
};

}  // namespace

void PoseRunParams::validate() const {
  if (!is_pose_scenario(config.scenario)) {
    std::string known;
    for (const std::string& n : controllers::pose_scenario_names())
      known += (known.empty() ? "" : ", ") + n;
    throw sim::InvalidArgument("scenario: must be one of " + known + ", got '" + config.scenario +
                               "'");
  }
  config.validate();
  if (!(velocity_window_s > 0)) {
    throw sim::InvalidArgument("velocity_window_s: must be > 0 s, got " +
                               std::to_string(velocity_window_s));
  }
}

PoseRunResult run_pose(sim::Simulation* sim, const PoseRunParams& params,
                       const std::function<void(double)>& progress) {
  params.validate();
  PoseScenario scenario(sim, params.config);
  PoseRunResult r;
  r.scenario = params.config.scenario;
  r.controller = controllers::to_string(params.config.controller);
  r.weld = controllers::to_string(params.config.weld);
  const controllers::ControllerParams& cp = *scenario.controller_params();
  r.reaction_time_s = cp.joints.empty() ? 0 : cp.joints.front().reaction_time_s;
  for (const controllers::JointParams& j : cp.joints)
    if (j.reaction_time_s != r.reaction_time_s) r.reaction_time_s = -1;

  PoseMetrics metrics(scenario, params.velocity_window_s, &r);
  scenario.add_observer(&metrics);
  std::optional<PoseTrace> trace;
  if (params.trace) scenario.add_observer(&trace.emplace(params.trace));

  const long steps = scenario.total_steps();
  const long report_every = std::max(1L, steps / 100);
  const auto wall_start = std::chrono::steady_clock::now();
  while (!scenario.run_over()) {
    scenario.step();
    const long done = scenario.step_index();
    if (progress && ((done - 1) % report_every == 0 || done == steps)) {
      progress(static_cast<double>(done) / static_cast<double>(steps));
    }
  }
  metrics.finish();
  r.muscles = muscle_report(*scenario.pipeline());
  const double dt = sim->model().opt.timestep;
  r.fallen = scenario.fell_at_s() >= 0;
  r.time_fallen_s = scenario.fell_at_s();
  r.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  r.simulated_s = r.steps * dt;
  r.realtime_factor = r.wall_s > 0 ? r.simulated_s / r.wall_s : 0;
  r.survived_push = params.config.pose_push.has_value() && !r.fallen &&
                    r.max_foot_displacement_m < kNoStepFootMove_m;
  return r;
}

StandingPushScan scan_standing_push(sim::Simulation* sim, const PoseRunParams& base,
                                    double direction_deg, const PushScanParams& scan,
                                    const std::function<void(double)>& progress) {
  if (!(scan.resolution_N > 0)) {
    std::ostringstream msg;
    msg << "push scan resolution: must be > 0 N, got " << scan.resolution_N;
    throw sim::InvalidArgument(msg.str());
  }
  if (!(scan.max_force_N >= scan.resolution_N)) {
    std::ostringstream msg;
    msg << "push scan max force: must be >= the resolution, got " << scan.max_force_N << " N";
    throw sim::InvalidArgument(msg.str());
  }
  StandingPushScan out;
  out.direction_deg = direction_deg;
  out.weld = controllers::to_string(base.config.weld);
  PoseRunParams run = base;
  run.config.scenario = "stand";
  run.trace = nullptr;
  run.config.pose_duration_s = scan.onset_s + scan.duration_s + scan.settle_s;
  const int n = static_cast<int>(std::floor(scan.max_force_N / scan.resolution_N + 1e-9));
  for (int i = 1; i <= n; ++i) {
    TimedPush push;
    push.force_N = i * scan.resolution_N;
    push.duration_s = scan.duration_s;
    push.direction_deg = direction_deg;
    push.onset_s = scan.onset_s;
    push.body = scan.body;
    run.config.pose_push = push;
    const PoseRunResult r = run_pose(sim, run);
    ++out.runs;
    if (!r.survived_push) {
      out.first_failure_N = push.force_N;
      out.failure = r.fallen
                        ? "fell"
                        : "feet moved " +
                              std::to_string(r.max_foot_displacement_m * 100).substr(0, 4) + " cm";
      break;
    }
    out.max_survived_N = push.force_N;
    if (progress) progress(static_cast<double>(i) / n);
  }
  if (progress) progress(1.0);
  return out;
}

}  // namespace biodyn::scenarios
