#pragma once
/// The scenario interface: what `biodyn pose`, `walk`, `push`, `push-sweep`, `render` and the
/// viewer run. A scenario owns the character's controllers on a simulation it is given, and its
/// schedule (poses, walking commands, stepping stones, a timed push, a stop, a captured motion);
/// observers measure it (metrics, traces, push judging) without changing it.
///
///   auto s = make_scenario(&sim, config);   // registry.h: built at t = 0
///   s->add_observer(&metrics);
///   while (!s->finished()) s->step();       // or a LiveScenario stepping it from outside
///
/// A new scenario is a class deriving from Scenario plus one line in the registry (registry.cc).
/// Everything a scenario's future depends on is in one state aggregate (save/restore: the
/// viewer's rewind). Parameters edited live (controller and walker parameters, speed, heading,
/// weld mode) are part of that state: an edit is a step in its history.

#include <Eigen/Core>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "biodyn/controllers/control_pipeline.h"
#include "biodyn/controllers/controller_params.h"
#include "biodyn/controllers/foot_contact.h"
#include "biodyn/controllers/motion_tracker.h"
#include "biodyn/controllers/torque_walker.h"
#include "biodyn/models/character.h"
#include "biodyn/models/mjcf.h"
#include "biodyn/models/rig.h"
#include "biodyn/muscles/muscle_drive.h"
#include "biodyn/muscles/muscle_set.h"
#include "biodyn/sim/joint_load.h"
#include "biodyn/sim/simulation.h"

namespace biodyn::scenarios {

class Scenario;
class WalkScenario;
class MocapScenario;
class FallWatch;  // src/fall_watch.h

// --- One value per rule ---
/// m/s, the commanded walking speeds the torque walker is run at (0.5-1.5 m/s tested).
inline constexpr double kMinWalkSpeed_m_s = 0.3, kMaxWalkSpeed_m_s = 2.0;
/// deg/s, the commanded turning rate's bound.
inline constexpr double kMaxHeadingRate_deg_s = 90.0;
/// Throw sim::InvalidArgument naming the value when a commanded speed (m/s) or turning rate
/// (deg/s) is outside those bounds: the config, the walk scenario's and the viewer's edits.
void check_walk_speed(double m_s);
void check_heading_rate(double deg_s);
/// Fallen = a body other than the feet touches the floor, or the pelvis is below this fraction
/// of its standing height: references.md (>= 0.7 x nominal is upright while walking) ...
inline constexpr double kWalkingFallPelvisFraction = 0.7;
/// ... and 0.6 while standing, which leaves room for the squat (pelvis at 0.79 x in it).
inline constexpr double kStandingFallPelvisFraction = 0.6;

/// A horizontal push through a body's centre of mass at a given time (references.md).
struct TimedPush {
  double force_N = 0;        ///< N, >= 0
  double duration_s = 0.2;   ///< s, > 0
  double direction_deg = 0;  ///< deg, 0 = forward (+x), 90 = to the character's left
  double onset_s = 1.0;      ///< s, simulation time of onset
  std::string body = "pelvis";
};

/// One horizontal push during steady walking, through the centre of mass of the pelvis or the
/// trunk (xfrc_applied), timed by the gait: after `settle_strides` strides (a stride starts at
/// a left-foot strike, at least 4) and once the walk is steady (the last 4 strides' speeds each
/// within 5 % of their mean; not pushed if not within 30 strides more: walk_scenario.cc), at
/// `onset_phase` of the next stride (its length taken from the stride before).
struct WalkPush {
  double force_N = 0;           ///< N, >= 0
  double duration_s = 0.2;      ///< s, > 0
  double direction_deg = 0;     ///< deg, relative to the heading: 0 forward, 90 left
  std::string body = "pelvis";  ///< "pelvis" or "trunk" (the thorax), or any body name
  double onset_phase = 0;       ///< [0, 1), fraction of the stride
  int settle_strides = 5;       ///< strides walked before the push's stride, at least (>= 1)
  double watch_s = 5.0;         ///< s, watched after the push ends (references.md: 5 s)
};

/// The legs' Hill muscles (`--muscles on`): the joint controllers' torques on the legs are shared
/// among them, with backups (muscles/muscle_drive.h). The character must be generated with
/// muscles (CharacterSpec::muscles, which model_spec() sets).
struct MuscleConfig {
  bool on = false;
  muscles::TendonChoice tendons = muscles::TendonChoice::kPerMuscle;
  /// A muscle parameter file's text and name (`--muscle-params`; muscle_set.h), optional.
  std::string params_json, params_source;
  muscles::MuscleDriveParams drive;
};

/// What a run's muscles did, per joint (the rig's joint groups: a hip's three DOFs together, an
/// ankle's two hinges together): integrals over the
/// run of the torque magnitudes the muscles gave, the backups gave, and the controller wanted
/// but neither gave (beyond the backups' range), N m s.
struct MuscleJointShare {
  std::string joint;
  double muscle_Nms = 0, backup_Nms = 0, not_given_Nms = 0;
  /// backup / (muscle + backup): the "backups' share of the joint torque".
  double backup_share() const {
    return muscle_Nms + backup_Nms > 0 ? backup_Nms / (muscle_Nms + backup_Nms) : 0.0;
  }
};
struct MuscleRunReport {
  std::vector<std::string> muscles;
  int compliant_tendons = 0, rigid_tendons = 0;
  std::vector<MuscleJointShare> joints;
  int qp_failures = 0, fiber_solve_failures = 0;
};
/// The report of `pipeline`'s muscles so far; nullopt without muscles.
std::optional<MuscleRunReport> muscle_report(const controllers::ControlPipeline& pipeline);

/// What the joints' range stops carried beside the motors over a run (sim/joint_load.h), with
/// the DOFs named (mocap_io::dof_names; "" when none).
struct JointLoadReport {
  double stop_peak_Nm = 0;                ///< largest stop torque
  double load_peak_ratio = 0;             ///< largest |motor + stop| / tau_max of a judged DOF
  double over_s = 0, over_longest_s = 0;  ///< s with a load above 1: in all, longest stretch
  std::string stop_peak_dof, load_peak_dof;
  std::string over_longest_dof;  ///< the worst DOF as the longest stretch ended
};
JointLoadReport joint_load_report(const mjModel& m, const sim::JointLoadStats& stats);

/// Everything a scenario is built from. Fields a scenario does not use must keep their
/// defaults (validate() refuses them, naming the option, rather than ignoring them).
struct ScenarioConfig {
  /// A registered name (registry.h): "stand", "squat", "reach", "one-leg" (the pose
  /// scenarios), "walk", "stones" (walk, then stepping stones) or "mocap".
  std::string scenario = "walk";
  /// The body the simulation's model was generated from (mocap retargets a BVH onto it).
  models::CharacterSpec character;

  // The control pipeline (every scenario but a kinematic playback).
  controllers::ControllerKind controller = controllers::ControllerKind::kVelocity;
  controllers::WeldMode weld = controllers::WeldMode::kHonest;
  double reaction_time_s = 0;  ///< s; > 0 replaces every joint's t_r
  /// Controller parameter overrides (controller_params.h JSON; `--controller-params`), optional.
  std::string controller_json, controller_source;
  MuscleConfig muscles;

  // Pose scenarios.
  /// s; 0: the scenario's own length; longer: the last pose holds (0 in the viewer: forever).
  double pose_duration_s = 0;
  std::optional<TimedPush> pose_push;

  // Walking ("walk", "stones").
  double speed_m_s = 1.0;           ///< m/s, commanded speed
  double heading_rate_deg_s = 0.0;  ///< deg/s, commanded turning rate (+ to the left)
  /// How the walker drives the joints: PD torques (SIMBICON) or the paper's velocity-based
  /// controllers (torque_walker.h, WalkerActuation; `--controller torque|velocity`).
  controllers::WalkerActuation walker_actuation = controllers::WalkerActuation::kTorque;
  /// Torque-walker parameter overrides (torque_walker.h JSON; `biodyn walk --params`), optional.
  std::string gait_json, gait_source;
  /// "stones" (paper §4.2): step lengths, m, ankle to ankle along the heading, walked from the
  /// first strike at or after steps_start_s (steady walking first); free steps after. Empty:
  /// the paper's (paper_stepping_stones_m).
  std::vector<double> steps_m;
  /// Stones placed in 2D: each stone's offset, m, to the left of its foot's line (the walkway's
  /// lines lie the hips' spacing apart, centred on the stance foot where the plan starts);
  /// empty: the balance feedback places the feet across. One per step length.
  std::vector<double> steps_lateral_m;
  double steps_start_s = 5.0;
  /// The ground ahead (models::Terrain) in the scene the live scenario builds (the CLI's walks
  /// build theirs with the physics options).
  models::Terrain terrain;
  /// s; >= 0: from this time the walker stops (a half step, then the feet side by side) and the
  /// character is handed to the standing controller (pose "stand" with its balance).
  double stop_at_s = -1;
  std::optional<WalkPush> walk_push;

  // "mocap": a motion played on the character: a qpos CSV (`biodyn mocap ik|retarget`, for this
  // character) or a BVH retargeted here with the first built-in joint map it fits. Kinematically
  // (no physics, no controllers; it loops), or with `track` by the joint controllers
  // (controllers/motion_tracker.h: physics, muscles within tau_max, the root free; once
  // through, then holding the last frame's targets).
  std::string motion_path;
  /// The part of the motion played, s of its own time (to < 0: to its end); replayed from 0.
  double motion_from_s = 0, motion_to_s = -1;
  bool track = false;
  controllers::MotionTrackerParams tracker;  ///< lookahead, balance feedback and its gains
  /// Tracking only, and only when asked: a residual force and moment on the pelvis (a "hand of
  /// god") pulling the root to the motion's, reported (TrackingStats::residual_*).
  bool residual = false;

  /// Throws sim::InvalidArgument naming the field, the rule and the value.
  void validate() const;
  /// The walker's parameters: the actuation's defaults with gait_json over them (throws
  /// sim::InvalidArgument naming gait_source and the field).
  controllers::TorqueWalkerParams walker_params() const;
  /// The body to generate the simulation's model from: `character`, with the muscles' tendons
  /// when muscles are on.
  models::CharacterSpec model_spec() const;
  /// The control pipeline's configuration: controller kind, weld mode, and the muscles (their
  /// parameters from the character's anatomy, the tendon choice and the parameter file).
  /// Throws sim::InvalidArgument for a bad muscle parameter file.
  controllers::ControlPipelineConfig pipeline_config() const;
  /// Whether the scenario walks ("walk", "stones").
  bool walking() const { return scenario == "walk" || scenario == "stones"; }
};

/// The paper's stepping stones (§4.2): 0.60, 0.20, 0.50, 0.16, 0.50, 0.30 m.
std::vector<double> paper_stepping_stones_m();

/// A scenario's whole state at one step (save/restore); each scenario has its own.
class ScenarioState {
 public:
  virtual ~ScenarioState() = default;
  /// Bytes held (the MuJoCo data dominates), for the rewind ring's report.
  virtual std::size_t bytes() const = 0;
};

/// Measures a scenario while it runs: called after every step. May end the run (a push judged).
class StepObserver {
 public:
  virtual ~StepObserver() = default;
  virtual void on_step(const Scenario& scenario) = 0;
  /// True once the observer has what it watched for (the run may end).
  virtual bool done() const { return false; }
};

class Scenario {
 public:
  virtual ~Scenario() = default;

  /// The configuration, as edited since (speed, heading rate, weld mode).
  const ScenarioConfig& config() const { return config_; }
  sim::Simulation& simulation() { return *sim_; }
  const sim::Simulation& simulation() const { return *sim_; }
  const models::Rig& rig() const { return rig_; }

  /// One physics step: the scenario's schedule, the controllers and mj_step, then the observers.
  /// No allocation in the step loop (the scenario's own logs aside: stones, strikes).
  void step();
  /// Steps until simulation time reaches t_s (no-op if already there).
  void run_until(double t_s);
  /// Steps taken since t = 0.
  long step_index() const { return steps_; }
  /// The scenario's own end (its duration, a fall that ends it); observers may end a run
  /// earlier (done()).
  virtual bool finished() const = 0;
  /// Whether the run should stop: finished() or an observer done.
  bool run_over() const;
  void add_observer(StepObserver* observer) { observers_.push_back(observer); }

  /// Fallen now by the scenario's rule (a body other than the feet on the floor, or the pelvis
  /// below its fall fraction of the standing height); never for a kinematic playback.
  virtual bool fallen() const = 0;
  /// When it first fell (s), or -1.
  double fell_at_s() const { return fell_at_s_; }
  /// When the simulation diverged (s; MuJoCo's bad qpos, qvel or qacc, after which it resets
  /// the data to the model's start), or -1. The run ends there, counted as a fall at that time:
  /// the reset state is never measured as if the body had stood up again.
  double diverged_at_s() const { return diverged_at_s_; }

  // --- Read-outs for specific scenarios (nullptr otherwise) ---
  /// The control pipeline, or nullptr (a kinematic playback).
  virtual const controllers::ControlPipeline* pipeline() const = 0;
  virtual const WalkScenario* walk() const { return nullptr; }
  virtual const MocapScenario* mocap() const { return nullptr; }

  // --- Edits (the viewer; each throws sim::InvalidArgument if this scenario has no such
  // parameter or the value is out of range). Applied at once, between steps. ---
  virtual void set_controller_params(const controllers::ControllerParams& params);
  virtual void set_weld_mode(controllers::WeldMode mode);
  virtual void set_walker_params(const controllers::TorqueWalkerParams& params);
  /// The walker's actuation (torque_walker.h): PD torques or the velocity-based controllers.
  virtual void set_walker_actuation(controllers::WalkerActuation actuation);
  virtual void set_speed(double m_s);
  virtual void set_heading_rate(double deg_s);
  /// A force through the CoM of `body` (a body id) for `duration_s`, from the next step.
  virtual void push(int body, const Eigen::Vector3d& force_W, double duration_s);

  /// The controller parameters in use (validated), and as the JSON `--controller-params` reads.
  virtual const controllers::ControllerParams* controller_params() const { return nullptr; }

  // --- Rewind ---
  /// A state object for this scenario (to save into).
  virtual std::unique_ptr<ScenarioState> new_state() const = 0;
  /// Saves everything the future depends on into `state` (its storage is reused once grown).
  virtual void save(ScenarioState* state) const = 0;
  /// Restores a state saved from this scenario: the following steps repeat bit for bit.
  virtual void restore(const ScenarioState& state) = 0;

 protected:
  /// `sim` must outlive the scenario; it is reset by the subclass's build.
  Scenario(sim::Simulation* sim, ScenarioConfig config);
  /// The scenario's own step (schedule, controllers, mj_step, its bookkeeping).
  virtual void advance() = 0;
  /// After a step is counted and a fall noted: read-outs that depend on them.
  virtual void after_step() {}
  /// Controller parameters from the config (defaults, the JSON file, the reaction time).
  controllers::ControllerParams controller_params_from_config() const;
  /// Records the first fall (called by step after advance).
  void note_fall();
  /// The part of the state every scenario has (save/restore of the subclasses).
  void save_common(struct CommonState* out) const;
  void restore_common(const struct CommonState& in);

  ScenarioConfig config_;
  sim::Simulation* sim_;
  models::Rig rig_;
  long steps_ = 0;
  double fell_at_s_ = -1;
  double diverged_at_s_ = -1;

 private:
  std::vector<StepObserver*> observers_;
};

/// The simulation state, the configuration as edited, the step count and the fall time: what
/// every scenario's state holds.
struct CommonState {
  sim::Simulation::Checkpoint sim;
  ScenarioConfig config;
  long steps = 0;
  double fell_at_s = -1;
  double diverged_at_s = -1;
  std::size_t bytes() const { return sizeof(*this) + sim.data.bytes(); }
};

}  // namespace biodyn::scenarios
