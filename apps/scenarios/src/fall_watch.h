#pragma once
// Fall detection shared by the scenarios (internal): fallen = a body other than the feet and
// toes touches the floor, or the pelvis drops below a fraction of its starting height
// (references.md: >= 0.7x nominal counts as upright while walking).

#include <mujoco/mujoco.h>

#include "biodyn/models/rig.h"

namespace biodyn::scenarios {

class FallWatch {
 public:
  /// Reads the pelvis start height from `d` (positions computed).
  FallWatch(const mjData& d, const models::Rig& rig, double pelvis_fraction)
      : rig_(&rig), pelvis_(rig.pelvis()), floor_(rig.floor_geom()), fraction_(pelvis_fraction) {
    pelvis_start_ = pelvis_ >= 0 ? d.xpos[3 * pelvis_ + 2] : 0;
  }

  bool foot_body(int body) const { return rig_->is_foot_part(body); }
  int floor_geom() const { return floor_; }
  double pelvis_start_height() const { return pelvis_start_; }

  /// True if the character is down in this state (contacts of the last step).
  bool down(const mjModel& m, const mjData& d) const {
    if (pelvis_ >= 0 && d.xpos[3 * pelvis_ + 2] < fraction_ * pelvis_start_) return true;
    for (int c = 0; c < d.ncon; ++c) {
      const mjContact& con = d.contact[c];
      const int other = con.geom1 == floor_ ? con.geom2 : con.geom2 == floor_ ? con.geom1 : -1;
      if (other >= 0 && con.dist <= 0 && !foot_body(m.geom_bodyid[other])) return true;
    }
    return false;
  }

 private:
  const models::Rig* rig_;
  int pelvis_ = -1, floor_ = -1;
  double fraction_ = 0.7, pelvis_start_ = 0;
};

}  // namespace biodyn::scenarios
