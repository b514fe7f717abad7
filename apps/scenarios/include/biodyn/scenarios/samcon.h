#pragma once
/// Sampling-based tracking of a captured motion (SAMCON: Liu et al. 2010, "Sampling-based
/// contact-rich motion control"), on top of the feedback tracker (controllers/motion_tracker.h).
///
/// Why this method: the feedback tracker alone keeps up with the body's own walk but falls
/// within a second of captured walks (walking5 at 0.52 s, the CMU clip at 0.73 s): its feedback
/// cannot plan a correction that pays off a step later. SAMCON searches for one, with physics
/// only: the motion is cut into windows (0.1 s); from each kept state ("parent") children are
/// simulated with random open-loop offsets on the joint targets (hips, knees, ankles, lumbar),
/// held over the window; the children closest to the motion at the window's end (and leaning
/// least on the joints' range stops beyond tau_max: load_scale) become the next parents. The best
/// leaf's chain of offsets is the control. Nothing acts on the root unless the config asks for a
/// residual (then reported): the joints (within tau_max, through the muscles when they are on)
/// and the floor move the body, so a motion the body cannot do still ends in a fall, reported.
///
/// Deterministic whatever the thread count: every child's offsets come from a counter-based
/// generator keyed by (seed, window, attempt, parent, child); each rollout writes its own slot;
/// the selection sorts by (cost, index) on one thread.

#include <Eigen/Core>
#include <array>
#include <functional>
#include <string>
#include <vector>

#include "biodyn/models/character.h"
#include "biodyn/models/mjcf.h"
#include "biodyn/scenarios/scenario.h"

namespace biodyn::scenarios {

struct SamconParams {
  double window_s = 0.1;   ///< s, offsets are held over a window
  int parents = 40;        ///< states kept per window
  int children = 20;       ///< rollouts per parent per window
  int max_attempts = 3;    ///< a window whose children all fall is sampled again, sigma x 1.5
  std::uint64_t seed = 1;  ///< the offsets' random stream
  int threads = 0;         ///< 0: every core
  /// rad: standard deviation of the offsets on hip (each of 3), knee, ankle (each of 2) and
  /// lumbar/thorax DOFs; other joints (arms, neck, toes) get none.
  double sigma_hip_rad = 0.12, sigma_knee_rad = 0.12, sigma_ankle_rad = 0.12,
         sigma_trunk_rad = 0.05;
  /// Cost scales: a joint RMS of joint_scale_rad, a root this far off horizontally or
  /// vertically, a pelvis turned this much, or a CoM this much faster each cost 1.
  double joint_scale_rad = 0.03, root_scale_m = 0.05, pelvis_scale_rad = 0.1,
         com_speed_scale_m_s = 0.3;
  /// A joint load (motor + range stop, TrackingStats) this far over tau_max through a window
  /// costs as much as one of the scales above: a path may not lean on the stops for free
  /// (impacts under 10 ms excepted: sim/joint_load.h).
  double load_scale = 0.1;
  void validate() const;  ///< throws sim::InvalidArgument naming the field
};

struct SamconResult {
  int windows = 0;               ///< windows planned (the motion's length / window_s)
  int windows_kept_up = 0;       ///< windows the best path got through without a fall
  double fell_at_s = -1;         ///< s, the best path's fall (-1: none while the motion lasts)
  long rollouts = 0, steps = 0;  ///< simulated in the search
  double simulated_s = 0;        ///< s, the search's steps x the timestep
  double wall_s = 0;
  /// The best path, replayed from the start: its offsets per window (windows x nv) and the
  /// tracking statistics of the replay (identical to the search's: a test).
  Eigen::MatrixXd offsets_rad;
  double joint_rms_rad = 0, joint_max_rad = 0, root_max_m = 0;
  double cost = 0;  ///< the best path's summed window costs
  /// The search's own statistics of the best path (its leaf's state): the replay must match.
  double search_joint_rms_rad = 0, search_root_max_m = 0;
  /// The replay's poses at every window end and its times (for the tracked motion output).
  std::vector<double> times_s;
  Eigen::MatrixXd qpos;          ///< frames x nq, one per `record_every_steps` step of the replay
  double peak_torque_ratio = 0;  ///< max over the replay of |tau| / tau_max
  JointLoadReport joint_load;    ///< the replay's joint stops beside its motors
  /// Dorsiflexion added to a swinging foot's first pose to start it clear of the floor, rad,
  /// left and right (TrackedMotion::start_swing_lift_rad).
  std::array<double, 2> start_swing_lift_rad{0.0, 0.0};
  std::array<double, 2> start_swing_clearance_m{0.0, 0.0};  ///< the lifted feet's then, m
  /// The replay's residual on the pelvis (ScenarioConfig::residual; 0 without it).
  double residual_force_rms_N = 0, residual_force_peak_N = 0;
  double residual_moment_rms_Nm = 0, residual_moment_peak_Nm = 0;
};

/// Runs SAMCON for the motion `config` names (scenario "mocap", track on) on the body
/// `config.model_spec()` with `physics`. `progress` gets the fraction of windows done. Throws
/// sim::InvalidArgument for bad params or config.
SamconResult run_samcon(const ScenarioConfig& config, const models::PhysicsOptions& physics,
                        const SamconParams& params, int record_every_steps = 5,
                        const std::function<void(double)>& progress = {});

}  // namespace biodyn::scenarios
