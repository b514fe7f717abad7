// The pose scenarios (pose_scenario.h).
#include "biodyn/scenarios/pose_scenario.h"

#include <cmath>

#include "biodyn/sim/errors.h"
#include "biodyn/sim/units.h"
#include "fall_watch.h"

namespace biodyn::scenarios {
struct PoseScenario::State : ScenarioState {
  CommonState common;
  std::size_t bytes() const override { return sizeof(*this) + common.bytes(); }
  controllers::ControlState control;
  controllers::ControllerParams params;
  std::size_t pose_index = 0;
  double pose_start_s = 0;
};

PoseScenario::PoseScenario(sim::Simulation* sim, ScenarioConfig config)
    : Scenario(sim, std::move(config)),
      params_(controller_params_from_config()),
      pipeline_(sim, rig_, params_, config_.pipeline_config()),
      poses_(controllers::pose_scenario(config_.scenario, rig_.groups(), config_.pose_duration_s)) {
  double total = 0;
  for (const controllers::Pose& p : poses_) total += p.duration_s;
  if (config_.pose_duration_s > 0) total = config_.pose_duration_s;
  total_steps_ = static_cast<long>(std::lround(total / sim->model().opt.timestep));

  sim->reset();
  pipeline_.reset_in_pose(poses_[0]);  // already standing in the first pose at t = 0
  const mjData& d = sim->data();
  fall_ = std::make_unique<FallWatch>(rig_, kStandingFallPelvisFraction);
  fall_->start(d);
  for (int s = 0; s < 2; ++s) {
    const int foot = rig_.leg(s).foot;
    foot_start_[s] = Eigen::Vector2d(d.xpos[3 * foot], d.xpos[3 * foot + 1]);
  }
  if (config_.pose_push) {
    const TimedPush& tp = *config_.pose_push;
    const double a = tp.direction_deg / kDegPerRad;
    sim::Push push;
    push.body = rig_.body(tp.body);
    if (push.body < 0) throw sim::InvalidArgument("push body: no body named '" + tp.body + "'");
    push.force_W = tp.force_N * Eigen::Vector3d(std::cos(a), std::sin(a), 0);
    push.start_s = tp.onset_s;
    push.duration_s = tp.duration_s;
    sim->schedule_push(push);
  }
}

PoseScenario::~PoseScenario() = default;

bool PoseScenario::fallen() const { return fall_->down(sim_->model(), sim_->data()); }

void PoseScenario::advance() {
  // The pose schedule: the next pose when this one's time is up; the last one holds.
  const double dt = sim_->model().opt.timestep;
  while (pose_index_ + 1 < poses_.size() &&
         sim_->data().time >= pose_start_s_ + poses_[pose_index_].duration_s - 0.5 * dt) {
    pose_start_s_ += poses_[pose_index_].duration_s;
    ++pose_index_;
    pipeline_.set_pose(poses_[pose_index_]);
  }
  pipeline_.step();
}

void PoseScenario::set_controller_params(const controllers::ControllerParams& params) {
  pipeline_.set_params(params);
  params_ = params;
}

void PoseScenario::set_weld_mode(controllers::WeldMode mode) {
  pipeline_.set_weld_mode(mode);
  config_.weld = mode;
}

std::unique_ptr<ScenarioState> PoseScenario::new_state() const { return std::make_unique<State>(); }

void PoseScenario::save(ScenarioState* out) const {
  State& s = static_cast<State&>(*out);
  save_common(&s.common);
  s.control = pipeline_.state();
  s.params = params_;
  s.pose_index = pose_index_;
  s.pose_start_s = pose_start_s_;
}

void PoseScenario::restore(const ScenarioState& in) {
  const State& s = static_cast<const State&>(in);
  set_controller_params(s.params);  // the parameters of that moment first (the edits before it)
  pipeline_.set_weld_mode(s.common.config.weld);
  restore_common(s.common);
  pipeline_.restore(s.control);
  pose_index_ = s.pose_index;
  pose_start_s_ = s.pose_start_s;
}

}  // namespace biodyn::scenarios
