// What both walkers stand on (gait_core.h).
#include "biodyn/controllers/gait_core.h"

#include <algorithm>

#include "biodyn/controllers/support_polygon.h"

namespace biodyn::controllers {

using Eigen::Vector2d;
using Eigen::Vector3d;

bool foot_touches_floor(const mjModel& m, const mjData& d, const models::Rig& rig, int side) {
  const models::RigLeg& leg = rig.leg(side);
  return sim::foot_touches_floor(m, d, rig.floor_geom(), leg.foot, leg.toes);
}

double level_sole_dorsiflexion(const HeadingFrame& heading, const Eigen::Quaterniond& q_shank_W,
                               double offset_rad, double toe_up_rad) {
  // Pitch about the heading frame's +y (toes down positive); dorsiflexion turns the foot about
  // -y, so the foot's pitch is shank_pitch - dorsiflexion: level (toes up) undoes the shank's.
  const Vector3d shank_x = heading.rotation().conjugate() * (q_shank_W * Vector3d::UnitX());
  const double shank_pitch = std::atan2(-shank_x.z(), shank_x.x());
  return offset_rad + shank_pitch + toe_up_rad;
}

LegTriangle solve_leg_triangle(double l1, double l2, const Vector3d& r, double sigma,
                               double min_knee_rad, double max_knee_rad) {
  LegTriangle out;
  const double reach_max = std::sqrt(l1 * l1 + l2 * l2 + 2 * l1 * l2 * std::cos(min_knee_rad));
  const double reach_min = std::max(
      0.3 * (l1 + l2), std::sqrt(l1 * l1 + l2 * l2 + 2 * l1 * l2 * std::cos(max_knee_rad)));
  const double wanted = r.norm();
  const double len = std::clamp(wanted, reach_min, reach_max);
  out.reachable = wanted >= reach_min && wanted <= reach_max;
  // Law of cosines: the knee's interior angle is pi - flexion. Beyond reach the knee is at its
  // least flexion exactly (the cosine there is +-1 up to rounding).
  out.knee_flexion_rad =
      wanted >= reach_max
          ? min_knee_rad
          : M_PI -
                std::acos(std::clamp((l1 * l1 + l2 * l2 - len * len) / (2 * l1 * l2), -1.0, 1.0));
  // alpha: the thigh's angle in front of the hip-ankle line (the knee bends backwards, so the
  // thigh leans forward).
  const double k = out.knee_flexion_rad;
  const double alpha = std::atan2(l2 * std::sin(k), l1 + l2 * std::cos(k));
  out.hip_flexion_rad = std::atan2(r.x(), -r.z()) + alpha;
  out.hip_abduction_rad = std::atan2(sigma * r.y(), -r.z());
  return out;
}

double base_polygon_step(double com_from_rear, double foot_length) {
  const double gap = 4.0 * com_from_rear / 3.0 - 2.0 * foot_length;
  return gap + foot_length;
}

SupportPolygons::SupportPolygons() {
  contacts_.reserve(64);
  points_.reserve(64);
  hull_.reserve(128);
  tolerance_.reserve(128);
}

void SupportPolygons::update(const mjModel& m, const mjData& d, const models::Rig& rig,
                             double tolerance_fraction) {
  sim::floor_contacts(m, d, rig.floor_geom(), &contacts_);
  const int feet[4] = {rig.leg(models::kLeft).foot, rig.leg(models::kRight).foot,
                       rig.leg(models::kLeft).toes, rig.leg(models::kRight).toes};
  contact_support_polygon(contacts_, feet, 4, &points_, &hull_);
  tolerance_.clear();
  if (hull_.size() < 3) return;
  tolerance_polygon(hull_, tolerance_fraction, &tolerance_);
}

BasePolygonStep base_polygon_rule(const std::vector<Vector2d>& support,
                                  const std::vector<Vector2d>& tolerance, double tolerance_fraction,
                                  const Vector3d& com_W, const Vector3d& com_velocity_H,
                                  const Vector2d& stance_ankle_W, const HeadingFrame& heading,
                                  int swing_side, double foot_length, double foot_width,
                                  double back_step_omega0) {
  BasePolygonStep step;
  if (support.size() < 3 || inside_convex(tolerance, com_W.head<2>())) return step;
  // The support polygon's extent and vertex centre in the heading frame, from the stance ankle.
  double rear = 1e9, front = -1e9, right = 1e9, left = -1e9, cx = 0, cy = 0;
  for (const Vector2d& w : support) {
    const Vector2d q = heading.to_heading(Vector2d(w - stance_ankle_W));
    rear = std::min(rear, q.x());
    front = std::max(front, q.x());
    right = std::min(right, q.y());
    left = std::max(left, q.y());
    cx += q.x();
    cy += q.y();
  }
  cx /= static_cast<double>(support.size());
  cy /= static_cast<double>(support.size());
  const Vector2d c = heading.to_heading(Vector2d(com_W.head<2>() - stance_ankle_W));
  const double sagittal_tol = tolerance_fraction * (front - rear);
  if (c.x() > cx + sagittal_tol) {
    // Ahead: b_P the polygon's rear edge (ankle to ankle, as heel to heel). In normal walking
    // the gait's own step is longer: the rule binds only when the CoM has run further ahead.
    const double length = base_polygon_step(c.x() - rear, foot_length);
    if (length > 0) step.length_m = length;
  } else if (c.x() < cx - sagittal_tol && com_velocity_H.x() < 0 &&
             (back_step_omega0 <= 0 || c.x() + com_velocity_H.x() / back_step_omega0 <= rear)) {
    const double length = -base_polygon_step(front - c.x(), foot_length);
    if (length < 0) step.length_m = length;
  }
  const double side =
      swing_side == models::kLeft ? 1.0 : -1.0;  // +1: the swing foot is the left one (+y)
  const double frontal_tol = tolerance_fraction * (left - right);
  if (side * (c.y() - cy) > frontal_tol && side * com_velocity_H.y() > 0) {
    const double outer = side > 0 ? right : left;
    const double width = base_polygon_step(side * (c.y() - outer), foot_width);
    if (width > 0) step.width_m = width;
  }
  return step;
}

}  // namespace biodyn::controllers
