// The walking scenarios (walk_scenario.h).
#include "biodyn/scenarios/walk_scenario.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "biodyn/sim/errors.h"
#include "biodyn/sim/queries.h"
#include "biodyn/sim/units.h"
#include "fall_watch.h"

namespace biodyn::scenarios {
namespace {

using Eigen::Vector2d;
using Eigen::Vector3d;

// A walk is steady for a push when every stride of the baseline is within this fraction of the
// baseline's mean speed (half the recovery criterion's 10 %: walk.cc).
constexpr double kSteadySpread = 0.05;
// Strides after settle_strides that a push waits for a steady walk before it is abandoned
// (PushOutcome::kNoSteadyStride: "never steady").
constexpr int kMaxSteadyWaitStrides = 30;

// The body a push goes through: "trunk" is the rig's trunk body (thorax, or the gait model's
// trunk), any other name that body.
int push_body_id(const models::Rig& rig, const std::string& body) {
  const int id = body == "trunk" && rig.trunk_body() >= 0 ? rig.trunk_body() : rig.body(body);
  if (id < 0) throw sim::InvalidArgument("push body: no body named '" + body + "'");
  return id;
}

}  // namespace

struct WalkScenario::State : ScenarioState {
  CommonState common;
  std::size_t bytes() const override { return sizeof(*this) + common.bytes(); }
  controllers::ControlState control;
  controllers::TorqueWalkerState walker;
  controllers::ControllerParams params;
  controllers::TorqueWalkerParams walker_params;
  Run run;
};

WalkScenario::WalkScenario(sim::Simulation* sim, ScenarioConfig config)
    : Scenario(sim, std::move(config)),
      params_(controller_params_from_config()),
      walker_params_(config_.walker_params()),
      pipeline_(sim, rig_, params_, config_.pipeline_config()),
      walker_(rig_, walker_params_) {
  if (config_.scenario == "stones" && config_.steps_m.empty())
    config_.steps_m = paper_stepping_stones_m();
  run_.stones.reserve(config_.steps_m.size() + 1);  // the stop's closing step may be one more
  sim->reset();
  stand_pose_ = controllers::pose_scenario("stand", rig_.groups(), 0)[0];
  pipeline_.reset_in_pose(stand_pose_);
  walker_.reset(sim->data());
  walker_.set_actuation(config_.walker_actuation);
  walker_.set_heading_rate(config_.heading_rate_deg_s / kDegPerRad);
  walker_.set_speed(config_.speed_m_s);
  pipeline_.set_driver(&walker_);
  if (walker_params_.start_shift_s > 0) start_weight_shift();
  fall_ = std::make_unique<FallWatch>(rig_, kWalkingFallPelvisFraction);
  fall_->start(sim->data());
  if (config_.walk_push) push_body_ = push_body_id(rig_, config_.walk_push->body);
}

WalkScenario::~WalkScenario() = default;

bool WalkScenario::fallen() const { return fall_->down(sim_->model(), sim_->data()); }

void WalkScenario::start_weight_shift() {
  controllers::Pose shift = stand_pose_;
  shift.name = "weight shift";
  shift.support = walker_.state().stance == models::kLeft ? controllers::Support::kLeft
                                                          : controllers::Support::kRight;
  shift.reach_time_s = walker_params_.start_shift_reach_s;
  pipeline_.set_pose(shift);
  pipeline_.set_driver(nullptr);
  run_.start_shift_until_s = sim_->data().time + walker_params_.start_shift_s;
}

void WalkScenario::advance() {
  pipeline_.step();
  const mjData& d = sim_->data();
  // The start's weight shift over: the walker starts from here (its first swing lifts).
  if (shifting_weight() && d.time >= run_.start_shift_until_s - 0.5 * sim_->model().opt.timestep) {
    run_.start_shift_until_s = -1;
    walker_.reset(d);
    pipeline_.set_driver(&walker_);
  }
  // Stopping: the walker plans its last steps; once the feet are side by side the standing
  // controller (pose and balance) takes over with both feet in stance.
  if (config_.stop_at_s >= 0 && d.time >= config_.stop_at_s && !walker_.stopping())
    walker_.request_stop();
  if (walker_.stopped() && pipeline_.driver() == &walker_) {
    pipeline_.set_driver(nullptr);
    pipeline_.set_stance(0, true);
    pipeline_.set_stance(1, true);
    pipeline_.set_pose(stand_pose_);
    run_.stopped_at_s = d.time;
  }
  if (walker_.strike_count() != run_.strikes_seen) on_strike();
  if (!config_.steps_m.empty()) place_stone();
}

void WalkScenario::on_strike() {
  const mjData& d = sim_->data();
  run_.strikes_seen = walker_.strike_count();
  const controllers::TorqueWalkerStrike& st = walker_.last_strike();
  // A planned step ends at this strike: its length walked. Then the plan starts at the first
  // strike at or after steps_start_s (from the swing that starts now).
  if (!std::isnan(st.target_length_m) && !run_.stones.empty() &&
      std::isnan(run_.stones.back().walked_m)) {
    Stone& stone = run_.stones.back();
    stone.walked_m = st.step_length_m;
    stone.walked_across_m = st.step_across_m;
    stone.out_of_reach = st.target_out_of_reach;
  }
  if (!config_.steps_m.empty() && !run_.stones_planned && d.time >= config_.steps_start_s) {
    walker_.plan_steps(config_.steps_m, planned_widths());
    run_.stones_planned = true;
    run_.stones_start_s = d.time;
  }
  run_.stone_pending = run_.stones_planned;
  if (st.side != 0) return;
  // Strides start at left strikes. The push: at onset_phase of the stride after settle_strides,
  // and after the walk is steady.
  constexpr int n = kBaselineStrides + 1;
  for (int i = 0; i + 1 < n; ++i) {
    run_.left_strike_s[i] = run_.left_strike_s[i + 1];
    run_.left_strike_com[i] = run_.left_strike_com[i + 1];
  }
  run_.left_strike_s[n - 1] = st.time_s;
  run_.left_strike_com[n - 1] = sim::center_of_mass(sim_->model(), d).position_W.head<2>();
  ++run_.left_strikes;
  if (!config_.walk_push || !std::isnan(run_.push_onset_s) || run_.push_abandoned ||
      run_.left_strikes < std::max(config_.walk_push->settle_strides, kBaselineStrides) + 1)
    return;
  const double speed_before = steady_stride_speed_m_s();
  if (std::isnan(speed_before)) {
    run_.push_abandoned =
        run_.left_strikes > config_.walk_push->settle_strides + kMaxSteadyWaitStrides;
    return;
  }
  const WalkPush& wp = *config_.walk_push;
  const double dt = sim_->model().opt.timestep;
  const double stride_s = run_.left_strike_s[n - 1] - run_.left_strike_s[n - 2];
  const double a = walker_.heading_rad() + wp.direction_deg / kDegPerRad;
  sim::Push push;
  push.body = push_body_;
  push.force_W = wp.force_N * Vector3d(std::cos(a), std::sin(a), 0);
  push.start_s = d.time + wp.onset_phase * stride_s;
  // Whole steps: the push is on for round(duration / dt) steps from the first step at or after
  // its start (simulation.h).
  push.start_s = std::ceil(push.start_s / dt - 1e-9) * dt;
  push.duration_s = wp.duration_s;
  sim_->schedule_push(push);
  run_.push_onset_s = push.start_s;
  run_.push_end_s = push.start_s + push.duration_s;
  run_.push_speed_before_m_s = speed_before;
  run_.push_after_strides = run_.left_strikes - 1;
}

double WalkScenario::steady_stride_speed_m_s() const {
  // The mean speed over the last kBaselineStrides strides, if each stride's speed is within
  // kSteadySpread of it: a walker still speeding up from the start (the velocity-based driver
  // takes ~8 s to its speed) has no speed to recover to yet. The mean is of the strides'
  // own lengths (as the judge measures the strides after the push): a chord would be short
  // on a turn.
  constexpr int n = kBaselineStrides + 1;
  double length_m = 0;
  for (int i = 1; i < n; ++i)
    length_m += (run_.left_strike_com[i] - run_.left_strike_com[i - 1]).norm();
  const double mean = length_m / (run_.left_strike_s[n - 1] - run_.left_strike_s[0]);
  for (int i = 1; i < n; ++i) {
    const double v = (run_.left_strike_com[i] - run_.left_strike_com[i - 1]).norm() /
                     (run_.left_strike_s[i] - run_.left_strike_s[i - 1]);
    if (std::abs(v - mean) > kSteadySpread * mean) return std::numeric_limits<double>::quiet_NaN();
  }
  return mean;
}

double Stone::error_m() const {
  return across_planned ? std::hypot(walked_m - target_m, walked_across_m - across_m)
                        : walked_m - target_m;
}

std::vector<double> WalkScenario::planned_widths() const {
  // The walkway: each foot's line the hips' spacing w apart, centred on the stance foot where
  // the plan starts; stone k lies o_k left of its line, so from the stone before (o_-1 = 0) the
  // step's width is w + (o_k - o_k-1), signed outwards for the swing side.
  std::vector<double> widths;
  if (config_.steps_lateral_m.empty()) return widths;
  // The plan starts with the swing after the next strike: the current stance leg's.
  int swing = walker_.stance_side();
  double before = 0;
  for (const double offset : config_.steps_lateral_m) {
    const double out = swing == models::kLeft ? 1.0 : -1.0;
    widths.push_back(rig_.hip_spacing_m() + out * (offset - before));
    before = offset;
    swing = 1 - swing;
  }
  return widths;
}

void WalkScenario::place_stone() {
  if (std::isnan(walker_.swing_target_m())) return;
  // The swing's stone, from the walker's reference: the stance ankle (which rolls forward a
  // little during the swing, so the stone follows it until the strike fixes it), along the
  // heading by the planned length, across as far as the swing ankle was when the swing began.
  const mjData& d = sim_->data();
  const int swing = 1 - walker_.stance_side();
  const int stance_body = rig_.leg(walker_.stance_side()).foot;
  const Vector2d stance(d.xpos[3 * stance_body], d.xpos[3 * stance_body + 1]);
  const Vector2d along(std::cos(walker_.heading_rad()), std::sin(walker_.heading_rad()));
  const Vector2d across(-along.y(), along.x());
  // The stop's closing step is planned too, but it is not one of the stones.
  if (run_.stone_pending && run_.stones.size() >= config_.steps_m.size())
    run_.stone_pending = false;
  if (run_.stone_pending) {
    run_.stone_pending = false;
    const int swing_body = rig_.leg(swing).foot;
    const Vector2d swing_at(d.xpos[3 * swing_body], d.xpos[3 * swing_body + 1]);
    Stone stone;
    stone.side = swing;
    stone.target_m = walker_.swing_target_m();
    stone.across_planned = !std::isnan(walker_.swing_width_m());
    stone.across_m = stone.across_planned
                         ? (swing == models::kLeft ? 1.0 : -1.0) * walker_.swing_width_m()
                         : (swing_at - stance).dot(across);
    run_.stones.push_back(stone);
  }
  Stone& stone = run_.stones.back();
  if (!std::isnan(stone.walked_m)) return;
  // Until the strike: whether the stone is beyond the leg's reach now (a fall reaching for it
  // leaves it so).
  stone.out_of_reach = walker_.state().swing_out_of_reach;
  stone.heading_rad = walker_.heading_rad();
  stone.ankle_W = stance + stone.target_m * along + stone.across_m * across;
}

void WalkScenario::set_controller_params(const controllers::ControllerParams& params) {
  pipeline_.set_params(params);
  params_ = params;
}

void WalkScenario::set_weld_mode(controllers::WeldMode mode) {
  pipeline_.set_weld_mode(mode);
  config_.weld = mode;
}

void WalkScenario::set_walker_params(const controllers::TorqueWalkerParams& params) {
  walker_.set_params(params);
  walker_params_ = params;
}

void WalkScenario::set_walker_actuation(controllers::WalkerActuation actuation) {
  walker_.set_actuation(actuation);
  config_.walker_actuation = actuation;
}

void WalkScenario::set_speed(double m_s) {
  check_walk_speed(m_s);
  walker_.set_speed(m_s);
  config_.speed_m_s = m_s;
}

void WalkScenario::set_heading_rate(double deg_s) {
  check_heading_rate(deg_s);
  walker_.set_heading_rate(deg_s / kDegPerRad);
  config_.heading_rate_deg_s = deg_s;
}

std::unique_ptr<ScenarioState> WalkScenario::new_state() const { return std::make_unique<State>(); }

void WalkScenario::save(ScenarioState* out) const {
  State& s = static_cast<State&>(*out);
  save_common(&s.common);
  s.control = pipeline_.state();
  s.walker = walker_.state();
  s.params = params_;
  s.walker_params = walker_params_;
  s.run = run_;
}

void WalkScenario::restore(const ScenarioState& in) {
  const State& s = static_cast<const State&>(in);
  // The parameters of that moment first (the edits before it), then the state.
  set_controller_params(s.params);
  set_walker_params(s.walker_params);
  pipeline_.set_weld_mode(s.common.config.weld);
  restore_common(s.common);
  walker_.set_actuation(config_.walker_actuation);  // the config of that moment
  pipeline_.restore(s.control);
  walker_.restore(s.walker);
  run_ = s.run;
  // The standing controller drives once the stop is done.
  pipeline_.set_driver(run_.stopped_at_s >= 0 || shifting_weight() ? nullptr : &walker_);
}

}  // namespace biodyn::scenarios
