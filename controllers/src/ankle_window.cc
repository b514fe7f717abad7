// The ankle torque window of a foot on the floor (ankle_window.h).
#include "biodyn/controllers/ankle_window.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

namespace biodyn::controllers {

void limit_ankle_to_contacts(ControlFrame* frame, const mjModel& m, const mjData& d,
                             const JointGroup& ankle, int foot, int toes,
                             const std::vector<sim::FloorContact>& contacts, double load_N,
                             double margin, double cop_fraction) {
  const mjtNum* q = d.xquat + 4 * foot;
  const Eigen::Vector3d foot_x =
      Eigen::Quaterniond(q[0], q[1], q[2], q[3]) * Eigen::Vector3d::UnitX();
  for (int k = 0; k < ankle.dof_count; ++k) {
    const int dof = ankle.dof_begin + k;
    const int j = m.dof_jntid[dof];
    const Eigen::Vector3d p(d.xanchor[3 * j], d.xanchor[3 * j + 1], d.xanchor[3 * j + 2]);
    const Eigen::Vector3d a(d.xaxis[3 * j], d.xaxis[3 * j + 1], d.xaxis[3 * j + 2]);
    // Lever of a unit vertical ground force at each contact point about the DOF's axis.
    double lo = 1e9, hi = -1e9;
    for (const sim::FloorContact& fc : contacts) {
      if (fc.distance > 0 || (fc.body != foot && (toes < 0 || fc.body != toes))) continue;
      const Eigen::Vector3d r = fc.position_W - p;
      const double arm = a.x() * r.y() - a.y() * r.x();  // a . (r x z)
      lo = std::min(lo, arm);
      hi = std::max(hi, arm);
    }
    if (lo > hi) return;  // foot in the air
    const double mid = (lo + hi) / 2, half = (hi - lo) / 2 * margin;
    if (cop_fraction >= 0) {
      // The lever grows heel to toe when the axis points along -y of the foot (dorsiflexion);
      // sideways the CoP is held central.
      double f = 0.5;
      const bool sagittal = std::abs(a.dot(foot_x)) < 0.5;
      if (sagittal) {
        const Eigen::Vector3d probe =
            foot_x.cross(Eigen::Vector3d::UnitZ());  // lever change per metre forward
        f = a.dot(probe) > 0 ? cop_fraction : 1.0 - cop_fraction;
      }
      // The CoP at f: tau + F arm_cop = 0 for a foot at rest.
      const double tau = -load_N * (mid + (2 * f - 1) * half);
      frame->set_torque(dof, tau);
    } else {
      frame->limit_torque(dof, std::min(-load_N * (mid + half), 0.0),
                          std::max(-load_N * (mid - half), 0.0));
    }
  }
}

}  // namespace biodyn::controllers
