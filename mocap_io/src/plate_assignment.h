#pragma once
/// Private to mocap_io: which foot a force plate's load belongs to (inverse_dynamics.cc).
///
/// A plate measures whatever stands on it. Labs assign each plate to a foot by hand (OpenSim's
/// ExternalLoads names the body per plate); doing it per frame from the pose needs more than
/// the horizontally nearest ankle, which hands the stance foot's load to a swing foot passing
/// over the plate (issue 24, defect 4). A foot carries a plate's load here only when
///  - some of its sole points (the bottom corners of the foot's and toes' box geoms) are over
///    the plate and within kSoleOnFloor_m of its surface, and
///  - the centre of pressure lies on the foot's footprint (those points' quadrilaterals in the
///    horizontal plane), give or take kCopOffFoot_m for marker and IK error.
/// When both feet qualify and the centre of pressure is not clearly on one of them (both on
/// the plate, load shared), or neither does, the load is not applied: it stays in the root
/// residual and the frame is reported as unassigned, never guessed.

#include <mujoco/mujoco.h>

#include <Eigen/Core>
#include <array>
#include <vector>

#include "biodyn/mocap_io/marker_data.h"

namespace biodyn::mocap_io::plate_internal {

/// N: a plate with less vertical force has no meaningful centre of pressure: unloaded.
inline constexpr double kMinPlateLoad_N = 20.0;
/// m: a sole point this high above the plate surface is off it (swing clearance is 1-2 cm at
/// the toe but the stance sole of an IK-fitted model can sit ~1-2 cm off the floor).
inline constexpr double kSoleOnFloor_m = 0.03;
/// m: a centre of pressure this far outside a foot's footprint is not under that foot
/// (marker-placement and IK error, soft tissue).
inline constexpr double kCopOffFoot_m = 0.04;
/// m: when both feet qualify, the centre of pressure must be this much nearer one footprint.
inline constexpr double kCopPreference_m = 0.02;

/// A plate's ground reaction at one time: linearly interpolated between its samples.
struct PlateSample {
  Eigen::Vector3d force_N, cop_m, free_moment_Nm;  ///< cop and free moment NaN when unloaded
};
/// `plate`'s reading at `t_s` (its clock: sample i at i / rate_hz), clamped to its samples.
PlateSample plate_sample(const ForcePlate& plate, double rate_hz, double t_s);

/// Whether the horizontal point `xy` lies over `plate`'s surface, give or take `margin_m`.
bool over_plate(const ForcePlate& plate, const Eigen::Vector2d& xy, double margin_m);

/// The box geoms (foot and toes) of each foot, resolved once per model.
class PlateFeet {
 public:
  /// foot_bodies[side]: the foot body of each side (-1: none).
  PlateFeet(const mjModel& m, const std::array<int, 2>& foot_bodies);
  /// The side (0 left, 1 right) whose foot carries a load with centre of pressure `cop` on
  /// `plate`, on the pose whose kinematics are in `d`; -1 when none or both could.
  int foot_for(const mjData& d, const ForcePlate& plate, const Eigen::Vector3d& cop) const;

 private:
  std::array<std::vector<int>, 2> box_geoms_;
  std::array<std::vector<Eigen::Vector3d>, 2> half_sizes_;  ///< m, of each box geom
};

}  // namespace biodyn::mocap_io::plate_internal
