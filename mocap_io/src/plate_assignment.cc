// Which foot a force plate's load belongs to (plate_assignment.h).
#include "plate_assignment.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace biodyn::mocap_io::plate_internal {
namespace {

using Eigen::Vector2d;
using Eigen::Vector3d;

/// m: a sole point this far outside the plate's edge still counts as over it (the plate edge
/// and the model's sole are both known to about a centimetre).
constexpr double kOnPlateMargin_m = 0.01;

double cross2(const Vector2d& a, const Vector2d& b) { return a.x() * b.y() - a.y() * b.x(); }

double segment_distance(const Vector2d& p, const Vector2d& a, const Vector2d& b) {
  const Vector2d ab = b - a;
  const double len2 = ab.squaredNorm();
  const double t = len2 > 0 ? std::clamp((p - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
  return (p - (a + t * ab)).norm();
}

/// Horizontal distance from `p` to the convex polygon `corners` (in order, either winding);
/// 0 inside.
template <int N>
double polygon_distance(const Vector2d& p, const std::array<Vector2d, N>& corners) {
  bool all_left = true, all_right = true;
  double edge = std::numeric_limits<double>::infinity();
  for (int i = 0; i < N; ++i) {
    const Vector2d& a = corners[static_cast<size_t>(i)];
    const Vector2d& b = corners[static_cast<size_t>((i + 1) % N)];
    const double side = cross2(b - a, p - a);
    all_left = all_left && side >= 0;
    all_right = all_right && side <= 0;
    edge = std::min(edge, segment_distance(p, a, b));
  }
  return all_left || all_right ? 0.0 : edge;
}

}  // namespace

PlateSample plate_sample(const ForcePlate& p, double rate_hz, double t_s) {
  const double s = t_s * rate_hz;
  const int s0 = std::clamp(static_cast<int>(std::floor(s)), 0, p.sample_count() - 1);
  const int s1 = std::min(s0 + 1, p.sample_count() - 1);
  const double w = std::clamp(s - s0, 0.0, 1.0);
  auto at = [&](const Eigen::MatrixXd& x) -> Vector3d {
    return (1 - w) * x.row(s0).transpose() + w * x.row(s1).transpose();
  };
  return {at(p.force_N), at(p.cop_m), at(p.free_moment_Nm)};
}

bool over_plate(const ForcePlate& plate, const Vector2d& xy, double margin_m) {
  std::array<Vector2d, 4> plate_xy;
  for (int c = 0; c < 4; ++c) plate_xy[static_cast<size_t>(c)] = plate.corners_m.col(c).head<2>();
  return polygon_distance<4>(xy, plate_xy) <= margin_m;
}

PlateFeet::PlateFeet(const mjModel& m, const std::array<int, 2>& foot_bodies) {
  for (size_t side = 0; side < 2; ++side) {
    const int foot = foot_bodies[side];
    if (foot < 0) continue;
    for (int g = 0; g < m.ngeom; ++g) {
      const int b = m.geom_bodyid[g];
      if (m.geom_type[g] != mjGEOM_BOX || (b != foot && m.body_parentid[b] != foot)) continue;
      box_geoms_[side].push_back(g);
      half_sizes_[side].emplace_back(m.geom_size[3 * g], m.geom_size[3 * g + 1],
                                     m.geom_size[3 * g + 2]);
    }
  }
}

int PlateFeet::foot_for(const mjData& d, const ForcePlate& plate, const Vector3d& cop) const {
  const double surface_z = plate.corners_m.row(2).mean();
  std::array<double, 2> cop_off = {std::numeric_limits<double>::infinity(),
                                   std::numeric_limits<double>::infinity()};
  std::array<bool, 2> on_plate = {false, false};
  for (size_t side = 0; side < 2; ++side) {
    for (size_t k = 0; k < box_geoms_[side].size(); ++k) {
      const int g = box_geoms_[side][k];
      const Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> r(d.geom_xmat + 9 * g);
      const Vector3d centre(d.geom_xpos[3 * g], d.geom_xpos[3 * g + 1], d.geom_xpos[3 * g + 2]);
      const Vector3d& h = half_sizes_[side][k];
      // The bottom face's corners, in order around it (box frame: z up from the sole).
      std::array<Vector2d, 4> footprint;
      const double sx[4] = {-1, 1, 1, -1}, sy[4] = {-1, -1, 1, 1};
      for (int c = 0; c < 4; ++c) {
        const Vector3d p = centre + r * Vector3d(sx[c] * h.x(), sy[c] * h.y(), -h.z());
        footprint[static_cast<size_t>(c)] = p.head<2>();
        if (p.z() - surface_z < kSoleOnFloor_m &&
            over_plate(plate, p.head<2>(), kOnPlateMargin_m)) {
          on_plate[side] = true;
        }
      }
      cop_off[side] = std::min(cop_off[side], polygon_distance<4>(cop.head<2>(), footprint));
    }
  }
  const bool left = on_plate[0] && cop_off[0] <= kCopOffFoot_m;
  const bool right = on_plate[1] && cop_off[1] <= kCopOffFoot_m;
  if (left && right) {
    if (cop_off[0] + kCopPreference_m <= cop_off[1]) return 0;
    if (cop_off[1] + kCopPreference_m <= cop_off[0]) return 1;
    return -1;  // both feet on the plate, the load shared: not ours to split
  }
  return left ? 0 : right ? 1 : -1;
}

}  // namespace biodyn::mocap_io::plate_internal
