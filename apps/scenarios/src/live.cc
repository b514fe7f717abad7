// A scenario stepped from outside with live edits and exact rewind (live.h).
#include "biodyn/scenarios/live.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <nlohmann/json.hpp>
#include <optional>

#include "biodyn/controllers/joint_groups.h"
#include "biodyn/controllers/poses.h"
#include "biodyn/mocap_io/bvh.h"
#include "biodyn/mocap_io/motion_csv.h"
#include "biodyn/mocap_io/retarget.h"
#include "biodyn/models/mjcf.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/model.h"
#include "fall_watch.h"

namespace biodyn::scenarios {
namespace {

constexpr double kRadPerDeg = 3.14159265358979323846 / 180.0;

// The walker's command ranges, for the config and for live edits alike.
void check_speed(double m_s) {
  if (!std::isfinite(m_s) || m_s < 0 || m_s > 3) {
    throw sim::InvalidArgument("speed: must be within [0, 3] m/s, got " + std::to_string(m_s));
  }
}

void check_heading_rate(double deg_s) {
  if (!std::isfinite(deg_s) || std::abs(deg_s) > 90) {
    throw sim::InvalidArgument("heading rate: must be within [-90, 90] deg/s, got " + std::to_string(deg_s));
  }
}
/// references.md: upright = pelvis >= 0.7 x its standing height (and only the feet touch the
/// floor: FallWatch).
constexpr double kFallenPelvisFraction = 0.7;

}  // namespace

/// The whole state of a LiveScenario at one step (live.h: rewind).
struct LiveScenario::Checkpoint {
  long step = -1;  // -1: free (or dropped by a new edit)
  sim::Simulation::Checkpoint sim;
  controllers::ControlState controller;
  controllers::TorqueWalkerState gait;
  RunState run;
};

std::vector<double> paper_stepping_stones_m() { return {0.60, 0.20, 0.50, 0.16, 0.50, 0.30}; }

std::vector<std::string> live_scenario_names() {
  std::vector<std::string> names = controllers::pose_scenario_names();
  names.push_back("walk");
  names.push_back("stones");
  names.push_back("mocap");
  return names;
}

void LiveConfig::validate() const {
  const std::vector<std::string> names = live_scenario_names();
  if (std::find(names.begin(), names.end(), scenario) == names.end()) {
    std::string list;
    for (const std::string& n : names) list += (list.empty() ? "" : ", ") + n;
    throw sim::InvalidArgument("scenario: expected one of " + list + ", got '" + scenario + "'");
  }
  if (track && scenario != "mocap") throw sim::InvalidArgument("track: only the mocap scenario tracks a motion");
  tracker.validate();
  if ((scenario == "mocap") != !motion_path.empty()) {
    throw sim::InvalidArgument(scenario == "mocap"
                                   ? "scenario mocap: give the motion (--motion motion.csv or file.bvh)"
                                   : "--motion: only the mocap scenario plays a motion");
  }
  if ((motion_from_s != 0 || motion_to_s >= 0) && scenario != "mocap") {
    throw sim::InvalidArgument("motion from/to: only the mocap scenario plays a motion");
  }
  if (!std::isfinite(motion_from_s) || motion_from_s < 0) {
    throw sim::InvalidArgument("motion from: must be a time >= 0 s, got " + std::to_string(motion_from_s));
  }
  if (!std::isfinite(motion_to_s) || (motion_to_s >= 0 && motion_to_s <= motion_from_s)) {
    throw sim::InvalidArgument("motion to: must be after motion from (" + std::to_string(motion_from_s) + " s), got " +
                               std::to_string(motion_to_s) + " s");
  }
  if (!steps_m.empty() && scenario != "stones") {
    throw sim::InvalidArgument("steps: only the stones scenario walks planned steps");
  }
  controllers::TorqueWalker::validate_plan(steps_m);
  if (!(steps_start_s >= 0) || !std::isfinite(steps_start_s)) {
    throw sim::InvalidArgument("steps start: must be a time >= 0 s, got " + std::to_string(steps_start_s));
  }
  check_speed(speed_m_s);
  check_heading_rate(heading_rate_deg_s);
}

LiveScenario::LiveScenario(LiveConfig config) {
  run_.config = std::move(config);
  run_.config.validate();
  if (run_.config.scenario == "stones" && run_.config.steps_m.empty()) run_.config.steps_m = paper_stepping_stones_m();
  const models::Character character = models::generate_character(run_.config.character);
  sim_ = std::make_unique<sim::Simulation>(
      sim::Model::from_string(models::to_mjcf(character), "generated character"));
  const mjModel& m = sim_->model();
  rig_ = std::make_unique<models::Rig>(m);
  const std::vector<controllers::JointGroup>& groups = rig_->groups();
  run_.controller_params = controllers::default_params(m, groups);
  if (!run_.config.controller_json.empty()) {
    controllers::apply_params_file_json(run_.config.controller_json, run_.config.controller_source,
                                        groups, m.opt.timestep, &run_.controller_params);
  }
  if (!run_.config.gait_json.empty()) {
    controllers::apply_torque_walker_json(run_.config.gait_json, run_.config.gait_source, &run_.gait_params);
  }
  if (run_.config.scenario == "mocap") {
    load_motion(m);
    if (run_.config.track) tracked_ = controllers::make_tracked_motion(m, *rig_, playback_t_, playback_);
  }
  initial_config_ = run_.config;
  initial_controller_params_ = run_.controller_params;
  initial_gait_params_ = run_.gait_params;
  stones_ = run_.config.scenario == "stones";
  checkpoint_every_ = std::max(1L, std::lround(kCheckpointInterval_s / m.opt.timestep));
  for (int i = 0; i < kCheckpoints; ++i) checkpoints_.push_back(std::make_unique<Checkpoint>());
  build();
}

LiveScenario::~LiveScenario() = default;

void LiveScenario::load_motion(const mjModel& m) {
  const std::string& path = run_.config.motion_path;
  std::string ext = path.substr(path.find_last_of('.') + 1);
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  mocap_io::Motion motion;
  if (ext == "bvh") {
    const mocap_io::BvhMotion bvh = mocap_io::read_bvh(path);
    std::string tried;
    for (const std::string& name : mocap_io::builtin_joint_map_names()) {
      const mocap_io::JointMap map = mocap_io::builtin_joint_map(name);
      try {
        mocap_io::resolve_joint_map(map, bvh, path);
      } catch (const sim::InvalidArgument& e) {
        tried += std::string(" ") + e.what();
        continue;
      }
      mocap_io::RetargetOptions options;
      options.source = path;
      motion = mocap_io::retarget_bvh(bvh, map, run_.config.character, options).motion;
      break;
    }
    if (motion.frame_count() == 0) {
      throw sim::InvalidArgument(path + ": no built-in joint map fits this BVH (retarget it with "
                                        "biodyn mocap retarget --map, then play motion.csv):" + tried);
    }
  } else {
    motion = mocap_io::read_motion_csv(path);
    mocap_io::check_motion_matches(motion, m, path);
  }
  // The part asked for (motion_from_s..motion_to_s of the motion's own time); unsolved
  // frames (NaN rows) are left out.
  const double t0 = motion.frame_count() > 0 ? motion.times_s.front() : 0.0;
  const double from = t0 + run_.config.motion_from_s;
  const double to = run_.config.motion_to_s < 0 ? 1e300 : t0 + run_.config.motion_to_s;
  std::vector<int> rows;
  for (int f = 0; f < motion.frame_count(); ++f) {
    const double t = motion.times_s[static_cast<std::size_t>(f)];
    if (t >= from - 1e-9 && t <= to + 1e-9 && motion.qpos.row(f).allFinite()) rows.push_back(f);
  }
  if (rows.size() < 2) {
    const double length = motion.frame_count() > 0 ? motion.times_s.back() - t0 : 0.0;
    throw sim::InvalidArgument(path + ": fewer than 2 solved frames to play" +
                               (run_.config.motion_from_s != 0 || run_.config.motion_to_s >= 0
                                    ? " from " + std::to_string(run_.config.motion_from_s) + " s to " +
                                          (run_.config.motion_to_s < 0 ? std::string("the end")
                                                                       : std::to_string(run_.config.motion_to_s) + " s") +
                                          " (the motion is " + std::to_string(length) + " s long)"
                                    : std::string()));
  }
  if (run_.config.track) {
    // Tracking needs a motion without gaps in time: solved frames must be consecutive.
    if (rows.back() - rows.front() + 1 != static_cast<int>(rows.size())) {
      throw sim::InvalidArgument(path + ": unsolved frames inside the motion (" +
                                 std::to_string(motion.frame_count() - static_cast<int>(rows.size())) +
                                 "); tracking needs a continuous motion (play it kinematically, or trim it)");
    }
  }
  playback_.resize(static_cast<Eigen::Index>(rows.size()), m.nq);
  playback_t_.clear();
  for (std::size_t i = 0; i < rows.size(); ++i) {
    playback_.row(static_cast<Eigen::Index>(i)) = motion.qpos.row(rows[i]);
    playback_t_.push_back(motion.times_s[static_cast<std::size_t>(rows[i])] -
                          motion.times_s[static_cast<std::size_t>(rows.front())]);
  }
}

void LiveScenario::show_playback_frame() {
  // The frame at or before run_.playback_time_s (looping): kinematic, as captured.
  const double length = playback_t_.back();
  const double t = length > 0 ? std::fmod(run_.playback_time_s, length) : 0.0;
  const auto it = std::upper_bound(playback_t_.begin(), playback_t_.end(), t);
  const Eigen::Index f = std::max<Eigen::Index>(0, (it - playback_t_.begin()) - 1);
  mjData& d = sim_->data();
  for (int k = 0; k < sim_->model().nq; ++k) d.qpos[k] = playback_(f, k);
  mju_zero(d.qvel, sim_->model().nv);
  d.time = run_.playback_time_s;
  mj_forward(&sim_->model(), &d);
}

void LiveScenario::build() {
  // The same set-up as run_walk and run_pose: standing in the first pose at t = 0.
  gait_.reset();
  ctrl_.reset();
  sim_->reset();
  const mjModel& m = sim_->model();
  controllers::ControlPipelineConfig cc;
  cc.weld.mode = run_.config.weld;
  ctrl_ = std::make_unique<controllers::ControlPipeline>(sim_.get(), *rig_, run_.controller_params, cc);
  const std::vector<controllers::JointGroup>& groups = rig_->groups();
  if (run_.config.scenario == "walk" || run_.config.scenario == "stones") {
    poses_ = controllers::pose_scenario("stand", groups, 0);
    ctrl_->reset_in_pose(poses_.front());
    gait_ = std::make_unique<controllers::TorqueWalker>(*rig_, run_.gait_params);
    gait_->reset(sim_->data());
    gait_->set_speed(run_.config.speed_m_s);
    gait_->set_heading_rate(run_.config.heading_rate_deg_s * kRadPerDeg);
    ctrl_->set_driver(gait_.get());
  } else if (run_.config.scenario == "mocap" && run_.config.track) {
    start_tracking();
  } else if (run_.config.scenario == "mocap") {
    run_.playback_time_s = 0;
    show_playback_frame();
  } else {
    poses_ = controllers::pose_scenario(run_.config.scenario, groups, 0);
    ctrl_->reset_in_pose(poses_.front());
  }
  run_.pose_index = 0;
  run_.pose_start_s = 0;
  run_.steps = 0;
  run_.stones.clear();
  run_.stones_planned = run_.stone_pending = false;
  run_.strikes_seen = 0;
  run_.tracking_stats = TrackingStats{};
  run_.fell_at_s = -1;
  fall_ = std::make_unique<FallWatch>(sim_->data(), *rig_, kFallenPelvisFraction);
}

void LiveScenario::start_tracking() {
  // The first frame (floored: make_tracked_motion), moving as the motion does.
  const mjModel& m = sim_->model();
  mjData& d = sim_->data();
  // The velocity over the first kVelocityWindow_s (frame-to-frame differences carry the
  // capture's jitter: motion_tracker.h).
  const std::size_t f1 = std::max<std::size_t>(1, tracked_.frame_at(controllers::TrackedMotion::kVelocityWindow_s));
  std::vector<mjtNum> q0(static_cast<std::size_t>(m.nq)), q1(static_cast<std::size_t>(m.nq));
  for (int k = 0; k < m.nq; ++k) {
    q0[static_cast<std::size_t>(k)] = tracked_.qpos(0, k);
    q1[static_cast<std::size_t>(k)] = tracked_.qpos(static_cast<Eigen::Index>(f1), k);
  }
  std::copy(q0.begin(), q0.end(), d.qpos);
  mj_differentiatePos(&m, d.qvel, tracked_.times_s[f1] - tracked_.times_s[0], q0.data(), q1.data());
  mj_forward(&m, &d);
  ctrl_->reset();
  tracker_ = std::make_unique<controllers::MotionTracker>(m, *rig_, &tracked_, run_.config.tracker);
  ctrl_->set_driver(tracker_.get());
}

controllers::MotionTracker::Error LiveScenario::tracking_error() const {
  if (!tracker_) return {};
  return tracker_->error(sim_->model(), sim_->data());
}

LiveScenario::TrackingReport LiveScenario::tracking_report() const {
  TrackingReport r;
  r.tracked = tracker_ != nullptr;
  if (!r.tracked) return r;
  r.balance = run_.config.tracker.balance;
  r.motion_length_s = motion_length_s();
  r.lookahead_s = run_.config.tracker.lookahead_s;
  r.start_lift_m = tracked_.start_lift_m;
  r.fell_at_s = run_.fell_at_s;
  r.stats = run_.tracking_stats;
  return r;
}

double LiveScenario::time_s() const { return sim_->data().time; }

bool LiveScenario::fallen() const {
  if (playback()) return false;  // a captured motion is shown as it is
  return fall_->down(sim_->model(), sim_->data());
}

void LiveScenario::step() {
  // After a rewind, the edits the run had made from here on come back at their steps.
  while (future_next_ < future_.size() && future_[future_next_].step == run_.steps) {
    pending_.push_back(future_[future_next_++]);
  }
  if (!pending_.empty()) {
    for (Edit& e : pending_) {
      e.step = run_.steps;
      e.apply(*this);
      log_.push_back(std::move(e));
    }
    pending_.clear();
  }
  const double dt = sim_->model().opt.timestep;
  if (playback()) {
    run_.playback_time_s = static_cast<double>(run_.steps + 1) * dt;
    show_playback_frame();
    ++run_.steps;
    if (run_.steps % checkpoint_every_ == 0) save_checkpoint();
    return;
  }
  // Pose scenarios: the next pose when this one's time is up; the last one holds.
  if (!gait_) {
    while (run_.pose_index + 1 < poses_.size() &&
           time_s() >= run_.pose_start_s + poses_[run_.pose_index].duration_s - 0.5 * dt) {
      run_.pose_start_s += poses_[run_.pose_index].duration_s;
      ++run_.pose_index;
      ctrl_->set_pose(poses_[run_.pose_index]);
    }
  }
  ctrl_->step();
  ++run_.steps;
  if (stones_) track_stones();
  if (run_.fell_at_s < 0 && fallen()) run_.fell_at_s = time_s();
  // Tracking error while the motion lasts (after it, the targets hold its last frame).
  if (tracker_ && run_.fell_at_s < 0 && run_.steps % 10 == 0 && time_s() <= motion_length_s() + 1e-9) {
    const controllers::MotionTracker::Error e = tracker_->error(sim_->model(), sim_->data());
    TrackingStats& t = run_.tracking_stats;
    ++t.samples;
    t.joint_sum_sq_rad2 += e.joint_rms_rad * e.joint_rms_rad;
    t.joint_max_rad = std::max(t.joint_max_rad, e.joint_rms_rad);
    t.root_max_m = std::max(t.root_max_m, e.root_horizontal_m);
  }
  if (run_.steps % checkpoint_every_ == 0) save_checkpoint();
}

void LiveScenario::track_stones() {
  // As run_walk: the plan starts at the first strike at or after steps_start_s; each strike
  // ends one planned step (its length walked) and begins the next swing.
  const controllers::TorqueWalker& g = *gait_;
  if (g.strike_count() != run_.strikes_seen) {
    run_.strikes_seen = g.strike_count();
    const controllers::TorqueWalkerStrike& st = g.last_strike();
    if (!std::isnan(st.target_length_m) && !run_.stones.empty() && std::isnan(run_.stones.back().walked_m)) {
      run_.stones.back().walked_m = st.step_length_m;
    }
    if (!run_.stones_planned && time_s() >= run_.config.steps_start_s) {
      gait_->plan_steps(run_.config.steps_m);  // from the swing that starts now
      run_.stones.reserve(run_.config.steps_m.size());
      run_.stones_planned = true;
    }
    run_.stone_pending = run_.stones_planned;
  }
  if (std::isnan(g.swing_target_m())) return;
  // The swing's stone, from the walker's reference: the stance ankle (which rolls forward a
  // little during the swing, so the stone follows it until the strike fixes it), along the
  // heading by the planned length, across as far as the swing ankle was when the swing began.
  const mjData& d = sim_->data();
  const int swing = 1 - g.stance_side();
  const int stance_body = rig_->leg(g.stance_side()).foot;
  const Eigen::Vector2d stance(d.xpos[3 * stance_body], d.xpos[3 * stance_body + 1]);
  const Eigen::Vector2d along(std::cos(g.heading_rad()), std::sin(g.heading_rad()));
  const Eigen::Vector2d across(-along.y(), along.x());
  if (run_.stone_pending) {
    run_.stone_pending = false;
    const int swing_body = rig_->leg(swing).foot;
    const Eigen::Vector2d swing_at(d.xpos[3 * swing_body], d.xpos[3 * swing_body + 1]);
    LiveStone stone;
    stone.side = swing;
    stone.target_m = g.swing_target_m();
    stone.across_m = (swing_at - stance).dot(across);
    run_.stones.push_back(stone);
  }
  LiveStone& stone = run_.stones.back();
  if (!std::isnan(stone.walked_m)) return;
  stone.heading_rad = g.heading_rad();
  stone.ankle_W = stance + stone.target_m * along + stone.across_m * across;
}

void LiveScenario::save_checkpoint() {
  // Once per step index: after a rewind the replay passes checkpoints it already has.
  Checkpoint* slot = nullptr;
  for (const std::unique_ptr<Checkpoint>& c : checkpoints_) {
    if (c->step == run_.steps) return;
    if (slot == nullptr || c->step < slot->step) slot = c.get();  // a free one, else the oldest
  }
  Checkpoint& c = *slot;
  c.step = run_.steps;
  sim_->save(&c.sim);
  c.controller = ctrl_->state();
  if (gait_) c.gait = gait_->state();
  c.run = run_;
}

void LiveScenario::restore_checkpoint(const Checkpoint& c) {
  // The parameters of that moment first (the edits logged before it), then its state.
  ctrl_->set_params(c.run.controller_params);
  ctrl_->set_weld_mode(c.run.config.weld);
  if (gait_) gait_->set_params(c.run.gait_params);
  sim_->restore(c.sim);
  ctrl_->restore(c.controller);
  if (gait_) gait_->restore(c.gait);
  run_ = c.run;
}

std::size_t LiveScenario::checkpoint_bytes() const {
  std::size_t bytes = 0;
  for (const std::unique_ptr<Checkpoint>& c : checkpoints_) {
    if (c->step >= 0) bytes += sizeof(Checkpoint) + c->sim.data.bytes();
  }
  return bytes;
}

void LiveScenario::run_until(double t_s) {
  const double dt = sim_->model().opt.timestep;
  while (time_s() < t_s - 0.5 * dt) step();
}

void LiveScenario::drop_future() {
  future_.clear();
  future_next_ = 0;
  for (const std::unique_ptr<Checkpoint>& c : checkpoints_) {
    if (c->step > run_.steps) c->step = -1;  // states of the dropped future
  }
}

void LiveScenario::record(std::function<void(LiveScenario&)> apply) {
  // A new edit starts a new future: the edits a rewound run would have replayed are dropped.
  drop_future();
  pending_.push_back({run_.steps, std::move(apply)});
}

void LiveScenario::set_controller_params(const controllers::ControllerParams& params) {
  params.validate(sim_->model().opt.timestep);
  record([params](LiveScenario& s) {
    s.run_.controller_params = params;
    s.ctrl_->set_params(params);
  });
}

void LiveScenario::set_gait_params(const controllers::TorqueWalkerParams& params) {
  if (!gait_) throw sim::InvalidArgument("walker parameters: the scenario does not walk");
  params.validate();
  record([params](LiveScenario& s) {
    s.run_.gait_params = params;
    s.gait_->set_params(params);
  });
}

void LiveScenario::set_speed(double m_s) {
  if (!gait_) throw sim::InvalidArgument("speed: the scenario does not walk");
  check_speed(m_s);
  record([m_s](LiveScenario& s) {
    s.run_.config.speed_m_s = m_s;
    s.gait_->set_speed(m_s);
  });
}

void LiveScenario::set_heading_rate(double deg_s) {
  if (!gait_) throw sim::InvalidArgument("heading rate: the scenario does not walk");
  check_heading_rate(deg_s);
  record([deg_s](LiveScenario& s) {
    s.run_.config.heading_rate_deg_s = deg_s;
    s.gait_->set_heading_rate(deg_s * kRadPerDeg);
  });
}

void LiveScenario::set_weld_mode(controllers::WeldMode mode) {
  record([mode](LiveScenario& s) {
    s.run_.config.weld = mode;
    s.ctrl_->set_weld_mode(mode);
  });
}

void LiveScenario::push(const std::string& body, const Eigen::Vector3d& force_W, double duration_s) {
  if (playback()) throw sim::InvalidArgument("push: the mocap scenario plays its motion kinematically");
  const int id = rig_->body(body);
  if (id < 0) throw sim::InvalidArgument("push body: no body named '" + body + "'");
  if (!(duration_s > 0) || !std::isfinite(duration_s) || !force_W.allFinite()) {
    throw sim::InvalidArgument("push: needs a finite force and a duration > 0 s");
  }
  record([id, force_W, duration_s](LiveScenario& s) {
    const double dt = s.sim_->model().opt.timestep;
    sim::Push p;
    p.body = id;
    p.force_W = force_W;
    // Whole steps from the step it was asked at (simulation.h).
    p.start_s = std::ceil(s.time_s() / dt - 1e-9) * dt;
    p.duration_s = duration_s;
    s.sim_->schedule_push(p);
  });
}

void LiveScenario::restart() {
  log_.clear();
  pending_.clear();
  run_.controller_params = initial_controller_params_;
  run_.gait_params = initial_gait_params_;
  run_.config = initial_config_;
  build();
}

void LiveScenario::reset() {
  future_.clear();
  future_next_ = 0;
  for (const std::unique_ptr<Checkpoint>& c : checkpoints_) c->step = -1;
  restart();
}

void LiveScenario::rewind_to(long step) {
  if (step < 0 || step > run_.steps) {
    throw sim::InvalidArgument("rewind: step must be within [0, " + std::to_string(run_.steps) +
                               "], got " + std::to_string(step));
  }
  // Edits made but not applied yet (say, in a panel while scrubbed back) belong to the point
  // rewound to: they take effect there and start a new future.
  std::vector<Edit> held = std::move(pending_);
  pending_.clear();
  // Every edit made so far (applied, and any still to be replayed), in step order.
  std::vector<Edit> all = log_;
  all.insert(all.end(), future_.begin() + static_cast<long>(future_next_), future_.end());
  const Checkpoint* from = nullptr;
  for (const std::unique_ptr<Checkpoint>& c : checkpoints_) {
    if (c->step >= 0 && c->step <= step && (from == nullptr || c->step > from->step)) from = c.get();
  }
  if (from != nullptr) {
    // The checkpoint's state has the edits made before its step; the rest are replayed.
    restore_checkpoint(*from);
    log_.clear();
    future_.clear();
    for (Edit& e : all) (e.step < from->step ? log_ : future_).push_back(std::move(e));
  } else {
    restart();
    future_ = std::move(all);
  }
  future_next_ = 0;
  last_rewind_replayed_ = step - run_.steps;
  while (run_.steps < step) this->step();
  if (!held.empty()) {
    drop_future();
    pending_ = std::move(held);  // applied at the next step, as any new edit
  }
}

std::string LiveScenario::controller_params_json() const {
  return controllers::params_to_json(run_.controller_params, rig_->groups()).dump(2) + "\n";
}

std::string LiveScenario::gait_params_json() const {
  return gait_ ? controllers::torque_walker_json(run_.gait_params) : std::string();
}

}  // namespace biodyn::scenarios
