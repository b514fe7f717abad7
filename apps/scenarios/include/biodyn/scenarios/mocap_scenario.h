#pragma once
/// The mocap scenario: a captured motion on the character, played kinematically (no physics, no
/// controllers; it loops) or tracked by the joint controllers (controllers/motion_tracker.h:
/// physics, muscles within tau_max, the root moved only by muscles and contacts unless a
/// residual is asked for (ScenarioConfig::residual, reported); once through,
/// then holding the last frame's targets). The motion is a qpos CSV (`biodyn mocap ik` or
/// `retarget`, for this character) or a BVH retargeted here with the first built-in joint map
/// that fits; the part config.motion_from_s..motion_to_s is played, from 0.

#include <Eigen/Core>
#include <array>
#include <cmath>
#include <memory>
#include <optional>
#include <vector>

#include "biodyn/controllers/control_pipeline.h"
#include "biodyn/controllers/motion_tracker.h"
#include "biodyn/scenarios/scenario.h"
#include "biodyn/sim/joint_load.h"

namespace biodyn::scenarios {

/// The tracking error over a run, sampled every 10 steps (20 ms) while upright and while the
/// motion lasts.
struct TrackingStats {
  long samples = 0;
  double joint_sum_sq_rad2 = 0, joint_max_rad = 0, root_max_m = 0;
  double joint_rms_rad() const {
    return samples > 0 ? std::sqrt(joint_sum_sq_rad2 / static_cast<double>(samples)) : 0.0;
  }
  /// Every step while tracking: the motors' and the joints' range stops' load (joint_load.h;
  /// the toes not judged).
  sim::JointLoadStats load;
  /// The residual on the pelvis (ScenarioConfig::residual), every step while tracking: sums of
  /// squares and peaks of its force (N) and its moment about the root's origin (N m).
  long residual_steps = 0;
  double residual_force_sum_sq = 0, residual_force_peak_N = 0;
  double residual_moment_sum_sq = 0, residual_moment_peak_Nm = 0;
  double residual_force_rms_N() const { return rms(residual_force_sum_sq); }
  double residual_moment_rms_Nm() const { return rms(residual_moment_sum_sq); }

 private:
  double rms(double sum_sq) const {
    return residual_steps > 0 ? std::sqrt(sum_sq / static_cast<double>(residual_steps)) : 0.0;
  }
};

/// Everything the summaries report about a tracked motion.
struct TrackingReport {
  bool tracked = false;
  bool balance = false;
  double motion_length_s = 0, lookahead_s = 0, start_lift_m = 0, fell_at_s = -1;
  /// Dorsiflexion added to each foot's first pose so a swinging foot starts clear of the floor
  /// (TrackedMotion::start_swing_lift_rad), rad, left and right.
  std::array<double, 2> start_swing_lift_rad{0.0, 0.0};
  std::array<double, 2> start_swing_clearance_m{0.0, 0.0};  ///< the lifted feet's, m
  TrackingStats stats;
  /// Did not fall while the motion lasted (after its end the targets hold its last frame).
  bool kept_up() const { return tracked && (fell_at_s < 0 || fell_at_s > motion_length_s); }
};

class MocapScenario : public Scenario {
 public:
  /// Reads the motion (throws sim::InvalidArgument naming the file: unreadable, no joint map
  /// fits, fewer than 2 solved frames in the part asked for, or unsolved frames inside a
  /// tracked part) and builds at t = 0 on its first frame (tracked: floored, moving as it does).
  MocapScenario(sim::Simulation* sim, ScenarioConfig config);
  ~MocapScenario() override;

  bool finished() const override { return false; }
  /// A kinematic playback never falls; a tracked one by the walking rule.
  bool fallen() const override;
  const MocapScenario* mocap() const override { return this; }
  const controllers::ControlPipeline* pipeline() const override { return pipeline_.get(); }
  const controllers::ControllerParams* controller_params() const override;
  void set_controller_params(const controllers::ControllerParams& params) override;
  void set_weld_mode(controllers::WeldMode mode) override;
  void push(int body, const Eigen::Vector3d& force_W, double duration_s) override;

  /// Whether the motion is played kinematically (not tracked).
  bool playback() const { return !config_.track; }
  /// The tracker (nullptr for a playback) and its error now.
  const controllers::MotionTracker* tracker() const { return tracker_.get(); }
  controllers::MotionTracker::Error tracking_error() const;
  TrackingReport tracking_report() const;
  const TrackingStats& tracking_stats() const { return stats_; }
  /// Open-loop corrections added to the tracker's joint targets from the next step
  /// (MotionTracker::set_offsets; samcon.h). Not part of the saved state: set before stepping.
  void set_tracking_offsets(const Eigen::VectorXd& offsets_rad) {
    if (tracker_) tracker_->set_offsets(offsets_rad);
  }
  /// The motion as tracked (floored at its first frame); valid when tracked.
  const controllers::TrackedMotion& tracked_motion() const { return tracked_; }
  /// The motion's length, s.
  double motion_length_s() const { return times_.empty() ? 0.0 : times_.back(); }

  std::unique_ptr<ScenarioState> new_state() const override;
  void save(ScenarioState* state) const override;
  void restore(const ScenarioState& state) override;

 private:
  struct State;
  void advance() override;
  void after_step() override;
  void load_motion();
  void show_playback_frame();
  void start_tracking();
  void apply_residual();

  Eigen::MatrixXd frames_;     // qpos per frame
  std::vector<double> times_;  // s, per frame, from 0
  controllers::TrackedMotion tracked_;
  controllers::ControllerParams params_;
  std::unique_ptr<controllers::ControlPipeline> pipeline_;  // tracked only
  std::unique_ptr<controllers::MotionTracker> tracker_;     // tracked only
  double playback_time_s_ = 0;
  TrackingStats stats_;
  std::unique_ptr<FallWatch> fall_;
  std::unique_ptr<sim::JointLoadMeter> load_meter_;  // tracked only
  // The residual wrench on the pelvis now as written to xfrc_applied (force, moment at its CoM;
  // world), added as a change so pushes there stay; its moment about the root's origin (the
  // reported one); the pose scratch (nq) for the motion's root. (A MuJoCo reset after a bad
  // acceleration zeroes xfrc_applied: the run is broken by then.)
  Eigen::Matrix<double, 6, 1> residual_W_ = Eigen::Matrix<double, 6, 1>::Zero();
  double residual_moment_Nm_ = 0;
  std::vector<double> residual_pose_, residual_pose_next_;
  double body_mass_kg_ = 0;
};

}  // namespace biodyn::scenarios
