#pragma once
/// Plane geometry of support polygons (world xy): the convex hull of the foot contacts, and
/// where a CoM projection lies against it. Shared by the gait driver's base-polygon balance
/// (paper §4.3) and the standing scenarios' read-outs. No allocation beyond `hull`'s capacity.

#include <Eigen/Core>
#include <vector>

#include "biodyn/sim/queries.h"

namespace biodyn::controllers {

/// Convex hull (Andrew's monotone chain), counter-clockwise, into `hull`; sorts `points`.
/// Fewer than 3 points are copied as they are (sorted).
void convex_hull(std::vector<Eigen::Vector2d>* points, std::vector<Eigen::Vector2d>* hull);

/// The feet's support polygon: the convex hull of the contacts (touching or penetrating) whose
/// body is one of `bodies[0..body_count)` (the feet and toes), into `hull`; `points` is scratch.
void contact_support_polygon(const std::vector<sim::FloorContact>& contacts, const int* bodies,
                             int body_count, std::vector<Eigen::Vector2d>* points,
                             std::vector<Eigen::Vector2d>* hull);

/// The tolerance polygon of paper §4.3: `support` scaled about its vertex centroid so that its
/// edges lie `fraction` of its extent from the centre (by 2 fraction). Empty for an empty support.
void tolerance_polygon(const std::vector<Eigen::Vector2d>& support, double fraction,
                       std::vector<Eigen::Vector2d>* tolerance);

/// Whether p lies inside (or on) the counter-clockwise convex polygon; false for fewer than 3
/// vertices.
bool inside_convex(const std::vector<Eigen::Vector2d>& polygon, const Eigen::Vector2d& p);

/// Distance of p outside the counter-clockwise convex polygon, m (0 inside, and for fewer than
/// 3 vertices).
double distance_outside(const std::vector<Eigen::Vector2d>& polygon, const Eigen::Vector2d& p);

}  // namespace biodyn::controllers
