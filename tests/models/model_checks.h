#pragma once
// Independent read-outs of a compiled MuJoCo model, for checking the generator against MuJoCo
// rather than against its own bookkeeping.

#include <mujoco/mujoco.h>

#include <algorithm>
#include <cmath>
#include <utility>

namespace biodyn::testing {

/// Lowest and highest world z of every non-plane geom (needs mj_forward).
inline std::pair<double, double> geom_z_span(const mjModel& m, const mjData& d) {
  double lo = 1e9, hi = -1e9;
  for (int g = 0; g < m.ngeom; ++g) {
    const double* size = m.geom_size + 3 * g;
    const double* R = d.geom_xmat + 9 * g;  // row-major; row 2 maps local axes to world z
    const double z = d.geom_xpos[3 * g + 2];
    double reach = 0;
    switch (m.geom_type[g]) {
      case mjGEOM_PLANE:
        continue;
      case mjGEOM_SPHERE:
        reach = size[0];
        break;
      case mjGEOM_CAPSULE:
        reach = size[0] + std::abs(R[8]) * size[1];
        break;
      case mjGEOM_BOX:
        reach = std::abs(R[6]) * size[0] + std::abs(R[7]) * size[1] + std::abs(R[8]) * size[2];
        break;
      default:
        reach = m.geom_rbound[g];
    }
    lo = std::min(lo, z - reach);
    hi = std::max(hi, z + reach);
  }
  return {lo, hi};
}

/// Total mass of all bodies, kg.
inline double total_mass(const mjModel& m) {
  double sum = 0;
  for (int b = 0; b < m.nbody; ++b) sum += m.body_mass[b];
  return sum;
}

}  // namespace biodyn::testing
