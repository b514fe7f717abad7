#include "biodyn/controllers/support_polygon.h"

#include <algorithm>

namespace biodyn::controllers {
namespace {

using Eigen::Vector2d;

// 2D cross product of (a - o) and (b - o): > 0 when o, a, b turn counter-clockwise.
double cross(const Vector2d& o, const Vector2d& a, const Vector2d& b) {
  return (a.x() - o.x()) * (b.y() - o.y()) - (a.y() - o.y()) * (b.x() - o.x());
}

}  // namespace

void convex_hull(std::vector<Vector2d>* points, std::vector<Vector2d>* hull) {
  std::vector<Vector2d>& pts = *points;
  std::sort(pts.begin(), pts.end(), [](const Vector2d& a, const Vector2d& b) {
    return a.x() < b.x() || (a.x() == b.x() && a.y() < b.y());
  });
  hull->clear();
  const std::size_t n = pts.size();
  if (n < 3) {
    hull->assign(pts.begin(), pts.end());
    return;
  }
  hull->resize(2 * n);
  std::size_t k = 0;
  for (std::size_t i = 0; i < n; ++i) {
    while (k >= 2 && cross((*hull)[k - 2], (*hull)[k - 1], pts[i]) <= 0) --k;
    (*hull)[k++] = pts[i];
  }
  for (std::size_t i = n - 1, t = k + 1; i > 0; --i) {
    while (k >= t && cross((*hull)[k - 2], (*hull)[k - 1], pts[i - 1]) <= 0) --k;
    (*hull)[k++] = pts[i - 1];
  }
  hull->resize(k - 1);
}

bool inside_convex(const std::vector<Vector2d>& polygon, const Vector2d& p) {
  if (polygon.size() < 3) return false;
  for (std::size_t i = 0; i < polygon.size(); ++i)
    if (cross(polygon[i], polygon[(i + 1) % polygon.size()], p) < 0) return false;
  return true;
}

double distance_outside(const std::vector<Vector2d>& polygon, const Vector2d& p) {
  if (polygon.size() < 3) return 0;
  bool inside = true;
  double best = 1e9;
  for (std::size_t i = 0; i < polygon.size(); ++i) {
    const Vector2d& a = polygon[i];
    const Vector2d& b = polygon[(i + 1) % polygon.size()];
    if (cross(a, b, p) < 0) inside = false;
    const Vector2d ab = b - a;
    const double t = std::clamp((p - a).dot(ab) / std::max(ab.squaredNorm(), 1e-18), 0.0, 1.0);
    best = std::min(best, (a + t * ab - p).norm());
  }
  return inside ? 0.0 : best;
}

void contact_support_polygon(const std::vector<sim::FloorContact>& contacts, const int* bodies,
                             int body_count, std::vector<Vector2d>* points,
                             std::vector<Vector2d>* hull) {
  points->clear();
  for (const sim::FloorContact& c : contacts) {
    if (c.distance > 0) continue;
    if (std::find(bodies, bodies + body_count, c.body) != bodies + body_count)
      points->push_back(c.position_W.head<2>());
  }
  convex_hull(points, hull);
}

void tolerance_polygon(const std::vector<Vector2d>& support, double fraction,
                       std::vector<Vector2d>* tolerance) {
  tolerance->clear();
  if (support.empty()) return;
  Vector2d centre = Vector2d::Zero();
  for (const Vector2d& p : support) centre += p;
  centre /= static_cast<double>(support.size());
  const double scale = 2.0 * fraction;
  for (const Vector2d& p : support) tolerance->push_back(centre + scale * (p - centre));
}

}  // namespace biodyn::controllers
