// The mocap scenario: a captured motion played or tracked (mocap_scenario.h).
#include "biodyn/scenarios/mocap_scenario.h"

#include <algorithm>
#include <cctype>
#include <cmath>

#include "biodyn/mocap_io/bvh.h"
#include "biodyn/mocap_io/motion_csv.h"
#include "biodyn/mocap_io/retarget.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/queries.h"
#include "fall_watch.h"

namespace biodyn::scenarios {

struct MocapScenario::State : ScenarioState {
  CommonState common;
  std::size_t bytes() const override { return sizeof(*this) + common.bytes(); }
  controllers::ControlState control;  // tracked only
  controllers::ControllerParams params;
  double playback_time_s = 0;
  TrackingStats stats;
  Eigen::Matrix<double, 6, 1> residual_W = Eigen::Matrix<double, 6, 1>::Zero();
  double residual_moment_Nm = 0;
};

MocapScenario::MocapScenario(sim::Simulation* sim, ScenarioConfig config)
    : Scenario(sim, std::move(config)) {
  load_motion();
  sim->reset();
  fall_ = std::make_unique<FallWatch>(rig_, kWalkingFallPelvisFraction);
  if (config_.track) {
    tracked_ = controllers::make_tracked_motion(sim->model(), rig_, times_, frames_);
    params_ = controller_params_from_config();
    pipeline_ = std::make_unique<controllers::ControlPipeline>(sim, rig_, params_,
                                                               config_.pipeline_config());
    start_tracking();
  } else {
    playback_time_s_ = 0;
    show_playback_frame();
  }
  fall_->start(sim->data());
}

MocapScenario::~MocapScenario() = default;

void MocapScenario::load_motion() {
  const std::string& path = config_.motion_path;
  std::string ext = path.substr(path.find_last_of('.') + 1);
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return std::tolower(c); });
  const mjModel& m = sim_->model();
  mocap_io::Motion motion;
  if (ext == "bvh") {
    motion = mocap_io::retarget_bvh_file(path, config_.character);
  } else {
    motion = mocap_io::read_motion_csv(path);
    mocap_io::check_motion_matches(motion, m, path);
  }
  // The part asked for (motion_from_s..motion_to_s of the motion's own time); unsolved
  // frames (NaN rows) are left out.
  const double t0 = motion.frame_count() > 0 ? motion.times_s.front() : 0.0;
  const double from = t0 + config_.motion_from_s;
  const double to = config_.motion_to_s < 0 ? 1e300 : t0 + config_.motion_to_s;
  std::vector<int> rows;
  for (int f = 0; f < motion.frame_count(); ++f) {
    const double t = motion.times_s[static_cast<std::size_t>(f)];
    if (t >= from - 1e-9 && t <= to + 1e-9 && motion.qpos.row(f).allFinite()) rows.push_back(f);
  }
  if (rows.size() < 2) {
    const double length = motion.frame_count() > 0 ? motion.times_s.back() - t0 : 0.0;
    throw sim::InvalidArgument(
        path + ": fewer than 2 solved frames to play" +
        (config_.motion_from_s != 0 || config_.motion_to_s >= 0
             ? " from " + std::to_string(config_.motion_from_s) + " s to " +
                   (config_.motion_to_s < 0 ? std::string("the end")
                                            : std::to_string(config_.motion_to_s) + " s") +
                   " (the motion is " + std::to_string(length) + " s long)"
             : std::string()));
  }
  if (config_.track && rows.back() - rows.front() + 1 != static_cast<int>(rows.size())) {
    // Tracking needs a motion without gaps in time: solved frames must be consecutive.
    throw sim::InvalidArgument(
        path + ": unsolved frames inside the motion (" +
        std::to_string(motion.frame_count() - static_cast<int>(rows.size())) +
        "); tracking needs a continuous motion (play it kinematically, or trim it)");
  }
  frames_.resize(static_cast<Eigen::Index>(rows.size()), m.nq);
  times_.clear();
  for (std::size_t i = 0; i < rows.size(); ++i) {
    frames_.row(static_cast<Eigen::Index>(i)) = motion.qpos.row(rows[i]);
    times_.push_back(motion.times_s[static_cast<std::size_t>(rows[i])] -
                     motion.times_s[static_cast<std::size_t>(rows.front())]);
  }
}

void MocapScenario::show_playback_frame() {
  // The frame at or before playback_time_s_ (looping): kinematic, as captured.
  const double length = times_.back();
  const double t = length > 0 ? std::fmod(playback_time_s_, length) : 0.0;
  const auto it = std::upper_bound(times_.begin(), times_.end(), t);
  const Eigen::Index f = std::max<Eigen::Index>(0, (it - times_.begin()) - 1);
  mjData& d = sim_->data();
  for (int k = 0; k < sim_->model().nq; ++k) d.qpos[k] = frames_(f, k);
  mju_zero(d.qvel, sim_->model().nv);
  d.time = playback_time_s_;
  mj_forward(&sim_->model(), &d);
}

void MocapScenario::start_tracking() {
  // The first frame (floored: make_tracked_motion), moving as the motion does.
  const mjModel& m = sim_->model();
  mjData& d = sim_->data();
  // The velocity over the first kVelocityWindow_s (frame-to-frame differences carry the
  // capture's jitter: motion_tracker.h).
  const std::size_t f1 =
      std::max<std::size_t>(1, tracked_.frame_at(controllers::TrackedMotion::kVelocityWindow_s));
  std::vector<mjtNum> q0(static_cast<std::size_t>(m.nq)), q1(static_cast<std::size_t>(m.nq));
  for (int k = 0; k < m.nq; ++k) {
    q0[static_cast<std::size_t>(k)] = tracked_.qpos(0, k);
    q1[static_cast<std::size_t>(k)] = tracked_.qpos(static_cast<Eigen::Index>(f1), k);
  }
  // A foot swinging with its toes on the floor starts clear of it (the same lift in both poses
  // leaves its velocity the motion's).
  for (int s = 0; s < 2; ++s) {
    const int adr =
        m.jnt_qposadr
            [m.dof_jntid[rig_.groups()[static_cast<std::size_t>(rig_.leg(s).ankle)].dof_begin]];
    q0[static_cast<std::size_t>(adr)] += tracked_.start_swing_lift_rad[static_cast<std::size_t>(s)];
    q1[static_cast<std::size_t>(adr)] += tracked_.start_swing_lift_rad[static_cast<std::size_t>(s)];
  }
  std::copy(q0.begin(), q0.end(), d.qpos);
  mj_differentiatePos(&m, d.qvel, tracked_.times_s[f1] - tracked_.times_s[0], q0.data(), q1.data());
  mj_forward(&m, &d);
  pipeline_->reset();
  tracker_ = std::make_unique<controllers::MotionTracker>(m, rig_, &tracked_, config_.tracker);
  pipeline_->set_driver(tracker_.get());
  residual_pose_.assign(static_cast<std::size_t>(m.nq), 0.0);
  residual_pose_next_.assign(static_cast<std::size_t>(m.nq), 0.0);
  body_mass_kg_ = mj_getTotalmass(&m);
  load_meter_ = std::make_unique<sim::JointLoadMeter>(m, models::judged_tau_max(m, rig_.groups()));
}

bool MocapScenario::fallen() const {
  if (playback()) return false;  // a captured motion is shown as it is
  return fall_->down(sim_->model(), sim_->data());
}

void MocapScenario::advance() {
  if (playback()) {
    playback_time_s_ = static_cast<double>(steps_ + 1) * sim_->model().opt.timestep;
    show_playback_frame();
    return;
  }
  if (config_.residual) apply_residual();
  pipeline_->step();
}

void MocapScenario::apply_residual() {
  // A critically damped 2 Hz pull of the pelvis to the motion's root (position and orientation),
  // scaled by the body's mass and a whole-body inertia of mass x (0.2 m)^2: strong enough to
  // carry what the kinematics get wrong, weak enough to leave the joints their work.
  constexpr double kOmega = 2 * M_PI * 2.0, kRadiusSq_m2 = 0.04, kDt_s = 0.01;
  const mjModel& m = sim_->model();
  mjData& d = sim_->data();
  controllers::motion_pose_at(m, tracked_, d.time, residual_pose_.data());
  controllers::motion_pose_at(m, tracked_, d.time + kDt_s, residual_pose_next_.data());
  const int joint = rig_.root_joint();
  const auto a = static_cast<std::size_t>(m.jnt_qposadr[joint]);
  const int v = m.jnt_dofadr[joint];
  const double* want = residual_pose_.data() + a;
  const double* next = residual_pose_next_.data() + a;
  const Eigen::Vector3d position(d.qpos[a], d.qpos[a + 1], d.qpos[a + 2]);
  const Eigen::Vector3d velocity(d.qvel[v], d.qvel[v + 1], d.qvel[v + 2]);
  const Eigen::Vector3d want_position(want[0], want[1], want[2]);
  const Eigen::Vector3d want_velocity =
      (Eigen::Vector3d(next[0], next[1], next[2]) - want_position) / kDt_s;
  const Eigen::Quaterniond q(d.qpos[a + 3], d.qpos[a + 4], d.qpos[a + 5], d.qpos[a + 6]);
  const Eigen::Quaterniond q_want(want[3], want[4], want[5], want[6]);
  const Eigen::Quaterniond q_next(next[3], next[4], next[5], next[6]);
  const auto rotation = [](const Eigen::Quaterniond& r) {  // world-frame rotation vector
    const Eigen::AngleAxisd aa(r.normalized());
    const double angle = aa.angle() > M_PI ? aa.angle() - 2 * M_PI : aa.angle();
    return Eigen::Vector3d(angle * aa.axis());
  };
  // The free joint's angular velocity is in the body frame (MuJoCo).
  const Eigen::Vector3d omega =
      q.normalized() * Eigen::Vector3d(d.qvel[v + 3], d.qvel[v + 4], d.qvel[v + 5]);
  const Eigen::Vector3d want_omega = rotation(q_next * q_want.conjugate()) / kDt_s;
  const double kp = kOmega * kOmega, kd = 2 * kOmega;
  // The wrench about the root's origin (where its error is measured; mocap id's root residual
  // is the same), written as xfrc_applied, which acts at the pelvis's CoM: moment - r x F.
  const Eigen::Vector3d force =
      body_mass_kg_ * (kp * (want_position - position) + kd * (want_velocity - velocity));
  const Eigen::Vector3d moment =
      body_mass_kg_ * kRadiusSq_m2 *
      (kp * rotation(q_want * q.conjugate()) + kd * (want_omega - omega));
  const int pelvis = rig_.pelvis();
  const Eigen::Vector3d com_offset_W =
      q.normalized() * Eigen::Vector3d(m.body_ipos[3 * pelvis], m.body_ipos[3 * pelvis + 1],
                                       m.body_ipos[3 * pelvis + 2]);
  Eigen::Matrix<double, 6, 1> w;
  w << force, moment - com_offset_W.cross(force);
  mjtNum* f = d.xfrc_applied + 6 * pelvis;
  for (int k = 0; k < 6; ++k) f[k] += w(k) - residual_W_(k);
  residual_W_ = w;
  residual_moment_Nm_ = moment.norm();
}

void MocapScenario::after_step() {
  // Tracking error while upright and while the motion lasts (after it, the targets hold its
  // last frame).
  if (!tracker_ || fell_at_s_ >= 0 || sim_->data().time > motion_length_s() + 1e-9) return;
  load_meter_->measure(sim_->model(), sim_->data(), &stats_.load);
  if (config_.residual) {
    const double force = residual_W_.head<3>().norm(), moment = residual_moment_Nm_;
    ++stats_.residual_steps;
    stats_.residual_force_sum_sq += force * force;
    stats_.residual_moment_sum_sq += moment * moment;
    stats_.residual_force_peak_N = std::max(stats_.residual_force_peak_N, force);
    stats_.residual_moment_peak_Nm = std::max(stats_.residual_moment_peak_Nm, moment);
  }
  if (steps_ % 10 != 0) return;
  const controllers::MotionTracker::Error e = tracker_->error(sim_->model(), sim_->data());
  ++stats_.samples;
  stats_.joint_sum_sq_rad2 += e.joint_rms_rad * e.joint_rms_rad;
  stats_.joint_max_rad = std::max(stats_.joint_max_rad, e.joint_rms_rad);
  stats_.root_max_m = std::max(stats_.root_max_m, e.root_horizontal_m);
}

controllers::MotionTracker::Error MocapScenario::tracking_error() const {
  if (!tracker_) return {};
  return tracker_->error(sim_->model(), sim_->data());
}

TrackingReport MocapScenario::tracking_report() const {
  TrackingReport r;
  r.tracked = tracker_ != nullptr;
  if (!r.tracked) return r;
  r.balance = config_.tracker.balance;
  r.motion_length_s = motion_length_s();
  r.lookahead_s = config_.tracker.lookahead_s;
  r.start_lift_m = tracked_.start_lift_m;
  r.start_swing_lift_rad = tracked_.start_swing_lift_rad;
  r.start_swing_clearance_m = tracked_.start_swing_clearance_m;
  r.fell_at_s = fell_at_s_;
  r.stats = stats_;
  return r;
}

const controllers::ControllerParams* MocapScenario::controller_params() const {
  return pipeline_ ? &params_ : nullptr;
}

void MocapScenario::set_controller_params(const controllers::ControllerParams& params) {
  if (!pipeline_) Scenario::set_controller_params(params);  // throws: a playback has none
  pipeline_->set_params(params);
  params_ = params;
}

void MocapScenario::set_weld_mode(controllers::WeldMode mode) {
  if (!pipeline_) Scenario::set_weld_mode(mode);  // throws
  pipeline_->set_weld_mode(mode);
  config_.weld = mode;
}

void MocapScenario::push(int body, const Eigen::Vector3d& force_W, double duration_s) {
  if (playback())
    throw sim::InvalidArgument("push: the mocap scenario plays its motion kinematically");
  Scenario::push(body, force_W, duration_s);
}

std::unique_ptr<ScenarioState> MocapScenario::new_state() const {
  return std::make_unique<State>();
}

void MocapScenario::save(ScenarioState* out) const {
  State& s = static_cast<State&>(*out);
  save_common(&s.common);
  if (pipeline_) {
    s.control = pipeline_->state();
    s.params = params_;
  }
  s.playback_time_s = playback_time_s_;
  s.stats = stats_;
  s.residual_W = residual_W_;
  s.residual_moment_Nm = residual_moment_Nm_;
}

void MocapScenario::restore(const ScenarioState& in) {
  const State& s = static_cast<const State&>(in);
  if (pipeline_) {
    set_controller_params(s.params);
    pipeline_->set_weld_mode(s.common.config.weld);
  }
  restore_common(s.common);
  if (pipeline_) pipeline_->restore(s.control);
  playback_time_s_ = s.playback_time_s;
  stats_ = s.stats;
  residual_W_ = s.residual_W;  // xfrc_applied (restored with the data) holds it
  residual_moment_Nm_ = s.residual_moment_Nm;
}

}  // namespace biodyn::scenarios
