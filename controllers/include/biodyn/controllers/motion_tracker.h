#pragma once
/// Tracking a captured motion with the joint controllers (issue 6: mocap playback "tracked by
/// the controllers"). Every step each joint group's target is the motion's orientation
/// `lookahead_s` ahead, due then: the velocity-based controller (joint_controller.h, paper §3.2)
/// then turns at the motion's own rate plus the error over the lookahead. Each foot is wanted
/// in stance (and may weld, in the chosen weld mode) while the motion has it on the floor.
///
/// The root is not driven: only the muscles (within tau_max) and the contacts move the body, so a
/// motion this body cannot balance ends in a fall. That is an answer, not a failure of the
/// tracker; there is no balance feedback here.

#include <Eigen/Core>
#include <array>
#include <vector>

#include "biodyn/controllers/character_controller.h"
#include "biodyn/controllers/joint_groups.h"

namespace biodyn::controllers {

/// A motion to track: qpos per frame for this model, and where each foot is on the floor.
struct TrackedMotion {
  std::vector<double> times_s;  ///< from 0, increasing
  Eigen::MatrixXd qpos;         ///< frames x nq
  /// Per frame: left and right foot on the floor (lowest sole point below
  /// kStanceHeight_m and the foot slower than kStanceSpeed_m_s horizontally).
  std::vector<std::array<bool, 2>> stance;
  static constexpr double kStanceHeight_m = 0.02;
  static constexpr double kStanceSpeed_m_s = 0.4;
};

/// Builds a TrackedMotion from qpos frames (forward kinematics on `m`; bodies foot_l/_r and
/// toes_l/_r with box geoms). Throws sim::InvalidArgument for fewer than 2 frames, times not
/// increasing or a qpos row of the wrong size.
TrackedMotion make_tracked_motion(const mjModel& m, const std::vector<double>& times_s, const Eigen::MatrixXd& qpos);

/// The motion's pose at time t (clamped to its ends): hinges interpolated linearly, ball joints
/// and the root orientation by slerp. `qpos` must have nq entries.
void motion_pose_at(const mjModel& m, const TrackedMotion& motion, double t_s, double* qpos);

class MotionTracker : public TargetDriver {
 public:
  MotionTracker(const mjModel& m, std::vector<JointGroup> groups, const TrackedMotion* motion,
                double lookahead_s = 0.1);
  void drive(CharacterController& controller, const mjModel& m, const mjData& d) override;

  /// How far the body is from the motion at the current time: RMS over the joint groups of
  /// the rotation between the body's and the motion's joint orientation (rad), and the
  /// pelvis's horizontal distance from the motion's (m).
  struct Error {
    double joint_rms_rad = 0;
    double root_horizontal_m = 0;
  };
  Error error(const mjModel& m, const mjData& d) const;

  double lookahead_s() const { return lookahead_s_; }

 private:
  Eigen::Quaterniond group_orientation(const mjModel& m, const JointGroup& g, const double* qpos) const;

  std::vector<JointGroup> groups_;
  const TrackedMotion* motion_;
  double lookahead_s_;
  mutable std::vector<double> pose_;  // nq scratch (drive and error: one thread)
};

}  // namespace biodyn::controllers
