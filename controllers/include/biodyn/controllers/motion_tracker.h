#pragma once
/// Tracking a captured motion with the joint controllers (issue 6: mocap playback "tracked by
/// the controllers"). Every step each joint group's target is the motion's orientation
/// `lookahead_s` ahead, due then: the velocity-based controller (joint_controller.h, paper §3.2)
/// then turns at the motion's own rate plus the error over the lookahead. Each foot is wanted
/// in stance (and may weld, in the chosen weld mode) while the motion has it on the floor.
///
/// Balance feedback on the deviation from the motion (SIMBICON, Yin et al. 2007, applied to a
/// reference motion as in Lee et al. 2010, "Data-driven biped control"), both through joint
/// targets only:
///  - a stance hip's target is the one that turns the pelvis to the motion's world orientation
///    with the thigh where it is (the stance leg carries the trunk; SIMBICON's torso control),
///    and with the foot on the floor the thigh's own rotation is fed forward, as the velocity
///    walker's stance hip does (velocity_walker.h step 3);
///  - in double support both ankles lean the body (dorsiflexion) by
///    -(a_d * (d - d_ref) + a_v * (v - v_ref)), d the CoM relative to the midpoint of the
///    ankles (the ankle strategy of standing balance, on the deviation from the motion);
///  - in single support the swing hip's flexion and abduction targets are moved by
///    c_d * (d - d_ref) + c_v * (v - v_ref): d the CoM relative to the stance ankle, v the CoM
///    velocity, in the pelvis's heading frame, the ref values the motion's own.
/// Open loop or not, the ankle of every foot on the floor is held to the torque its contacts
/// can return (ankle_window.h): a foot stays flat rather than rocking on an edge.
/// The root is not driven: only the muscles (within tau_max) and the contacts move the body, so
/// a motion this body cannot keep up with still ends in a fall; that is reported, not hidden.

#include <Eigen/Core>
#include <array>
#include <cmath>
#include <vector>

#include "biodyn/controllers/control_driver.h"
#include "biodyn/controllers/joint_groups.h"
#include "biodyn/models/rig.h"
#include "biodyn/sim/queries.h"

namespace biodyn::controllers {

/// A motion to track: qpos per frame for this model, and where each foot is on the floor.
struct TrackedMotion {
  std::vector<double> times_s;  ///< from 0, increasing
  Eigen::MatrixXd qpos;         ///< frames x nq, raised by start_lift_m
  /// m the motion was raised (negative: lowered) so the first frame's lowest sole point
  /// touches the floor.
  double start_lift_m = 0;
  /// Per frame: left and right foot on the floor (lowest sole point below
  /// kStanceHeight_m and the foot slower than kStanceSpeed_m_s horizontally, its speed over
  /// +-kVelocityWindow_s: a retargeted stance foot jitters by centimetres between frames).
  std::vector<std::array<bool, 2>> stance;
  /// Per frame: the whole-body CoM and its velocity (central differences over
  /// +-kVelocityWindow_s), and each foot's origin (the ankle), world, for the balance feedback.
  std::vector<Eigen::Vector3d> com_W, com_velocity_W;
  std::vector<std::array<Eigen::Vector2d, 2>> ankle_W;
  /// rad of ankle dorsiflexion added to each foot's first pose where the motion has that foot
  /// off the floor with its toes within kSwingClearance_m of it and not leaving it (0
  /// elsewhere): the simulation starts with it clear. Captured and retargeted swings pass their
  /// toes within millimetres of the floor (walking5 through IK: 0-2 mm at 4 m/s in its first 65
  /// ms), and a body set down with a toe touching the floor at swing speed trips at once (walking5
  /// from its first frame: thrown 5 cm up in 0.1 s, fell at 0.42 s; with the toes clear it kept
  /// up). People clear it by 1-2 cm at mid-swing (Winter 1992: minimum toe clearance 1.29 +- 0.62
  /// cm). Only the start: the targets stay the motion's, and a toe that grazes later meets the
  /// floor through the dynamics.
  std::array<double, 2> start_swing_lift_rad{0.0, 0.0};
  /// m, a lifted foot's lowest point above the floor in the lifted first pose (the motion
  /// floored again on it); 0 for a foot not lifted.
  std::array<double, 2> start_swing_clearance_m{0.0, 0.0};
  static constexpr double kSwingClearance_m = 0.015;
  static constexpr double kSwingLiftMax_rad = 15 * M_PI / 180;
  static constexpr double kStanceHeight_m = 0.02;
  static constexpr double kStanceSpeed_m_s = 0.4;
  static constexpr double kVelocityWindow_s = 0.05;
  /// The frame nearest t (clamped to the motion).
  std::size_t frame_at(double t_s) const;
};

/// Builds a TrackedMotion from qpos frames (forward kinematics on `m`; the rig's feet and toes
/// with their box geoms), floored at its first frame (start_lift_m). Throws sim::InvalidArgument
/// for fewer than 2 frames, times not increasing or a qpos row of the wrong size, and
/// models::RigError for a model without feet.
TrackedMotion make_tracked_motion(const mjModel& m, const models::Rig& rig,
                                  const std::vector<double>& times_s, const Eigen::MatrixXd& qpos);

/// The motion's pose at time t (clamped to its ends): hinges interpolated linearly, ball joints
/// and the root orientation by slerp. `qpos` must have nq entries.
void motion_pose_at(const mjModel& m, const TrackedMotion& motion, double t_s, double* qpos);

struct MotionTrackerParams {
  double lookahead_s = 0.1;  ///< s, targets are the motion this far ahead
  bool balance = true;       ///< the stance-hip pelvis control and the swing placement feedback
  double sagittal_cd =
      0.5;  ///< rad of swing hip flexion per m of CoM further ahead than the motion's
  double sagittal_cv = 0.2;  ///< rad per m/s of CoM faster forward than the motion's
  double frontal_cd = 0.5;   ///< rad of swing hip abduction (towards the CoM's side) per m
  double frontal_cv = 0.3;   ///< rad per m/s
  double ankle_cd =
      1.0;  ///< double support: rad of ankle plantarflexion per m of CoM ahead of the motion's
  double ankle_cv = 0.3;  ///< rad per m/s
  /// Feet on the floor (open loop too): ankle torques held to what the ground returns with the
  /// centre of pressure inside this fraction of the contacts' extent (ankle_window.h; 0: off).
  double ankle_cop_margin = 0.8;
  void validate() const;  ///< throws sim::InvalidArgument naming the field
};

class MotionTracker : public ControlDriver {
 public:
  /// Throws models::RigError for a rig without ball hips, ankles, thighs and feet, and
  /// sim::InvalidArgument for bad params. `rig` and `motion` must outlive the tracker.
  MotionTracker(const mjModel& m, const models::Rig& rig, const TrackedMotion* motion,
                MotionTrackerParams params = {});
  void drive(const ControlInput& in, ControlFrame* frame) override;

  /// How far the body is from the motion at the current time: RMS over the joint groups of
  /// the rotation between the body's and the motion's joint orientation (rad), and the
  /// pelvis's horizontal distance from the motion's (m).
  struct Error {
    double joint_rms_rad = 0;
    double root_horizontal_m = 0;
  };
  Error error(const mjModel& m, const mjData& d) const;

  const MotionTrackerParams& params() const { return params_; }

  /// Open-loop corrections on top of the tracking (sampling-based control, scenarios/samcon.h):
  /// per DOF (nv entries, the root's ignored), rad, added to each joint group's target after the
  /// feedback: hinge angles directly, a ball group's as a rotation vector in its body frame.
  /// Empty (the default): none. A stance hip turning the pelvis by velocity keeps that wish.
  void set_offsets(const Eigen::VectorXd& offsets_rad) { offsets_ = offsets_rad; }
  const Eigen::VectorXd& offsets() const { return offsets_; }

 private:
  Eigen::Quaterniond group_orientation(const mjModel& m, const JointGroup& g,
                                       const double* qpos) const;

  const models::Rig* rig_;
  const TrackedMotion* motion_;
  MotionTrackerParams params_;
  double weight_ = 0;  // N
  std::vector<sim::FloorContact> contacts_;
  void drive_feedback(const ControlInput& in, ControlFrame* frame);
  void apply_offsets(const mjModel& m, ControlFrame* frame) const;

  mutable std::vector<double> pose_;  // nq scratch (drive and error: one thread)
  Eigen::VectorXd offsets_;           // nv, or empty
};

}  // namespace biodyn::controllers
