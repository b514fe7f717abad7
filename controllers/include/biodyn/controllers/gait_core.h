#pragma once
/// What both walkers stand on (one version of each): the heading frame, foot-strike detection,
/// the level swing sole, the paper's 2D IK triangle (§4.2) and base-polygon rule (§4.3), and the
/// feet's support polygon. The torque walker (torque_walker.h) and the velocity-based walker
/// (velocity_walker.h) are state machines on top of these; the parts of the character they use
/// come from the rig (models/rig.h).

#include <mujoco/mujoco.h>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>
#include <limits>
#include <vector>

#include "biodyn/models/rig.h"
#include "biodyn/sim/queries.h"

namespace biodyn::controllers {

/// The walker's heading frame: x along the heading on the floor, y to its left, z up. It turns
/// at the commanded rate; advance() is once per time (a step redone at the same time turns it
/// no further).
class HeadingFrame {
 public:
  /// Heading `heading_rad` (about +z, from +x) at `time_s`.
  void reset(double heading_rad, double time_s) {
    heading_rad_ = heading_rad;
    last_time_s_ = time_s;
  }
  /// Turns at `rate_rad_s` from the last time to `time_s`.
  void advance(double time_s, double rate_rad_s) {
    heading_rad_ += rate_rad_s * std::max(time_s - last_time_s_, 0.0);
    last_time_s_ = time_s;
  }
  double heading_rad() const { return heading_rad_; }
  /// The frame's rotation from the world (about +z).
  Eigen::Quaterniond rotation() const {
    return Eigen::Quaterniond(Eigen::AngleAxisd(heading_rad_, Eigen::Vector3d::UnitZ()));
  }
  /// Unit vector along the heading (world xy).
  Eigen::Vector2d along() const { return {std::cos(heading_rad_), std::sin(heading_rad_)}; }
  /// A world vector in the heading frame.
  Eigen::Vector3d to_heading(const Eigen::Vector3d& v_W) const {
    return rotation().conjugate() * v_W;
  }
  /// A world xy vector in the heading frame (x along, y across to the left).
  Eigen::Vector2d to_heading(const Eigen::Vector2d& v_W) const {
    const double c = std::cos(heading_rad_), s = std::sin(heading_rad_);
    return {c * v_W.x() + s * v_W.y(), -s * v_W.x() + c * v_W.y()};
  }
  /// A heading-frame xy vector in the world.
  Eigen::Vector2d to_world(const Eigen::Vector2d& v_H) const {
    const double c = std::cos(heading_rad_), s = std::sin(heading_rad_);
    return {c * v_H.x() - s * v_H.y(), s * v_H.x() + c * v_H.y()};
  }

 private:
  double heading_rad_ = 0;
  double last_time_s_ = 0;
};

/// Whether foot `side`'s sole (foot or toes) touches the floor now (a contact at distance <= 0).
bool foot_touches_floor(const mjModel& m, const mjData& d, const models::Rig& rig, int side);

/// A swing's foot strike: the swing foot touches the floor after having left it (a foot still on
/// the floor at the start of the swing, or scuffing, has not struck).
class StrikeDetector {
 public:
  /// A new swing begins: the foot has not left the floor yet.
  void start_swing() { lifted_ = false; }
  /// This step's contact of the swing foot; true once it touches after having left the floor.
  bool update(bool touches) {
    if (!touches) lifted_ = true;
    return touches && lifted_;
  }
  bool lifted() const { return lifted_; }

 private:
  bool lifted_ = false;
};

/// The swing ankle's dorsiflexion that holds the sole level in the heading frame, toes up by
/// `toe_up_rad`, whatever the shank does (a foot that followed the shank back would scuff with
/// its toes): `offset_rad` + the shank's pitch in the heading frame + `toe_up_rad` (the foot's
/// pitch is shank pitch - dorsiflexion, dorsiflexion turning the foot about -y).
double level_sole_dorsiflexion(const HeadingFrame& heading, const Eigen::Quaterniond& q_shank_W,
                               double offset_rad, double toe_up_rad);

/// The paper's 2D IK triangle (§4.2) for one leg: hip - knee - ankle.
struct LegTriangle {
  double hip_flexion_rad = 0;    ///< thigh pitch forward of vertical (heading frame)
  double hip_abduction_rad = 0;  ///< thigh roll outward of vertical
  double knee_flexion_rad = 0;
  bool reachable = true;  ///< false: the pose is the closest reachable one
};

/// The thigh and knee angles that put the ankle at `hip_to_ankle` (heading frame: x forward,
/// y left, z up; m) for thigh length l1 and shank length l2. `sigma` is +1 for a left leg,
/// -1 for a right one (abduction is outward). The knee bends at least `min_knee_rad` and at most
/// `max_knee_rad`; a point beyond the leg's reach (or closer than the most flexed knee allows,
/// and than 0.3 (l1 + l2)) gives the pose pointing at it with the nearest reachable length
/// (paper: "the closest state to the desired foot position").
LegTriangle solve_leg_triangle(double l1, double l2, const Eigen::Vector3d& hip_to_ankle,
                               double sigma, double min_knee_rad, double max_knee_rad = M_PI);

/// Paper §4.3, read as: the next strike makes the base polygon long enough that the CoM, at
/// `com_from_rear` (m) in front of the polygon's rear edge, lies on the new polygon's
/// tolerance edge at 75% of its length: d = 4(c_CM - b_P)/3 - 2 foot_length is the gap from
/// the stance toe to the new heel, so the step (heel to heel) is d + foot_length. Returns it.
double base_polygon_step(double com_from_rear, double foot_length);

/// The feet's support polygon (the convex hull of their floor contacts, world xy, counter-
/// clockwise) and the paper's tolerance polygon about its centre (§4.3). Keeps its buffers: no
/// allocation once they have grown.
class SupportPolygons {
 public:
  SupportPolygons();
  /// From this step's floor contacts of both feet and toes; the tolerance polygon puts its
  /// edges `tolerance_fraction` of the support's extent from its centre (empty for fewer than 3
  /// support points).
  void update(const mjModel& m, const mjData& d, const models::Rig& rig, double tolerance_fraction);
  const std::vector<Eigen::Vector2d>& support() const { return hull_; }
  const std::vector<Eigen::Vector2d>& tolerance() const { return tolerance_; }

 private:
  std::vector<sim::FloorContact> contacts_;
  std::vector<Eigen::Vector2d> points_, hull_, tolerance_;
};

/// The step the base-polygon rule asks for (paper §4.3), heading frame, from the stance ankle:
/// NaN where it asks nothing.
struct BasePolygonStep {
  /// m along the heading: at least this far ahead (> 0), or at least this far behind (< 0).
  double length_m = std::numeric_limits<double>::quiet_NaN();
  /// m across, towards the swing side: at least this wide.
  double width_m = std::numeric_limits<double>::quiet_NaN();
};

/// Paper §4.3 during a swing: when the CoM's projection `com_W` is outside the tolerance
/// polygon, the next strike goes at least base_polygon_step() from the polygon's far edge:
///  - ahead of the tolerance band: a step forward (b_P the rear edge);
///  - behind it and moving backwards (`com_velocity_H`, heading frame): a step back from the
///    front edge (behind but moving forwards is every step's start: the CoM comes over the foot);
///    with `back_step_omega0` > 0, only while the capture point x + v_x / back_step_omega0
///    (Pratt et al. 2006; omega0 = sqrt(g / CoM height)) is behind the polygon's rear edge too
///    (otherwise the body comes to rest over its feet without a step; 0: the paper's rule);
///  - beyond the band towards the swing side and moving that way: a wider step (b_P the stance
///    foot's outer edge, the foot width for the foot length). Towards the stance side the rule
///    would need a cross-over step: not taken (the legs would collide).
/// `support`/`tolerance` from SupportPolygons (fewer than 3 support points: nothing asked).
BasePolygonStep base_polygon_rule(const std::vector<Eigen::Vector2d>& support,
                                  const std::vector<Eigen::Vector2d>& tolerance,
                                  double tolerance_fraction, const Eigen::Vector3d& com_W,
                                  const Eigen::Vector3d& com_velocity_H,
                                  const Eigen::Vector2d& stance_ankle_W,
                                  const HeadingFrame& heading, int swing_side, double foot_length,
                                  double foot_width, double back_step_omega0 = 0);

}  // namespace biodyn::controllers
