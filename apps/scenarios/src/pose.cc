#include "biodyn/scenarios/pose.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <sstream>

#include "biodyn/controllers/control_pipeline.h"
#include "biodyn/controllers/controller_params.h"
#include "biodyn/models/rig.h"
#include "biodyn/controllers/poses.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/queries.h"
#include "biodyn/controllers/support_polygon.h"
#include "fall_watch.h"

namespace biodyn::scenarios {
namespace {

using controllers::convex_hull;
using controllers::distance_outside;
using controllers::JointGroup;
using Eigen::Vector2d;

constexpr double kRadToDeg = 180.0 / M_PI;
// Fallen: the pelvis below this fraction of its standing height (references.md: >= 0.7x
// nominal counts as upright while walking; 0.6 leaves room for the squat).
constexpr double kFallenPelvisFraction = 0.6;
// A foot point within this gap of the floor counts as support (a welded or lightly loaded
// sole hovers a fraction of a millimetre above its contact surface in MuJoCo's soft contact).
constexpr double kSupportGap_m = 0.002;
// A push counts as survived without stepping only if no foot moved this far (a standing
// controller never steps, but a foot can slide or pivot away).
constexpr double kNoStepFootMove_m = 0.03;

}  // namespace

void PoseRunParams::validate() const {
  const auto fail = [](const std::string& field, const std::string& rule, double v) {
    std::ostringstream s;
    s << field << ": " << rule << ", got " << v;
    throw sim::InvalidArgument(s.str());
  };
  if (!(duration_s >= 0) || !std::isfinite(duration_s)) fail("duration", "must be >= 0 s", duration_s);
  if (reaction_time_s != 0 && !(reaction_time_s >= 0.001 && reaction_time_s <= 2.0))
    fail("reaction-time", "must be in [0.001, 2] s", reaction_time_s);
  if (push) {
    if (!(push->force_N >= 0) || !std::isfinite(push->force_N))
      fail("push force", "must be >= 0 N", push->force_N);
    if (!(push->duration_s > 0) || !std::isfinite(push->duration_s))
      fail("push duration", "must be > 0 s", push->duration_s);
    if (!std::isfinite(push->direction_deg)) fail("push direction", "must be finite", push->direction_deg);
    if (!(push->onset_s >= 0)) fail("push onset", "must be >= 0 s", push->onset_s);
  }
  if (!(velocity_window_s > 0)) fail("velocity_window_s", "must be > 0 s", velocity_window_s);
}

PoseRunResult run_pose(sim::Simulation* sim, const PoseRunParams& params,
                       const std::function<void(double)>& progress) {
  params.validate();
  const mjModel& m = sim->model();
  mjData& d = sim->data();
  const models::Rig rig(m);
  const std::vector<JointGroup>& groups = rig.groups();
  controllers::ControllerParams cp = controllers::default_params(m, groups);
  if (!params.params_json.empty()) {
    controllers::apply_params_file_json(params.params_json, params.params_source, groups,
                                        m.opt.timestep, &cp);
  }
  if (params.reaction_time_s > 0) {
    for (controllers::JointParams& j : cp.joints) j.reaction_time_s = params.reaction_time_s;
  }
  const std::vector<controllers::Pose> poses =
      controllers::pose_scenario(params.scenario, groups, params.duration_s);
  double total = 0;
  for (const controllers::Pose& p : poses) total += p.duration_s;
  if (params.duration_s > 0) total = params.duration_s;

  sim->reset();
  controllers::ControlPipelineConfig config;
  config.kind = params.kind;
  config.weld.mode = params.weld;
  controllers::ControlPipeline ctrl(sim, rig, cp, config);
  ctrl.reset_in_pose(poses[0]);  // already standing in the first pose at t = 0

  PoseRunResult r;
  r.scenario = params.scenario;
  r.controller = controllers::to_string(params.kind);
  r.weld = controllers::to_string(params.weld);
  r.reaction_time_s = cp.joints.empty() ? 0 : cp.joints.front().reaction_time_s;
  for (const controllers::JointParams& j : cp.joints)
    if (j.reaction_time_s != r.reaction_time_s) r.reaction_time_s = -1;

  const int pelvis = rig.pelvis();
  const FallWatch fall(d, rig, kFallenPelvisFraction);
  const int floor = fall.floor_geom();
  const int foot[2] = {rig.leg(models::kLeft).foot, rig.leg(models::kRight).foot};
  Vector2d foot_start[2];
  for (int s = 0; s < 2; ++s) foot_start[s] = Vector2d(d.xpos[3 * foot[s]], d.xpos[3 * foot[s] + 1]);

  if (params.push) {
    const double a = params.push->direction_deg / kRadToDeg;
    sim::Push push;
    push.body = rig.body(params.push->body);
    if (push.body < 0) {
      throw sim::InvalidArgument("push body: no body named '" + params.push->body + "'");
    }
    push.force_W = params.push->force_N * Eigen::Vector3d(std::cos(a), std::sin(a), 0);
    push.start_s = params.push->onset_s;
    push.duration_s = params.push->duration_s;
    sim->schedule_push(push);
  }

  const double dt = m.opt.timestep;
  const int steps = static_cast<int>(std::lround(total / dt));
  const int report_every = std::max(1, steps / 100);
  std::size_t pose_index = 0;
  double pose_start = d.time;
  bool checked = false;
  std::vector<Vector2d> contact_points, hull;
  contact_points.reserve(64);
  double window_sum = 0;
  int window_samples = 0;
  const int window_steps = std::max(1, static_cast<int>(std::lround(params.velocity_window_s / dt)));
  int weld_active_steps = 0;
  const auto wall_start = std::chrono::steady_clock::now();
  if (params.trace) {
    *params.trace << "time_s,pose,com_x,com_y,com_z,pelvis_z,cp_error_x,cp_error_y,"
                     "sagittal_tilt_rad,frontal_tilt_rad,hip_flexion_rad,weld_l,weld_r,"
                     "weld_fx_l,weld_fy_l,weld_fz_l,weld_fx_r,weld_fy_r,weld_fz_r,"
                     "ground_fz_l,ground_fz_r,tension_excess_l,tension_excess_r,"
                     "max_torque_ratio,saturated_dofs,redone\n";
  }

  for (int step = 0; step < steps; ++step) {
    // Pose schedule.
    while (pose_index + 1 < poses.size() &&
           d.time >= pose_start + poses[pose_index].duration_s - 0.5 * dt) {
      pose_start += poses[pose_index].duration_s;
      ++pose_index;
      ctrl.set_pose(poses[pose_index]);
      checked = false;
    }
    const controllers::StepReport rep = ctrl.step();
    ++r.steps;
    r.warnings += rep.status.new_warnings;
    r.max_torque_ratio = std::max(r.max_torque_ratio, rep.joints.max_torque_ratio);
    r.solver_converged = r.solver_converged && rep.joints.converged;
    if (rep.weld_tension) ++r.weld_tension_steps;
    r.weld_redone_steps += rep.redone > 0 ? 1 : 0;
    for (int s = 0; s < 2; ++s) {
      r.max_weld_force_N = std::max(r.max_weld_force_N, rep.weld[static_cast<std::size_t>(s)].force_W.norm());
      if (rep.weld_active[static_cast<std::size_t>(s)]) ++weld_active_steps;
    }
    if (rep.joints_outside_limits > 0) ++r.joints_outside_limits_steps;
    if (params.trace) {
      const Eigen::Vector3d com = sim::center_of_mass(m, d).position_W;
      const Eigen::Vector2d& e = ctrl.balance().capture_point_error();
      *params.trace << d.time << ',' << poses[pose_index].name << ',' << com.x() << ','
                    << com.y() << ',' << com.z() << ',' << d.xpos[3 * pelvis + 2] << ','
                    << e.x() << ',' << e.y() << ',' << rep.balance.sagittal_tilt << ','
                    << rep.balance.frontal_tilt << ',' << rep.balance.hip_flexion << ','
                    << rep.weld_active[0] << ',' << rep.weld_active[1] << ','
                    << rep.weld[0].force_W.x() << ',' << rep.weld[0].force_W.y() << ','
                    << rep.weld[0].force_W.z() << ',' << rep.weld[1].force_W.x() << ','
                    << rep.weld[1].force_W.y() << ',' << rep.weld[1].force_W.z() << ','
                    << rep.weld[0].ground_force_W.z() << ',' << rep.weld[1].ground_force_W.z()
                    << ',' << rep.weld[0].tension_excess_N << ',' << rep.weld[1].tension_excess_N
                    << ',' << rep.joints.max_torque_ratio << ',' << rep.joints.saturated_dofs
                    << ',' << rep.redone << '\n';
    }

    // Read-outs below use the kinematics and contacts mj_step1 computed for this step (the
    // state one step earlier than d.time): no extra mj_forward in the loop.
    // Target check at the pose's reach time.
    const controllers::Pose& pose = poses[pose_index];
    if (!checked && d.time >= pose_start + pose.reach_time_s - 0.5 * dt) {
      checked = true;
      TargetCheck tc;
      tc.pose = pose.name;
      tc.time_s = d.time;
      for (std::size_t g = 0; g < groups.size(); ++g) {
        const double e = ctrl.orientation_error(static_cast<int>(g)) * kRadToDeg;
        if (e > tc.error_deg) {
          tc.error_deg = e;
          tc.worst_joint = groups[g].name;
        }
        const auto it = pose.angles_rad.find(groups[g].name);
        const Eigen::Vector3d angles = it == pose.angles_rad.end() ? Eigen::Vector3d::Zero() : it->second;
        const Eigen::Quaterniond q_pose = controllers::orientation_from_angles(groups[g], angles);
        const Eigen::Quaterniond q_now = sim::relative_orientation(m, d, groups[g].body);
        tc.pose_error_deg =
            std::max(tc.pose_error_deg, controllers::rotation_angle(q_now.conjugate() * q_pose) * kRadToDeg);
      }
      r.max_orientation_error_deg = std::max(r.max_orientation_error_deg, tc.error_deg);
      r.max_pose_error_deg = std::max(r.max_pose_error_deg, tc.pose_error_deg);
      r.targets.push_back(tc);
    }

    // Fall: a body other than the feet on the floor, or the pelvis down (fall_watch.h).
    const bool down = fall.down(m, d);
    contact_points.clear();
    for (int c = 0; c < d.ncon; ++c) {
      const mjContact& con = d.contact[c];
      const int other = con.geom1 == floor ? con.geom2 : con.geom2 == floor ? con.geom1 : -1;
      if (other < 0 || con.dist > kSupportGap_m) continue;
      if (fall.foot_body(m.geom_bodyid[other])) contact_points.emplace_back(con.pos[0], con.pos[1]);
    }
    if (down && !r.fallen) {
      r.fallen = true;
      r.time_fallen_s = d.time;
    }
    // CoM against the support polygon of the actual contacts.
    if (contact_points.size() >= 3) {
      convex_hull(&contact_points, &hull);
      const Eigen::Vector3d com = sim::center_of_mass(m, d).position_W;
      const double out = distance_outside(hull, com.head<2>());
      if (out > 0) r.com_outside_support_s += dt;
      r.max_com_outside_support_m = std::max(r.max_com_outside_support_m, out);
    }
    for (int s = 0; s < 2; ++s) {
      if (!pose.stance[static_cast<std::size_t>(s)]) continue;
      const Vector2d now(d.xpos[3 * foot[s]], d.xpos[3 * foot[s] + 1]);
      r.max_foot_displacement_m = std::max(r.max_foot_displacement_m, (now - foot_start[s]).norm());
    }
    // Joint-velocity RMS per window.
    for (const JointGroup& g : groups)
      for (int k = 0; k < g.dof_count; ++k) {
        const double v = d.qvel[g.dof_begin + k];
        window_sum += v * v;
        ++window_samples;
      }
    if ((step + 1) % window_steps == 0 || step + 1 == steps) {
      r.joint_velocity_rms.push_back(std::sqrt(window_sum / std::max(window_samples, 1)));
      window_sum = 0;
      window_samples = 0;
    }
    if (progress && (step % report_every == 0 || step + 1 == steps)) {
      progress(static_cast<double>(step + 1) / steps);
    }
  }
  r.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  r.simulated_s = r.steps * dt;
  r.realtime_factor = r.wall_s > 0 ? r.simulated_s / r.wall_s : 0;
  r.weld_active_fraction = r.steps > 0 ? weld_active_steps / (2.0 * r.steps) : 0;
  r.survived_push =
      params.push.has_value() && !r.fallen && r.max_foot_displacement_m < kNoStepFootMove_m;
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
  out.weld = controllers::to_string(base.weld);
  PoseRunParams run = base;
  run.scenario = "stand";
  run.trace = nullptr;
  run.duration_s = scan.onset_s + scan.duration_s + scan.settle_s;
  const int n = static_cast<int>(std::floor(scan.max_force_N / scan.resolution_N + 1e-9));
  for (int i = 1; i <= n; ++i) {
    PosePush push;
    push.force_N = i * scan.resolution_N;
    push.duration_s = scan.duration_s;
    push.direction_deg = direction_deg;
    push.onset_s = scan.onset_s;
    push.body = scan.body;
    run.push = push;
    const PoseRunResult r = run_pose(sim, run);
    ++out.runs;
    if (!r.survived_push) {
      out.first_failure_N = push.force_N;
      out.failure = r.fallen ? "fell" : "feet moved " + std::to_string(r.max_foot_displacement_m * 100).substr(0, 4) + " cm";
      break;
    }
    out.max_survived_N = push.force_N;
    if (progress) progress(static_cast<double>(i) / n);
  }
  if (progress) progress(1.0);
  return out;
}

}  // namespace biodyn::scenarios
