#pragma once
/// A scenario stepped from outside, one physics step at a time, with its parameters edited while
/// it runs: what the viewer (`biodyn view`) and `biodyn render` drive (issue 6). The same
/// controllers as `biodyn pose` and `biodyn walk`: the joint controllers with their muscle
/// limits, the foot welds in the chosen mode, the standing balance or the torque walker.
///
/// Rewind is exact: every edit (parameters, speed, heading, a push) is logged with the step it
/// took effect at, and every 0.5 s of simulated time the whole state (simulation, controllers,
/// walker, scenario) is saved into a ring of checkpoints covering the last 16 s. Rewinding to
/// step k restores the newest checkpoint at or before k and replays the log from it to k (at most
/// 0.5 s of simulation); further back than the ring it rebuilds the scenario at t = 0 and replays
/// from there (slower, as exact). The simulation is deterministic (sim/determinism.h), so
/// resuming from k gives the same future the first run had, until a new edit is made (which
/// drops the logged edits and the checkpoints after k).

#include <Eigen/Core>
#include <cmath>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "biodyn/controllers/control_pipeline.h"
#include "biodyn/controllers/controller_params.h"
#include "biodyn/controllers/motion_tracker.h"
#include "biodyn/controllers/torque_walker.h"
#include "biodyn/models/character.h"
#include "biodyn/models/rig.h"
#include "biodyn/sim/simulation.h"

namespace biodyn::scenarios {

class FallWatch;  // src/fall_watch.h

/// What to build.
struct LiveConfig {
  /// "stand", "squat", "reach", "one-leg" (the pose scenarios, holding their last pose), "walk",
  /// "stones" (walk, then the stepping stones: steps_m) or "mocap" (motion_path).
  std::string scenario = "walk";
  models::CharacterSpec character;
  controllers::WeldMode weld = controllers::WeldMode::kHonest;
  double speed_m_s = 1.0;           ///< walk: commanded speed
  double heading_rate_deg_s = 0.0;  ///< walk: commanded turning rate
  /// Controller parameters (controller_params.h JSON; `biodyn pose --params`), optional.
  std::string controller_json, controller_source;
  /// Torque-walker parameters (torque_gait.h JSON; `biodyn walk --params`), optional.
  std::string gait_json, gait_source;
  /// scenario "mocap": a motion played on the character: a qpos CSV (`biodyn mocap
  /// ik|retarget`, for this character) or a BVH retargeted here with the first built-in joint
  /// map it fits. Kinematically (no physics, no controllers; it loops), or with `track` by the
  /// joint controllers (controllers/motion_tracker.h: physics, muscles within tau_max, the root
  /// free; once through, then holding the last frame's targets).
  std::string motion_path;
  /// The part of the motion played, s of its own time (to < 0: to its end); replayed from 0.
  /// A capture that stands, fidgets, walks and stops can be tracked from the walk on.
  double motion_from_s = 0, motion_to_s = -1;
  bool track = false;
  controllers::MotionTrackerParams tracker;  ///< lookahead, balance feedback and its gains
  /// scenario "stones" (paper §4.2): step lengths, m, ankle to ankle along the heading, walked
  /// from the first strike at or after steps_start_s (steady walking first); free steps after.
  /// Empty: the paper's (paper_stepping_stones_m).
  std::vector<double> steps_m;
  double steps_start_s = 5.0;

  void validate() const;  ///< throws sim::InvalidArgument naming the field
};

/// Names LiveConfig::scenario accepts.
std::vector<std::string> live_scenario_names();

/// The paper's stepping stones (§4.2): 0.60, 0.20, 0.50, 0.16, 0.50, 0.30 m.
std::vector<double> paper_stepping_stones_m();

/// scenario "stones": one planned step. Drawn where its length puts the swing foot's ankle:
/// from the stance ankle (the walker's reference; it rolls forward a little during the swing,
/// and the stone with it until the strike) along the heading, as far across as the swing ankle
/// was when the swing began (the walker plans lengths, not widths).
struct LiveStone {
  Eigen::Vector2d ankle_W = Eigen::Vector2d::Zero();  ///< m, world xy
  double heading_rad = 0;
  int side = 0;          ///< the swing foot (0 left, 1 right)
  double target_m = 0;   ///< planned length
  double across_m = 0;   ///< m, left of the stance ankle (heading frame)
  double walked_m = std::numeric_limits<double>::quiet_NaN();  ///< length at the strike; NaN: in swing
};

class LiveScenario {
 public:
  /// Builds the character, controllers and scenario at t = 0. Throws sim::InvalidArgument for a
  /// bad config (naming the field or file).
  explicit LiveScenario(LiveConfig config);
  ~LiveScenario();

  /// One physics step: pending edits first, then the controllers and mj_step. Allocates only
  /// when an edit is pending, when the stones plan starts or a stone is added, and when a
  /// checkpoint slot is first filled or its arrays grow (the first 16 s; rarely after).
  void step();
  /// Steps until simulation time reaches t_s (no-op if already there).
  void run_until(double t_s);

  long step_index() const { return run_.steps; }
  double time_s() const;
  /// Fallen by the scenarios' rule (fall_watch.h): a body other than the feet touches the floor,
  /// or the pelvis is below 0.7 x its start height. Never for a kinematic playback.
  bool fallen() const;

  // --- Edits: logged, applied before the next step. ---
  void set_controller_params(const controllers::ControllerParams& params);
  void set_gait_params(const controllers::TorqueWalkerParams& params);  ///< walk only
  void set_speed(double m_s);                                         ///< walk only
  void set_heading_rate(double deg_s);                                ///< walk only
  void set_weld_mode(controllers::WeldMode mode);
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
  /// MuJoCo data the checkpoints hold, bytes (each also holds a copy of the controllers,
  /// ~0.44 MB for the full character).
  std::size_t checkpoint_bytes() const;

  // --- Read-outs (for panels, overlays and plots). ---
  const LiveConfig& config() const { return run_.config; }
  sim::Simulation& simulation() { return *sim_; }
  /// The character's parts, resolved once (models/rig.h).
  const models::Rig& rig() const { return *rig_; }
  const sim::Simulation& simulation() const { return *sim_; }
  const controllers::ControlPipeline& controller() const { return *ctrl_; }
  const controllers::ControllerParams& controller_params() const { return run_.controller_params; }
  /// The walker, or nullptr in the pose scenarios.
  const controllers::TorqueWalker* gait() const { return gait_.get(); }
  const controllers::StepReport& last_report() const { return ctrl_->last_report(); }
  const std::vector<sim::Push>& pushes() const { return sim_->pushes(); }
  /// scenario "stones": the steps planned so far (empty before steps_start_s).
  const std::vector<LiveStone>& stones() const { return run_.stones; }
  /// Whether the scenario walks.
  bool walking() const { return gait_ != nullptr; }
  /// Whether the scenario plays a motion kinematically (scenario "mocap" without track).
  bool playback() const { return playback_.rows() > 0 && !run_.config.track; }
  /// scenario "mocap" with track: the tracker (nullptr otherwise), its error now, and how far
  /// the start was raised so the lowest sole touched the floor (m; negative: lowered).
  const controllers::MotionTracker* tracker() const { return tracker_.get(); }
  controllers::MotionTracker::Error tracking_error() const;
  /// The tracking error over the run so far, sampled every 10 steps (20 ms) while upright.
  struct TrackingStats {
    long samples = 0;
    double joint_sum_sq_rad2 = 0, joint_max_rad = 0, root_max_m = 0;
    double joint_rms_rad() const { return samples > 0 ? std::sqrt(joint_sum_sq_rad2 / static_cast<double>(samples)) : 0.0; }
  };
  const TrackingStats& tracking_stats() const { return run_.tracking_stats; }
  /// When the character first fell in this run (s), or -1.
  double fell_at_s() const { return run_.fell_at_s; }
  /// scenario mocap with track: everything the summaries report about the tracking.
  struct TrackingReport {
    bool tracked = false;
    bool balance = false;
    double motion_length_s = 0, lookahead_s = 0, start_lift_m = 0, fell_at_s = -1;
    TrackingStats stats;
    /// Did not fall while the motion lasted (after its end the targets hold its last frame).
    bool kept_up() const { return tracked && (fell_at_s < 0 || fell_at_s > motion_length_s); }
  };
  TrackingReport tracking_report() const;
  double track_start_lift_m() const { return tracked_.start_lift_m; }
  /// The motion's length, s (scenario "mocap").
  double motion_length_s() const { return playback_t_.empty() ? 0.0 : playback_t_.back(); }

  /// The parameters in the files the CLI reads: controller params JSON (`biodyn pose --params`)
  /// and walker params JSON (`biodyn walk --params`; empty for the pose scenarios).
  std::string controller_params_json() const;
  std::string gait_params_json() const;

 private:
  struct Edit {
    long step;
    std::function<void(LiveScenario&)> apply;
  };
  struct Checkpoint;  // live.cc
  void save_checkpoint();
  void restore_checkpoint(const Checkpoint& c);
  void build();
  void load_motion(const mjModel& m);
  void show_playback_frame();
  void start_tracking();
  void restart();  // t = 0 with the initial parameters; the log is cleared, future_ kept
  void record(std::function<void(LiveScenario&)> apply);
  /// Drops the edits a rewound run would replay and the checkpoints after now.
  void drop_future();

  // Everything about the run besides the simulation and the controllers' own state: what a
  // checkpoint copies along with those (one struct, so a new field cannot be left out).
  struct RunState {
    LiveConfig config;  // speed, heading and weld as edited
    controllers::ControllerParams controller_params;
    controllers::TorqueWalkerParams gait_params;
    long steps = 0;
    std::size_t pose_index = 0;  // pose scenarios: the current pose and when it began
    double pose_start_s = 0;
    double playback_time_s = 0;  // mocap, kinematic
    // scenario "stones": the stones so far, whether the plan was given, strikes seen, whether
    // the new swing's stone is still to be placed.
    std::vector<LiveStone> stones;
    bool stones_planned = false, stone_pending = false;
    int strikes_seen = 0;
    TrackingStats tracking_stats;  // mocap, tracked
    double fell_at_s = -1;
  };
  RunState run_;
  LiveConfig initial_config_;
  controllers::ControllerParams initial_controller_params_;
  controllers::TorqueWalkerParams initial_gait_params_;

  std::unique_ptr<sim::Simulation> sim_;
  std::unique_ptr<models::Rig> rig_;
  std::unique_ptr<controllers::ControlPipeline> ctrl_;
  std::unique_ptr<controllers::TorqueWalker> gait_;
  controllers::TrackedMotion tracked_;  // mocap + track
  std::unique_ptr<controllers::MotionTracker> tracker_;
  std::vector<controllers::Pose> poses_;
  Eigen::MatrixXd playback_;        // mocap: qpos per frame
  std::vector<double> playback_t_;  // mocap: s, per frame
  std::unique_ptr<FallWatch> fall_;  // the scenarios' fall rule, from the start of each run
  bool stones_ = false;              // scenario "stones" (not a string compare per step)
  void track_stones();

  std::vector<Edit> log_;      // every edit applied since t = 0, by step
  std::vector<Edit> pending_;  // edits for the next step
  std::vector<Edit> future_;   // after a rewind: the edits to replay at their steps
  std::size_t future_next_ = 0;
  std::vector<std::unique_ptr<Checkpoint>> checkpoints_;  // kCheckpoints slots, step -1 = free
  long checkpoint_every_ = 250;                           // steps
  long last_rewind_replayed_ = 0;
};

}  // namespace biodyn::scenarios
