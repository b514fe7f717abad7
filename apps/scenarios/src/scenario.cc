// The scenario interface and its configuration (scenario.h).
#include "biodyn/scenarios/scenario.h"

#include "biodyn/mocap_io/inverse_dynamics.h"

#include <cmath>
#include <sstream>

#include "biodyn/controllers/torque_walker.h"
#include "biodyn/scenarios/registry.h"
#include "biodyn/sim/errors.h"
#include "checks.h"

namespace biodyn::scenarios {
namespace {

void refuse_unless(bool allowed, const std::string& what) {
  if (!allowed) throw sim::InvalidArgument(what);
}

}  // namespace

void check_walk_speed(double m_s) {
  if (!(m_s >= kMinWalkSpeed_m_s && m_s <= kMaxWalkSpeed_m_s))
    fail("speed", "must be in [0.3, 2] m/s", m_s);
}

void check_heading_rate(double deg_s) {
  if (!(std::abs(deg_s) <= kMaxHeadingRate_deg_s))
    fail("heading-rate", "must be within +-90 deg/s", deg_s);
}

std::vector<double> paper_stepping_stones_m() { return {0.60, 0.20, 0.50, 0.16, 0.50, 0.30}; }

JointLoadReport joint_load_report(const mjModel& m, const sim::JointLoadStats& stats) {
  const std::vector<std::string> names = mocap_io::dof_names(m);
  const auto name_of = [&](int dof) {
    return dof >= 0 ? names[static_cast<std::size_t>(dof)] : std::string();
  };
  JointLoadReport r;
  r.stop_peak_Nm = stats.stop_peak_Nm;
  r.stop_peak_dof = name_of(stats.stop_peak_dof);
  r.load_peak_ratio = stats.load_peak_ratio;
  r.load_peak_dof = name_of(stats.load_peak_dof);
  r.over_s = static_cast<double>(stats.over_steps) * m.opt.timestep;
  r.over_longest_s = static_cast<double>(stats.over_longest) * m.opt.timestep;
  r.over_longest_dof = name_of(stats.over_longest_dof);
  return r;
}

std::optional<MuscleRunReport> muscle_report(const controllers::ControlPipeline& pipeline) {
  if (pipeline.muscles() == nullptr) return std::nullopt;
  const muscles::MuscleDrive& drive = *pipeline.muscles();
  const muscles::MuscleDriveState& s = drive.state();
  const mjModel& m = pipeline.simulation().model();
  MuscleRunReport r;
  for (const muscles::MuscleParams& p : drive.set().params()) {
    r.muscles.push_back(p.name);
    (p.tendon == muscles::TendonModel::kCompliant ? r.compliant_tendons : r.rigid_tendons) += 1;
  }
  const std::vector<int>& dofs = drive.set().covered_dofs();
  // Per anatomical joint (the rig's joint groups: the ankle's two hinges together).
  const auto joint_of = [&](int dof) {
    for (const models::JointGroup& g : pipeline.rig().groups())
      if (dof >= g.dof_begin && dof < g.dof_begin + g.dof_count) return g.name;
    return std::string(mj_id2name(&m, mjOBJ_JOINT, m.dof_jntid[dof]));
  };
  for (std::size_t k = 0; k < dofs.size(); ++k) {
    const std::string name = joint_of(dofs[k]);
    if (r.joints.empty() || r.joints.back().joint != name) r.joints.push_back({name});
    MuscleJointShare& j = r.joints.back();
    j.muscle_Nms += s.muscle_impulse_Nms[k];
    j.backup_Nms += s.backup_impulse_Nms[k];
    j.not_given_Nms += s.missing_impulse_Nms[k];
  }
  r.qp_failures = s.qp_failures;
  r.fiber_solve_failures = s.fiber_failures;
  return r;
}

models::CharacterSpec ScenarioConfig::model_spec() const {
  models::CharacterSpec spec = character;
  spec.muscles = spec.muscles || muscles.on;
  return spec;
}

controllers::ControlPipelineConfig ScenarioConfig::pipeline_config() const {
  controllers::ControlPipelineConfig p;
  p.kind = controller;
  p.weld.mode = weld;
  if (muscles.on) {
    const models::Character c = models::generate_character(model_spec());
    p.muscles = muscles::muscle_params(c.muscles, muscles.tendons);
    if (!muscles.params_json.empty())
      muscles::apply_muscle_overrides(muscles.params_json, muscles.params_source, &p.muscles);
    p.muscle_drive = muscles.drive;
  }
  return p;
}

controllers::TorqueWalkerParams ScenarioConfig::walker_params() const {
  controllers::TorqueWalkerParams p = controllers::walker_defaults(walker_actuation);
  if (!gait_json.empty()) controllers::apply_torque_walker_json(gait_json, gait_source, &p);
  return p;
}

void ScenarioConfig::validate() const {
  check_scenario_name(scenario);
  const bool pose = is_pose_scenario(scenario), mocap = scenario == "mocap";
  if (reaction_time_s != 0 && !(reaction_time_s >= 0.001 && reaction_time_s <= 2.0))
    fail("reaction-time", "must be in [0.001, 2] s", reaction_time_s);
  // Pose scenarios.
  if (!(pose_duration_s >= 0) || !std::isfinite(pose_duration_s))
    fail("duration", "must be >= 0 s", pose_duration_s);
  refuse_unless(pose || (pose_duration_s == 0 && !pose_push),
                "pose duration/push: only the pose scenarios");
  if (pose_push) {
    const TimedPush& p = *pose_push;
    if (!(p.force_N >= 0) || !std::isfinite(p.force_N))
      fail("push force", "must be >= 0 N", p.force_N);
    if (!(p.duration_s > 0) || !std::isfinite(p.duration_s))
      fail("push duration", "must be > 0 s", p.duration_s);
    if (!std::isfinite(p.direction_deg)) fail("push direction", "must be finite", p.direction_deg);
    if (!(p.onset_s >= 0)) fail("push onset", "must be >= 0 s", p.onset_s);
  }
  // Walking.
  check_walk_speed(speed_m_s);
  check_heading_rate(heading_rate_deg_s);
  refuse_unless(steps_m.empty() || scenario == "stones",
                "steps: only the stones scenario walks planned steps");
  if (steps_m.size() > 1000)
    fail("steps", "at most 1000 step lengths", static_cast<double>(steps_m.size()));
  terrain.validate();
  refuse_unless(steps_lateral_m.empty() || steps_lateral_m.size() == steps_m.size(),
                "step offsets: one per step length");
  for (std::size_t i = 0; i < steps_lateral_m.size(); ++i) {
    if (!(std::abs(steps_lateral_m[i]) <= 0.3))
      fail("step offset " + std::to_string(i + 1), "must be within +-0.3 m", steps_lateral_m[i]);
  }
  controllers::TorqueWalker::validate_plan(steps_m);
  // The walker's parameters too, before any run (a sweep's workers would each fail later).
  if (!gait_json.empty()) walker_params();
  if (!(steps_start_s >= 0) || !std::isfinite(steps_start_s))
    fail("steps start", "must be a time >= 0 s", steps_start_s);
  if (!std::isfinite(stop_at_s)) fail("stop-at", "must be finite", stop_at_s);
  refuse_unless(walking() || (stop_at_s < 0 && !walk_push),
                "stop/walk push: only the walking scenarios");
  if (walk_push) {
    const WalkPush& p = *walk_push;
    if (!steps_m.empty())
      throw sim::InvalidArgument("steps: stepping stones and a push cannot be combined in one run");
    if (stop_at_s >= 0)
      throw sim::InvalidArgument("stop: stopping and a push cannot be combined in one run");
    if (!(p.force_N >= 0) || !std::isfinite(p.force_N))
      fail("push force", "must be >= 0 N", p.force_N);
    if (!(p.duration_s > 0) || !(p.duration_s <= 10))
      fail("push duration", "must be in (0, 10] s", p.duration_s);
    if (!std::isfinite(p.direction_deg)) fail("push direction", "must be finite", p.direction_deg);
    if (!(p.onset_phase >= 0 && p.onset_phase < 1))
      fail("push onset-phase", "must be in [0, 1)", p.onset_phase);
    if (!(p.settle_strides >= 1 && p.settle_strides <= 100))
      fail("push settle strides", "must be in [1, 100]", p.settle_strides);
    if (!(p.watch_s >= 0 && p.watch_s <= 60)) fail("push watch", "must be in [0, 60] s", p.watch_s);
  }
  // Motion.
  if (track && !mocap) throw sim::InvalidArgument("track: only the mocap scenario tracks a motion");
  if (residual && !track) throw sim::InvalidArgument("residual: only with a tracked motion");
  refuse_unless(!muscles.on || !mocap || track,
                "muscles: a kinematic playback has no controllers for them to drive (mocap "
                "with --track has)");
  tracker.validate();
  if (mocap != !motion_path.empty()) {
    throw sim::InvalidArgument(
        mocap ? "scenario mocap: give the motion (--motion motion.csv or file.bvh)"
              : "--motion: only the mocap scenario plays a motion");
  }
  if ((motion_from_s != 0 || motion_to_s >= 0) && !mocap) {
    throw sim::InvalidArgument("motion from/to: only the mocap scenario plays a motion");
  }
  if (!std::isfinite(motion_from_s) || motion_from_s < 0) {
    throw sim::InvalidArgument("motion from: must be a time >= 0 s, got " +
                               std::to_string(motion_from_s));
  }
  if (!std::isfinite(motion_to_s) || (motion_to_s >= 0 && motion_to_s <= motion_from_s)) {
    throw sim::InvalidArgument("motion to: must be after motion from (" +
                               std::to_string(motion_from_s) + " s), got " +
                               std::to_string(motion_to_s) + " s");
  }
}

Scenario::Scenario(sim::Simulation* sim, ScenarioConfig config)
    : config_(std::move(config)), sim_(sim), rig_(sim->model()) {
  config_.validate();
}

void Scenario::step() {
  const double time_before_s = sim_->data().time;
  const long diverged_before = sim_->warnings().diverged();
  advance();
  ++steps_;
  if (sim_->warnings().diverged() > diverged_before) {
    // MuJoCo has reset the data to the start: the run ends at the divergence, as a fall.
    diverged_at_s_ = time_before_s;
    if (fell_at_s_ < 0) fell_at_s_ = time_before_s;
    return;
  }
  note_fall();
  after_step();
  for (StepObserver* o : observers_) o->on_step(*this);
}

void Scenario::run_until(double t_s) {
  const double dt = sim_->model().opt.timestep;
  while (sim_->data().time < t_s - 0.5 * dt) step();
}

bool Scenario::run_over() const {
  if (finished() || diverged_at_s_ >= 0) return true;
  for (const StepObserver* o : observers_)
    if (o->done()) return true;
  return false;
}

void Scenario::note_fall() {
  if (fell_at_s_ < 0 && fallen()) fell_at_s_ = sim_->data().time;
}

void Scenario::save_common(CommonState* out) const {
  sim_->save(&out->sim);
  out->config = config_;
  out->steps = steps_;
  out->fell_at_s = fell_at_s_;
  out->diverged_at_s = diverged_at_s_;
}

void Scenario::restore_common(const CommonState& in) {
  sim_->restore(in.sim);
  config_ = in.config;
  steps_ = in.steps;
  fell_at_s_ = in.fell_at_s;
  diverged_at_s_ = in.diverged_at_s;
}

controllers::ControllerParams Scenario::controller_params_from_config() const {
  const mjModel& m = sim_->model();
  controllers::ControllerParams p = controllers::default_params(m, rig_.groups());
  if (!config_.controller_json.empty()) {
    controllers::apply_params_file_json(config_.controller_json, config_.controller_source,
                                        rig_.groups(), m.opt.timestep, &p);
  }
  if (config_.reaction_time_s > 0) {
    for (controllers::JointParams& j : p.joints) j.reaction_time_s = config_.reaction_time_s;
  }
  return p;
}

void Scenario::set_controller_params(const controllers::ControllerParams&) {
  throw sim::InvalidArgument("controller parameters: the " + config_.scenario +
                             " scenario has no controllers");
}

void Scenario::set_weld_mode(controllers::WeldMode) {
  throw sim::InvalidArgument("weld: the " + config_.scenario + " scenario has no controllers");
}

void Scenario::set_walker_actuation(controllers::WalkerActuation) {
  throw sim::InvalidArgument("controller: the " + config_.scenario + " scenario does not walk");
}

void Scenario::set_walker_params(const controllers::TorqueWalkerParams&) {
  throw sim::InvalidArgument("walker parameters: the " + config_.scenario +
                             " scenario does not walk");
}

void Scenario::set_speed(double) {
  throw sim::InvalidArgument("speed: the " + config_.scenario + " scenario does not walk");
}

void Scenario::set_heading_rate(double) {
  throw sim::InvalidArgument("heading rate: the " + config_.scenario + " scenario does not walk");
}

void Scenario::push(int body, const Eigen::Vector3d& force_W, double duration_s) {
  if (body < 0 || body >= sim_->model().nbody) throw sim::InvalidArgument("push: no such body");
  const double dt = sim_->model().opt.timestep;
  sim::Push p;
  p.body = body;
  p.force_W = force_W;
  // Whole steps from the next step (simulation.h).
  p.start_s = std::ceil(sim_->data().time / dt - 1e-9) * dt;
  p.duration_s = duration_s;
  sim_->schedule_push(p);
}

}  // namespace biodyn::scenarios
