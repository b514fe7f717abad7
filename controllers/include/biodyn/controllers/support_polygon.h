#pragma once
/// Plane geometry of support polygons (world xy): the convex hull of the foot contacts, and
/// where a CoM projection lies against it. Shared by the gait driver's base-polygon balance
/// (paper §4.3) and the standing scenarios' read-outs. No allocation beyond `hull`'s capacity.

#include <Eigen/Core>
#include <vector>

namespace biodyn::controllers {

/// Convex hull (Andrew's monotone chain), counter-clockwise, into `hull`; sorts `points`.
/// Fewer than 3 points are copied as they are (sorted).
void convex_hull(std::vector<Eigen::Vector2d>* points, std::vector<Eigen::Vector2d>* hull);

/// Whether p lies inside (or on) the counter-clockwise convex polygon; false for fewer than 3
/// vertices.
bool inside_convex(const std::vector<Eigen::Vector2d>& polygon, const Eigen::Vector2d& p);

/// Distance of p outside the counter-clockwise convex polygon, m (0 inside, and for fewer than
/// 3 vertices).
double distance_outside(const std::vector<Eigen::Vector2d>& polygon, const Eigen::Vector2d& p);

}  // namespace biodyn::controllers
