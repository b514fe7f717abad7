#pragma once
// Fall detection shared by the scenarios (internal): fallen = a body other than the feet and
// toes touches the floor, or the pelvis drops below a fraction of its starting height
// (scenario.h: one fraction for walking, one for standing).

#include <mujoco/mujoco.h>

#include "biodyn/models/rig.h"
#include "biodyn/sim/queries.h"

namespace biodyn::scenarios {

class FallWatch {
 public:
  FallWatch(const models::Rig& rig, double pelvis_fraction)
      : rig_(&rig), fraction_(pelvis_fraction) {}

  /// Reads the pelvis's standing height from `d` (positions computed): call once placed.
  void start(const mjData& d) {
    pelvis_start_ = rig_->pelvis() >= 0 ? d.xpos[3 * rig_->pelvis() + 2] : 0;
  }

  bool foot_body(int body) const { return rig_->is_foot_part(body); }
  int floor_geom() const { return rig_->floor_geom(); }
  double pelvis_start_height() const { return pelvis_start_; }

  /// True if the character is down in this state (contacts of the last step).
  bool down(const mjModel& m, const mjData& d) const {
    const int pelvis = rig_->pelvis(), floor = rig_->floor_geom();
    if (pelvis >= 0 && d.xpos[3 * pelvis + 2] < fraction_ * pelvis_start_) return true;
    for (int c = 0; c < d.ncon; ++c) {
      const mjContact& con = d.contact[c];
      const int other = sim::is_ground(m, con.geom1, floor)   ? con.geom2
                        : sim::is_ground(m, con.geom2, floor) ? con.geom1
                                                              : -1;
      if (other >= 0 && con.dist <= 0 && !foot_body(m.geom_bodyid[other])) return true;
    }
    return false;
  }

 private:
  const models::Rig* rig_;
  double fraction_ = 0.7, pelvis_start_ = 0;
};

}  // namespace biodyn::scenarios
