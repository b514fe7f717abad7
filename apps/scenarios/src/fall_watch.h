#pragma once
// Fall detection shared by the scenarios (internal): fallen = a body other than the feet and
// toes touches the floor, or the pelvis drops below a fraction of its starting height
// (references.md: >= 0.7x nominal counts as upright while walking).

#include <mujoco/mujoco.h>

#include <string>
#include <vector>

namespace biodyn::scenarios {

class FallWatch {
 public:
  /// Reads the pelvis start height from `d` (positions computed).
  FallWatch(const mjModel& m, const mjData& d, double pelvis_fraction)
      : pelvis_(mj_name2id(&m, mjOBJ_BODY, "pelvis")),
        floor_(mj_name2id(&m, mjOBJ_GEOM, "floor")),
        fraction_(pelvis_fraction),
        foot_body_(static_cast<std::size_t>(m.nbody), false) {
    for (int b = 0; b < m.nbody; ++b) {
      const char* n = mj_id2name(&m, mjOBJ_BODY, b);
      foot_body_[static_cast<std::size_t>(b)] = n && is_foot_body(n);
    }
    pelvis_start_ = pelvis_ >= 0 ? d.xpos[3 * pelvis_ + 2] : 0;
  }

  static bool is_foot_body(const std::string& name) {
    return name.rfind("foot_", 0) == 0 || name.rfind("toes_", 0) == 0;
  }
  bool foot_body(int body) const { return foot_body_[static_cast<std::size_t>(body)]; }
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
  int pelvis_ = -1, floor_ = -1;
  double fraction_ = 0.7, pelvis_start_ = 0;
  std::vector<bool> foot_body_;
};

}  // namespace biodyn::scenarios
