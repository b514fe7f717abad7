// Any scenario stepped from outside with live edits and exact rewind (live.h).
#include "biodyn/scenarios/live.h"

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>

#include "biodyn/models/mjcf.h"
#include "biodyn/scenarios/registry.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/model.h"

namespace biodyn::scenarios {

LiveScenario::LiveScenario(ScenarioConfig config) {
  config.validate();
  // The model's body with the muscles' tendons when the muscles are on (the pipeline binds to
  // them).
  const models::Character character = models::generate_character(config.model_spec());
  models::PhysicsOptions physics;
  physics.terrain = config.terrain;
  sim_ = std::make_unique<sim::Simulation>(
      sim::Model::from_string(models::to_mjcf(character, physics), "generated character"));
  scenario_ = make_scenario(sim_.get(), config);
  walk_ = scenario_->walk();
  mocap_ = scenario_->mocap();
  initial_ = scenario_->new_state();
  scenario_->save(initial_.get());
  checkpoint_every_ = std::max(1L, std::lround(kCheckpointInterval_s / sim_->model().opt.timestep));
  checkpoints_.resize(kCheckpoints);
}

LiveScenario::~LiveScenario() = default;

void LiveScenario::step() {
  // After a rewind, the edits the run had made from here on come back at their steps.
  while (future_next_ < future_.size() && future_[future_next_].step == step_index()) {
    pending_.push_back(future_[future_next_++]);
  }
  if (!pending_.empty()) {
    for (Edit& e : pending_) {
      e.step = step_index();
      e.apply(*scenario_);
      log_.push_back(std::move(e));
    }
    pending_.clear();
  }
  scenario_->step();
  if (step_index() % checkpoint_every_ == 0) save_checkpoint();
}

void LiveScenario::run_until(double t_s) {
  const double dt = sim_->model().opt.timestep;
  while (time_s() < t_s - 0.5 * dt) step();
}

const controllers::StepReport& LiveScenario::last_report() const {
  static const controllers::StepReport kNone{};
  return scenario_->pipeline() ? scenario_->pipeline()->last_report() : kNone;
}

const std::vector<Stone>& LiveScenario::stones() const {
  static const std::vector<Stone> kNone;
  return walk_ ? walk_->stones() : kNone;
}

controllers::MotionTracker::Error LiveScenario::tracking_error() const {
  return mocap_ ? mocap_->tracking_error() : controllers::MotionTracker::Error{};
}

const TrackingStats& LiveScenario::tracking_stats() const {
  static const TrackingStats kNone{};
  return mocap_ ? mocap_->tracking_stats() : kNone;
}

TrackingReport LiveScenario::tracking_report() const {
  return mocap_ ? mocap_->tracking_report() : TrackingReport{};
}

void LiveScenario::save_checkpoint() {
  // Once per step index: after a rewind the replay passes checkpoints it already has.
  Checkpoint* slot = nullptr;
  for (Checkpoint& c : checkpoints_) {
    if (c.step == step_index()) return;
    if (slot == nullptr || c.step < slot->step) slot = &c;  // a free one, else the oldest
  }
  if (!slot->state) slot->state = scenario_->new_state();
  slot->step = step_index();
  scenario_->save(slot->state.get());
}

std::size_t LiveScenario::checkpoint_bytes() const {
  std::size_t bytes = 0;
  for (const Checkpoint& c : checkpoints_) {
    if (c.step >= 0) bytes += sizeof(Checkpoint) + c.state->bytes();
  }
  return bytes;
}

void LiveScenario::drop_future() {
  future_.clear();
  future_next_ = 0;
  for (Checkpoint& c : checkpoints_) {
    if (c.step > step_index()) c.step = -1;  // states of the dropped future
  }
}

void LiveScenario::record(std::function<void(Scenario&)> apply) {
  // A new edit starts a new future: the edits a rewound run would have replayed are dropped.
  drop_future();
  pending_.push_back({step_index(), std::move(apply)});
}

void LiveScenario::set_controller_params(const controllers::ControllerParams& params) {
  if (scenario_->controller_params() == nullptr)
    scenario_->set_controller_params(params);  // throws
  params.validate(sim_->model().opt.timestep);
  record([params](Scenario& s) { s.set_controller_params(params); });
}

void LiveScenario::set_gait_params(const controllers::TorqueWalkerParams& params) {
  if (!walk_) throw sim::InvalidArgument("walker parameters: the scenario does not walk");
  params.validate();
  record([params](Scenario& s) { s.set_walker_params(params); });
}

void LiveScenario::set_speed(double m_s) {
  if (!walk_) throw sim::InvalidArgument("speed: the scenario does not walk");
  check_walk_speed(m_s);
  record([m_s](Scenario& s) { s.set_speed(m_s); });
}

void LiveScenario::set_heading_rate(double deg_s) {
  if (!walk_) throw sim::InvalidArgument("heading rate: the scenario does not walk");
  check_heading_rate(deg_s);
  record([deg_s](Scenario& s) { s.set_heading_rate(deg_s); });
}

void LiveScenario::set_walker_actuation(controllers::WalkerActuation actuation) {
  if (!walk_) throw sim::InvalidArgument("controller: the scenario does not walk");
  record([actuation](Scenario& s) { s.set_walker_actuation(actuation); });
}

void LiveScenario::set_weld_mode(controllers::WeldMode mode) {
  if (scenario_->pipeline() == nullptr) scenario_->set_weld_mode(mode);  // throws
  record([mode](Scenario& s) { s.set_weld_mode(mode); });
}

void LiveScenario::push(const std::string& body, const Eigen::Vector3d& force_W,
                        double duration_s) {
  if (playback())
    throw sim::InvalidArgument("push: the mocap scenario plays its motion kinematically");
  const int id = rig().body(body);
  if (id < 0) throw sim::InvalidArgument("push body: no body named '" + body + "'");
  if (!(duration_s > 0) || !std::isfinite(duration_s) || !force_W.allFinite()) {
    throw sim::InvalidArgument("push: needs a finite force and a duration > 0 s");
  }
  record([id, force_W, duration_s](Scenario& s) { s.push(id, force_W, duration_s); });
}

void LiveScenario::restart() {
  log_.clear();
  pending_.clear();
  scenario_->restore(*initial_);
}

void LiveScenario::reset() {
  future_.clear();
  future_next_ = 0;
  for (Checkpoint& c : checkpoints_) c.step = -1;
  restart();
}

void LiveScenario::rewind_to(long step) {
  if (step < 0 || step > step_index()) {
    throw sim::InvalidArgument("rewind: step must be within [0, " + std::to_string(step_index()) +
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
  for (const Checkpoint& c : checkpoints_) {
    if (c.step >= 0 && c.step <= step && (from == nullptr || c.step > from->step)) from = &c;
  }
  if (from != nullptr) {
    // The checkpoint's state has the edits made before its step; the rest are replayed.
    scenario_->restore(*from->state);
    log_.clear();
    future_.clear();
    for (Edit& e : all) (e.step < from->step ? log_ : future_).push_back(std::move(e));
  } else {
    restart();
    future_ = std::move(all);
  }
  future_next_ = 0;
  last_rewind_replayed_ = step - step_index();
  while (step_index() < step) this->step();
  if (!held.empty()) {
    drop_future();
    pending_ = std::move(held);  // applied at the next step, as any new edit
  }
}

std::string LiveScenario::controller_params_json() const {
  const controllers::ControllerParams* p = controller_params();
  return p ? controllers::params_to_json(*p, rig().groups()).dump(2) + "\n" : std::string();
}

std::string LiveScenario::gait_params_json() const {
  return walk_ ? controllers::torque_walker_json(walk_->walker().params()) : std::string();
}

}  // namespace biodyn::scenarios
