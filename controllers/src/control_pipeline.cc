// The control pipeline (control_pipeline.h).
#include "biodyn/controllers/control_pipeline.h"

#include <algorithm>
#include <limits>

#include "biodyn/sim/queries.h"

namespace biodyn::controllers {
namespace {

constexpr int kMaxRedos = 2;  // one per foot weld

// Any of the foot's (or its toes') contacts MuJoCo lists, within the geoms' margin: the
// supports that choose the PD gains. A foot about to touch already carries the body in the
// next steps, so this is wider than sim::foot_touches_floor (touching or penetrating).
bool foot_within_contact_margin(const mjModel& m, const mjData& d, int floor_geom,
                                const models::RigLeg& leg) {
  constexpr double kAnyDistance = std::numeric_limits<double>::infinity();
  return sim::floor_contact_count(m, d, floor_geom, leg.foot, kAnyDistance) > 0 ||
         (leg.toes >= 0 && sim::floor_contact_count(m, d, floor_geom, leg.toes, kAnyDistance) > 0);
}

}  // namespace

ControlPipeline::ControlPipeline(sim::Simulation* sim, const models::Rig& rig,
                                 ControllerParams params, ControlPipelineConfig config)
    : sim_(sim),
      rig_(&rig),
      config_(config),
      frame_(rig, sim->model().nv),
      joints_(sim->model(), rig, params, config.kind),
      limiter_(rig.groups(), params),
      welds_(sim->model(), rig, config.weld),
      standing_(sim->model(), rig, config.balance),
      snapshot_(sim->model()),
      qfrc_other_(static_cast<std::size_t>(sim->model().nv)),
      torque_(static_cast<std::size_t>(sim->model().nv)),
      applied_(static_cast<std::size_t>(sim->model().nv)) {
  const mjModel& m = sim->model();
  for (int a = 0; a < m.nu; ++a)
    if (m.actuator_trntype[a] == mjTRN_JOINT) joint_motors_.push_back(a);
  if (!config_.muscles.empty()) {
    muscles_ = std::make_unique<muscles::MuscleDrive>(m, muscles::MuscleSet(m, config_.muscles),
                                                      joints_.tau_max(), config_.muscle_drive);
  }
}

void ControlPipeline::set_params(const ControllerParams& params) {
  joints_.set_params(params);
  limiter_.set_params(params);
}

void ControlPipeline::set_weld_mode(WeldMode mode) {
  config_.weld.mode = mode;
  welds_.set_mode(sim_->mutable_model(), mode);
}

void ControlPipeline::reset() {
  welds_.reset(sim_->mutable_model());
  sim_->forward();
  // The PD gains see the feet as supports (the character starts standing on both).
  joints_.reset(sim_->model(), sim_->data(), &frame_,
                {rig_->leg(models::kLeft).foot, rig_->leg(models::kRight).foot});
  standing_.reset(sim_->data().time);
  driver_ = nullptr;
  if (muscles_) muscles_->reset(sim_->model(), sim_->data(), joints_.previous_torque().data());
}

void ControlPipeline::reset_in_pose(const Pose& pose) {
  const double tilt = place_in_pose(sim_->model(), sim_->data(), *rig_, pose, config_.balance);
  reset();
  standing_.preset_sagittal_tilt(tilt);
  set_pose(pose);
}

void ControlPipeline::set_pose(const Pose& pose) {
  standing_.set_pose(pose, sim_->data().time);
  for (int s = 0; s < 2; ++s)
    welds_.set_stance(sim_->mutable_model(), s, pose.stance[static_cast<std::size_t>(s)]);
}

void ControlPipeline::set_stance(int side, bool stance) {
  if (welds_.stance(side) != stance) welds_.set_stance(sim_->mutable_model(), side, stance);
}

double ControlPipeline::orientation_error(int group) const {
  return controllers::orientation_error(
      sim_->model(), sim_->data(), groups()[static_cast<std::size_t>(group)], frame_.target(group));
}

void ControlPipeline::control(mjData& d) {
  mjModel& m = sim_->mutable_model();
  const int nv = m.nv;
  frame_.begin_step();
  // 1. The driver: targets, DOF commands, stance wishes.
  ControlDriver& driver = driver_ != nullptr ? *driver_ : standing_;
  driver.drive(ControlInput{m, d, *rig_, last_report_}, &frame_);
  // 2. The feet: stance wishes, welds at strikes.
  for (int s = 0; s < 2; ++s) {
    const int wish = frame_.stance_wish(s);
    if (wish >= 0) set_stance(s, wish == 1);
  }
  welds_.engage_at_strikes(m, d);
  // 3. Extra generalized forces: the swing-twist limits (muscles would add theirs here).
  last_outside_ = limiter_.compute(m, d, frame_.qfrc_extra());
  // 4. The joint controllers, with every other force of this step acting: the extra forces and
  // the pushes (xfrc_applied at body CoMs; a tracking's residual, when asked for, too).
  const mjtNum* extra = frame_.qfrc_extra();
  std::copy(extra, extra + nv, qfrc_other_.begin());
  for (int b = 1; b < m.nbody; ++b) {
    const mjtNum* f = d.xfrc_applied + 6 * b;
    if (f[0] == 0 && f[1] == 0 && f[2] == 0 && f[3] == 0 && f[4] == 0 && f[5] == 0) continue;
    mj_applyFT(&m, &d, f, f + 3, d.xipos + 3 * b, b, qfrc_other_.data());
  }
  if (joints_.kind() == ControllerKind::kPd) {
    int supports[2], n = 0;
    for (int s = 0; s < 2; ++s) {
      if (foot_within_contact_margin(m, d, rig_->floor_geom(), rig_->leg(s)))
        supports[n++] = rig_->leg(s).foot;
    }
    joints_.update_pd_gains(m, d, supports, n);
  }
  last_status_ = joints_.compute(m, d, frame_, qfrc_other_.data(), torque_.data());
  // 5. The Hill muscles give the legs' torques (with the backups), the controllers the others'.
  std::copy(torque_.begin(), torque_.end(), applied_.begin());
  if (muscles_) muscles_->compute(m, d, torque_.data(), applied_.data());
  // 6. Applied: the extra forces plus the joint torques (zero on the free root: no helping hand).
  for (int i = 0; i < nv; ++i) d.qfrc_applied[i] = extra[i] + applied_[static_cast<std::size_t>(i)];
  for (int a : joint_motors_) d.ctrl[a] = 0;  // the joint torques go through qfrc_applied
}

StepReport ControlPipeline::step() {
  mjModel& m = sim_->mutable_model();
  mjData& d = sim_->data();
  StepReport report;
  snapshot_.save(m, d);
  bool released[2] = {false, false};
  for (int attempt = 0;; ++attempt) {
    report.status = sim_->step([&](const mjModel&, mjData& data) { control(data); });
    const int tense = welds_.measure(m, d);
    if (tense >= 0 && config_.weld.mode == WeldMode::kHonest && attempt < kMaxRedos) {
      // Undo, switch the offending weld off (and any released before in this step: the
      // snapshot has them on), and take the step again (foot_contact.h).
      snapshot_.restore(m, d);
      released[tense] = true;
      for (int s = 0; s < 2; ++s)
        if (released[s]) welds_.release_for_tension(m, s, d.time);
      ++report.redone;
      continue;
    }
    report.weld_tension = tense >= 0;
    break;
  }
  welds_.release_near_edges(m, d.time);
  joints_.commit();
  if (muscles_) muscles_->commit();
  report.joints = last_status_;
  report.joints_outside_limits = last_outside_;
  report.balance = driver_ == nullptr ? standing_.offsets() : BalanceOffsets{};
  for (int s = 0; s < 2; ++s) {
    report.weld[static_cast<std::size_t>(s)] = welds_.wrench(s);
    report.weld_active[static_cast<std::size_t>(s)] = welds_.active(m, s);
  }
  last_report_ = report;
  return report;
}

ControlState ControlPipeline::state() const {
  return ControlState{frame_,         joints_.state(),
                      welds_.state(), standing_.state(),
                      last_report_,   muscles_ ? muscles_->state() : muscles::MuscleDriveState{}};
}

void ControlPipeline::restore(const ControlState& state) {
  frame_ = state.frame;
  joints_.restore(state.joints);
  welds_.restore(state.welds);
  standing_.restore(state.standing);
  last_report_ = state.last_report;
  if (muscles_) muscles_->restore(state.muscles);
}

}  // namespace biodyn::controllers
