#pragma once
/// The pose scenarios (stand, squat, reach, one-leg): a pose sequence (controllers/poses.h)
/// held by the standing controller and its balance under the joint controllers and the foot
/// welds; optionally a push at a given time. `biodyn pose`, `stand-push`, the viewer and
/// `render` run it. Its last pose holds; with a duration (config.pose_duration_s, or the
/// sequence's own length) it is finished then.

#include <memory>
#include <vector>

#include "biodyn/controllers/control_pipeline.h"
#include "biodyn/controllers/poses.h"
#include "biodyn/scenarios/scenario.h"

namespace biodyn::scenarios {

class PoseScenario : public Scenario {
 public:
  /// Builds at t = 0: `sim` reset, the character standing at rest in the first pose (as if it
  /// had stood so before: its muscles carry the static load), the push scheduled. Throws
  /// sim::InvalidArgument for a bad config or a model the scenario cannot do (reach: no arms).
  PoseScenario(sim::Simulation* sim, ScenarioConfig config);
  ~PoseScenario() override;

  bool finished() const override { return steps_ >= total_steps_; }
  bool fallen() const override;
  const controllers::ControlPipeline* pipeline() const override { return &pipeline_; }
  const controllers::ControllerParams* controller_params() const override { return &params_; }
  void set_controller_params(const controllers::ControllerParams& params) override;
  void set_weld_mode(controllers::WeldMode mode) override;

  const std::vector<controllers::Pose>& poses() const { return poses_; }
  std::size_t pose_index() const { return pose_index_; }
  double pose_start_s() const { return pose_start_s_; }
  /// Steps of the whole sequence (its length, or the configured duration).
  long total_steps() const { return total_steps_; }
  /// Where the feet stood at t = 0 (world xy), for the no-step check of a push.
  const Eigen::Vector2d& foot_start(int side) const {
    return foot_start_[static_cast<std::size_t>(side)];
  }

  std::unique_ptr<ScenarioState> new_state() const override;
  void save(ScenarioState* state) const override;
  void restore(const ScenarioState& state) override;

 private:
  struct State;
  void advance() override;

  controllers::ControllerParams params_;
  controllers::ControlPipeline pipeline_;
  std::vector<controllers::Pose> poses_;
  std::size_t pose_index_ = 0;
  double pose_start_s_ = 0;
  long total_steps_ = 0;
  Eigen::Vector2d foot_start_[2];
  std::unique_ptr<FallWatch> fall_;
};

}  // namespace biodyn::scenarios
