#pragma once
/// The walking scenarios ("walk", "stones"): a generated character starts standing and walks
/// under the torque walker (controllers/torque_walker.h) with the joint controllers' muscle
/// limits and a foot-contact mode. Its schedule: the commanded speed and turning rate, the
/// stepping stones (paper §4.2; planned from the first strike after steps_start_s), a stop back
/// to standing (the standing controller takes over once the feet are side by side), and one
/// push timed by the gait (references.md, push protocol). `biodyn walk`, `push`, `push-sweep`,
/// the viewer and `render` run it.

#include <Eigen/Core>
#include <limits>
#include <memory>
#include <vector>

#include "biodyn/controllers/control_pipeline.h"
#include "biodyn/controllers/poses.h"
#include "biodyn/controllers/torque_walker.h"
#include "biodyn/scenarios/scenario.h"

namespace biodyn::scenarios {

/// One planned step of the stepping stones. Where its length puts the swing foot's ankle: from
/// the stance ankle (the walker's reference; it rolls forward a little during the swing, and the
/// stone with it until the strike) along the heading; across by the planned width (stones
/// placed in 2D, ScenarioConfig::steps_lateral_m), else as far across as the swing ankle was
/// when the swing began (the balance feedback places the foot across).
struct Stone {
  Eigen::Vector2d ankle_W = Eigen::Vector2d::Zero();  ///< m, world xy
  double heading_rad = 0;
  int side = 0;                 ///< the swing foot (0 left, 1 right)
  double target_m = 0;          ///< planned length
  double across_m = 0;          ///< m, left of the stance ankle (heading frame)
  bool across_planned = false;  ///< across_m is the plan's (2D stones), not the balance's
  double walked_m =
      std::numeric_limits<double>::quiet_NaN();  ///< length at the strike; NaN: in swing
  double walked_across_m = std::numeric_limits<double>::quiet_NaN();  ///< left, at the strike
  /// The target was beyond the leg's reach: the foot came down at the closest reachable point.
  bool out_of_reach = false;
  /// m, the miss at the strike: the distance from the stone in 2D with a planned width, else
  /// walked - planned length.
  double error_m() const;
};

class WalkScenario : public Scenario {
 public:
  /// Builds at t = 0: `sim` reset, the character standing in the pose "stand", the walker
  /// starting from it (after the start's weight shift, when its params ask for one). Throws
  /// sim::InvalidArgument for a bad config (naming the field or file).
  WalkScenario(sim::Simulation* sim, ScenarioConfig config);
  ~WalkScenario() override;

  /// With a duration (run_walk), or with the push judged (an observer's done()); and at a fall.
  bool finished() const override { return fell_at_s_ >= 0 || steps_ >= max_steps_; }
  /// Ends the run after `steps` steps (run_walk's duration; the viewer's runs go on).
  void set_max_steps(long steps) { max_steps_ = steps; }
  bool fallen() const override;
  const WalkScenario* walk() const override { return this; }
  const controllers::ControlPipeline* pipeline() const override { return &pipeline_; }
  const controllers::ControllerParams* controller_params() const override { return &params_; }

  void set_controller_params(const controllers::ControllerParams& params) override;
  void set_weld_mode(controllers::WeldMode mode) override;
  void set_walker_params(const controllers::TorqueWalkerParams& params) override;
  void set_walker_actuation(controllers::WalkerActuation actuation) override;
  void set_speed(double m_s) override;
  void set_heading_rate(double deg_s) override;

  const controllers::TorqueWalker& walker() const { return walker_; }
  /// The stepping stones planned so far (empty before steps_start_s), with their walked lengths.
  const std::vector<Stone>& stones() const { return run_.stones; }
  /// The plan: config().steps_m (the paper's for "stones" without one); empty: free walking.
  /// s, the strike the plan started from (-1: not yet).
  double stones_start_s() const { return run_.stones_start_s; }
  /// s, when the feet came side by side and the standing controller took over (-1: never).
  double stopped_at_s() const { return run_.stopped_at_s; }
  /// The push of config.walk_push once scheduled: its onset and end (s), else NaN.
  double push_onset_s() const { return run_.push_onset_s; }
  double push_end_s() const { return run_.push_end_s; }
  /// m/s, the mean stride speed over the (at most kBaselineStrides) steady strides before the
  /// push, once scheduled; else NaN.
  double push_speed_before_m_s() const { return run_.push_speed_before_m_s; }
  /// Strides walked before the push's stride once scheduled (>= settle_strides), else -1.
  int push_after_strides() const { return run_.push_after_strides; }
  /// The walk never became steady in the strides a push waits: it will not come.
  bool push_abandoned() const { return run_.push_abandoned; }
  /// The pushed body (config.walk_push), or -1.
  int push_body() const { return push_body_; }

  std::unique_ptr<ScenarioState> new_state() const override;
  void save(ScenarioState* state) const override;
  void restore(const ScenarioState& state) override;

 private:
  struct State;
  /// Strides the push's baseline speed is measured over; they must be steady (walk.h).
  static constexpr int kBaselineStrides = 4;
  // What the scenario's schedule carries from step to step (part of its state).
  struct Run {
    int strikes_seen = 0;
    bool stones_planned = false, stone_pending = false;
    double stones_start_s = -1;
    std::vector<Stone> stones;
    double stopped_at_s = -1;
    /// s, when the start's weight shift ends and the walker takes over (-1: none, or over).
    double start_shift_until_s = -1;
    int left_strikes = 0;
    // The last kBaselineStrides + 1 left strikes (oldest first): times and CoM xy.
    double left_strike_s[kBaselineStrides + 1] = {};
    Eigen::Vector2d left_strike_com[kBaselineStrides + 1] = {};
    double push_onset_s = std::numeric_limits<double>::quiet_NaN();
    double push_speed_before_m_s = std::numeric_limits<double>::quiet_NaN();
    int push_after_strides = -1;  // strides walked before the push's stride
    bool push_abandoned = false;  // the walk never became steady: no push
    double push_end_s = std::numeric_limits<double>::quiet_NaN();
  };
  void advance() override;
  /// Gait initiation (TorqueWalkerParams::start_shift_s): the standing controller moves the CoM
  /// towards the walker's first stance foot, both feet down, before the walker drives.
  void start_weight_shift();
  bool shifting_weight() const { return run_.start_shift_until_s >= 0; }
  /// At a strike: the stones' walked lengths, the plan's start, the push's timing.
  void on_strike();
  /// The baseline's mean stride speed if its strides are steady (walk_scenario.cc), else NaN.
  double steady_stride_speed_m_s() const;
  /// The current swing's stone follows the stance ankle until the strike fixes it.
  void place_stone();
  /// The plan's step widths from config().steps_lateral_m (empty without it), from the swing
  /// after the next strike (plan_steps).
  std::vector<double> planned_widths() const;

  controllers::ControllerParams params_;
  controllers::TorqueWalkerParams walker_params_;
  controllers::ControlPipeline pipeline_;
  controllers::TorqueWalker walker_;
  controllers::Pose stand_pose_;
  int push_body_ = -1;
  long max_steps_ = std::numeric_limits<long>::max();
  Run run_;
  std::unique_ptr<FallWatch> fall_;
};

}  // namespace biodyn::scenarios
