#pragma once
/// Any scenario stepped from outside, one physics step at a time, with its parameters edited
/// while it runs: what the viewer (`biodyn view`) and `biodyn render` drive. It owns the
/// character's simulation (generated from the config's model_spec(): the character,
/// with the muscles' tendons when they are on) and wraps the registry's
/// scenario (registry.h) with two things of its own: an edit log and a ring of checkpoints.
///
/// Rewind is exact: every edit (parameters, speed, heading, weld mode, a push) is logged with the
/// step it took effect at, and every 0.5 s of simulated time the scenario's whole state
/// (Scenario::save: simulation, controllers, walker, schedule, parameters) goes into a ring of
/// checkpoints covering the last 16 s. Rewinding to step k restores the newest checkpoint at or
/// before k and replays the log from it to k (at most 0.5 s of simulation); further back than
/// the ring it restores the state at t = 0 and replays from there (slower, as exact). The
/// simulation is deterministic (sim/determinism.h), so resuming from k gives the same future the
/// first run had, until a new edit is made (which drops the logged edits and the checkpoints
/// after k).

#include <Eigen/Core>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "biodyn/controllers/control_pipeline.h"
#include "biodyn/controllers/controller_params.h"
#include "biodyn/controllers/motion_tracker.h"
#include "biodyn/controllers/torque_walker.h"
#include "biodyn/models/rig.h"
#include "biodyn/scenarios/mocap_scenario.h"
#include "biodyn/scenarios/scenario.h"
#include "biodyn/scenarios/walk_scenario.h"
#include "biodyn/sim/simulation.h"

namespace biodyn::scenarios {

class LiveScenario {
 public:
  /// Generates the character, builds the scenario at t = 0. Throws sim::InvalidArgument for a
  /// bad config (naming the field or file).
  explicit LiveScenario(ScenarioConfig config);
  ~LiveScenario();

  /// One physics step: pending edits first, then the scenario's step. Allocates only when an
  /// edit is pending, when the scenario logs something (a stone), and when a checkpoint slot is
  /// first filled or its arrays grow (the first 16 s; rarely after).
  void step();
  /// Steps until simulation time reaches t_s (no-op if already there).
  void run_until(double t_s);

  long step_index() const { return scenario_->step_index(); }
  double time_s() const { return sim_->data().time; }
  /// Fallen by the scenario's rule (a body other than the feet touches the floor, or the pelvis
  /// below its fall fraction of the standing height). Never for a kinematic playback.
  bool fallen() const { return scenario_->fallen(); }
  /// When the character first fell in this run (s), or -1.
  double fell_at_s() const { return scenario_->fell_at_s(); }

  // --- Edits: logged, applied before the next step. Each is checked now (a value out of
  // range, or an edit the scenario does not have, throws sim::InvalidArgument). ---
  void set_controller_params(const controllers::ControllerParams& params);
  void set_gait_params(const controllers::TorqueWalkerParams& params);  ///< walking only
  void set_speed(double m_s);                                           ///< walking only
  void set_heading_rate(double deg_s);                                  ///< walking only
  void set_weld_mode(controllers::WeldMode mode);
  void set_walker_actuation(controllers::WalkerActuation actuation);  ///< walking only
  /// A horizontal (or any) force through the CoM of `body` for `duration_s`, from the next step.
  void push(const std::string& body, const Eigen::Vector3d& force_W, double duration_s);

  /// Back to t = 0 with the config's parameters; the edit log is cleared.
  void reset();
  /// Back to step `step` (0 <= step <= step_index()) from the newest checkpoint at or before it
  /// (or from t = 0), replaying the log: the state equals the one the run had at that step.
  /// Edits made but not yet applied take effect at `step` and start a new future there.
  void rewind_to(long step);

  /// Simulated time between checkpoints, and how many the ring keeps (16 s).
  static constexpr double kCheckpointInterval_s = 0.5;
  static constexpr int kCheckpoints = 32;
  /// Steps the last rewind_to replayed (from its checkpoint, or from t = 0).
  long last_rewind_replayed_steps() const { return last_rewind_replayed_; }
  /// MuJoCo data the checkpoints hold, bytes (each also holds the controllers' states, a few
  /// kB).
  std::size_t checkpoint_bytes() const;

  // --- Read-outs (for panels, overlays and plots). ---
  Scenario& scenario() { return *scenario_; }
  const Scenario& scenario() const { return *scenario_; }
  /// The configuration, as edited since (speed, heading rate, weld mode).
  const ScenarioConfig& config() const { return scenario_->config(); }
  sim::Simulation& simulation() { return *sim_; }
  const sim::Simulation& simulation() const { return *sim_; }
  /// The character's parts, resolved once (models/rig.h).
  const models::Rig& rig() const { return scenario_->rig(); }
  /// The control pipeline (nullptr for a kinematic playback).
  const controllers::ControlPipeline* controller() const { return scenario_->pipeline(); }
  /// The legs' Hill muscles (ScenarioConfig::muscles on), or nullptr.
  const muscles::MuscleDrive* muscles() const {
    return scenario_->pipeline() ? scenario_->pipeline()->muscles() : nullptr;
  }
  /// What the muscles did so far (scenario.h), or nullopt without muscles.
  std::optional<MuscleRunReport> muscle_report() const {
    return scenario_->pipeline() ? scenarios::muscle_report(*scenario_->pipeline()) : std::nullopt;
  }
  const controllers::ControllerParams* controller_params() const {
    return scenario_->controller_params();
  }
  /// The walker, or nullptr when the scenario does not walk.
  const controllers::TorqueWalker* gait() const { return walk_ ? &walk_->walker() : nullptr; }
  const controllers::StepReport& last_report() const;
  const std::vector<sim::Push>& pushes() const { return sim_->pushes(); }
  /// Stepping stones: the steps planned so far (empty before steps_start_s, or when not walking).
  const std::vector<Stone>& stones() const;
  /// Whether the scenario walks.
  bool walking() const { return walk_ != nullptr; }
  /// Whether the scenario plays a motion kinematically (mocap without track).
  bool playback() const { return mocap_ != nullptr && mocap_->playback(); }
  /// mocap with track: the tracker (nullptr otherwise), its error now, the report.
  const controllers::MotionTracker* tracker() const { return mocap_ ? mocap_->tracker() : nullptr; }
  controllers::MotionTracker::Error tracking_error() const;
  const TrackingStats& tracking_stats() const;
  TrackingReport tracking_report() const;
  double track_start_lift_m() const { return tracking_report().start_lift_m; }
  /// The motion's length, s (mocap).
  double motion_length_s() const { return mocap_ ? mocap_->motion_length_s() : 0.0; }

  /// The parameters in the files the CLI reads: controller params JSON (`biodyn pose --params`)
  /// and walker params JSON (`biodyn walk --params`; empty when not walking).
  std::string controller_params_json() const;
  std::string gait_params_json() const;

 private:
  struct Edit {
    long step;
    std::function<void(Scenario&)> apply;
  };
  struct Checkpoint {
    long step = -1;  // -1: free (or dropped by a new edit)
    std::unique_ptr<ScenarioState> state;
  };
  void save_checkpoint();
  void restart();  // t = 0 with the initial parameters; the log is cleared, future_ kept
  void record(std::function<void(Scenario&)> apply);
  /// Drops the edits a rewound run would replay and the checkpoints after now.
  void drop_future();

  std::unique_ptr<sim::Simulation> sim_;
  std::unique_ptr<Scenario> scenario_;
  const WalkScenario* walk_ = nullptr;      // the scenario as a walk, or nullptr
  const MocapScenario* mocap_ = nullptr;    // the scenario as a mocap, or nullptr
  std::unique_ptr<ScenarioState> initial_;  // the state at t = 0

  std::vector<Edit> log_;      // every edit applied since t = 0, by step
  std::vector<Edit> pending_;  // edits for the next step
  std::vector<Edit> future_;   // after a rewind: the edits to replay at their steps
  std::size_t future_next_ = 0;
  std::vector<Checkpoint> checkpoints_;  // kCheckpoints slots
  long checkpoint_every_ = 250;          // steps
  long last_rewind_replayed_ = 0;
};

}  // namespace biodyn::scenarios
