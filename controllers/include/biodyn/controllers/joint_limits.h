#pragma once
/// Anatomical swing-twist limits of the hip and shoulder ball joints (Baerlocher & Boulic
/// 2001; the paper §3.1 used them for its "limit forces"). MuJoCo 2.2.2 can only limit a ball
/// joint's total rotation angle (a cone), which lets a hip twist 120 degrees or abduct as far
/// as it flexes. Here the relative orientation is split as q = swing * twist (twist about the
/// bone axis z, swing about an axis in the x-y plane); the swing must stay inside an ellipse
/// with a half-axis per quadrant (flexion/extension, abduction/adduction) and the twist inside
/// [-external, internal]. Outside, a passive torque (a ligament: stiff spring and damper,
/// never pulling inwards) pushes the joint back. It is an internal torque between the two
/// segments, like the joint's own structure, not a muscle and not a force on the root.
/// MuJoCo's cone stays on as an outer backstop.

#include <mujoco/mujoco.h>

#include <Eigen/Geometry>
#include <vector>

#include "biodyn/controllers/controller_params.h"
#include "biodyn/controllers/joint_groups.h"

namespace biodyn::controllers {

/// Anatomical swing-twist angles of a ball joint's relative orientation, rad.
struct SwingTwistAngles {
  double flexion = 0;            ///< swing towards flexion (+) / extension (-)
  double abduction = 0;          ///< swing towards abduction (+) / adduction (-)
  double internal_rotation = 0;  ///< twist: internal (+) / external (-)
};

/// Splits a ball group's relative orientation into swing and twist (anatomical signs).
SwingTwistAngles swing_twist_angles(const JointGroup& group, const Eigen::Quaterniond& q);

/// Elliptic swing measure: <= 1 inside the swing limit, > 1 outside.
double swing_ratio(const SwingTwistLimits& limits, const SwingTwistAngles& angles);

/// Computes the limit torques of every group with swing-twist limits.
class SwingTwistLimiter {
 public:
  /// Natural frequency of the limit spring-damper, rad/s (critically damped, stiffness from
  /// the DOF's joint-space inertia): stiff, yet stable with explicit forces at dt = 2 ms
  /// (2 w dt = 0.4).
  static constexpr double kLimitFrequency_rad_s = 100.0;

  SwingTwistLimiter(const std::vector<JointGroup>& groups, const ControllerParams& params);
  /// Replaces the limits (live tuning).
  void set_params(const ControllerParams& params);

  /// Adds the limit torques (body frame of each ball joint) into `qfrc` (nv). Call after
  /// mj_step1 (needs xquat and qM). Returns how many joints are outside their limits.
  int compute(const mjModel& m, const mjData& d, mjtNum* qfrc) const;

 private:
  struct Entry {
    int group = -1;
    SwingTwistLimits limits;
  };
  std::vector<JointGroup> groups_;
  std::vector<Entry> entries_;
};

}  // namespace biodyn::controllers
