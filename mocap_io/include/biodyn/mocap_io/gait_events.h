#pragma once
/// Gait events of a captured motion: heel strikes per foot, from the force plates where a plate
/// sees the foot land (the onset of the load inverse dynamics assigned to that foot) and from
/// the foot's kinematics elsewhere (the back of the sole coming down to the floor), and the gait
/// cycle between two heel strikes of one foot as 0-100 %.

#include <mujoco/mujoco.h>

#include <Eigen/Core>
#include <string>
#include <vector>

namespace biodyn::mocap_io {

/// The heel point (back of the sole, middle of its width) must rise this far above its lowest
/// height in the motion before a strike counts: swing lifts the heel by 20-30 cm, a rolling
/// stance foot by less (m).
inline constexpr double kHeelLiftHeight_m = 0.05;
/// A heel strike: the heel point coming down through this height above its lowest (m); the time
/// is interpolated between the frames on either side. The heel reaches the floor at contact, so
/// the threshold is small; the time it leads the plate's onset is reported (heel_strikes).
inline constexpr double kHeelStrikeHeight_m = 0.01;
/// A kinematic strike this close to a plate's onset on the same foot is that strike (s): the
/// plate's time is used.
inline constexpr double kStrikeMatchWindow_s = 0.1;

/// One heel strike of one foot.
struct HeelStrike {
  double time_s = 0;  ///< s, on the motion's clock
  int plate = -1;     ///< the plate (0-based) whose load onset gives time_s; -1: kinematics only
  /// s: the kinematic detector's time for this strike (NaN when it saw none: e.g. the heel was
  /// not seen lifted before it in the motion).
  double kinematic_time_s = 0;
  /// s: when this foot's plate load ended (toe off), or NaN without a plate.
  double plate_off_time_s = 0;
};

/// Heel strikes of the foot of `side` (models::kLeft / kRight) over the frames `qpos` (frames x
/// nq of `m`) at `times_s`, in time order. `plate_foot` (frames x plates, the same frames;
/// InverseDynamicsResult::plate_foot), when it has columns, gives the plates' strikes: the first
/// frame of a run of frames where a plate's load is assigned to this foot (a run that starts at
/// the motion's first frame is not an onset). Throws sim::InvalidArgument when the sizes
/// disagree or the model has no such foot.
std::vector<HeelStrike> heel_strikes(const mjModel& m, const Eigen::MatrixXd& qpos,
                                     const std::vector<double>& times_s, int side,
                                     const Eigen::MatrixXi& plate_foot);

/// `values` (frames x columns at `times_s`, increasing) over the gait cycle [t0_s, t1_s] as
/// `points` rows at 0, 100 / (points - 1), ..., 100 % of it, linearly interpolated. Throws
/// sim::InvalidArgument if the cycle is not within the times or points < 2.
Eigen::MatrixXd resample_cycle(const std::vector<double>& times_s, const Eigen::MatrixXd& values,
                               double t0_s, double t1_s, int points);

}  // namespace biodyn::mocap_io
