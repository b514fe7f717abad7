// The control frame (control_frame.h).
#include "biodyn/controllers/control_frame.h"

#include <algorithm>

#include "biodyn/controllers/joint_groups.h"

namespace biodyn::controllers {
namespace {

// A DOF given several commands in one step keeps the strongest: free over spring over an
// explicit velocity over the target (the order the stages set them in does not matter).
void raise(DofCommand* c, DofMode mode) {
  if (static_cast<int>(mode) > static_cast<int>(c->mode)) c->mode = mode;
}

}  // namespace

ControlFrame::ControlFrame(const models::Rig& rig, int nv)
    : rig_(&rig),
      targets_(rig.groups().size()),
      dofs_(static_cast<std::size_t>(nv)),
      qfrc_extra_(static_cast<std::size_t>(nv), 0.0) {}

void ControlFrame::begin_step() {
  std::fill(dofs_.begin(), dofs_.end(), DofCommand{});
  std::fill(qfrc_extra_.begin(), qfrc_extra_.end(), 0.0);
  stance_wish_ = {-1, -1};
}

void ControlFrame::set_target(int group, const Eigen::Quaterniond& orientation, double reach_at_s) {
  JointTarget& t = targets_[static_cast<std::size_t>(group)];
  t.orientation = orientation.normalized();
  t.reach_at_s = reach_at_s;
}

void ControlFrame::set_joint_angles(int group, Eigen::Vector3d angles_rad, double reach_at_s) {
  const JointGroup& g = rig_->groups()[static_cast<std::size_t>(group)];
  angles_rad = clamp_to_range(g, angles_rad, kTargetLimitMargin_rad);
  set_target(group, orientation_from_angles(g, angles_rad), reach_at_s);
}

void ControlFrame::limit_torque(int dof, double lo_Nm, double hi_Nm) {
  DofCommand& c = dofs_[static_cast<std::size_t>(dof)];
  c.torque_min_Nm = std::max(c.torque_min_Nm, lo_Nm);
  c.torque_max_Nm = std::min(c.torque_max_Nm, hi_Nm);
}

void ControlFrame::set_spring(int group, double stiffness_Nm_per_rad, double damping_Nm_s_per_rad) {
  const JointGroup& g = rig_->groups()[static_cast<std::size_t>(group)];
  for (int k = 0; k < g.dof_count; ++k) {
    DofCommand& c = dofs_[static_cast<std::size_t>(g.dof_begin + k)];
    raise(&c, DofMode::kSpring);
    c.stiffness_Nm_per_rad = std::max(stiffness_Nm_per_rad, 0.0);
    c.damping_Nm_s_per_rad = std::max(damping_Nm_s_per_rad, 0.0);
  }
}

void ControlFrame::set_velocity(int group, const Eigen::Vector3d& w_body_rad_s) {
  const JointGroup& g = rig_->groups()[static_cast<std::size_t>(group)];
  if (!g.ball) return;
  for (int k = 0; k < 3; ++k) {
    DofCommand& c = dofs_[static_cast<std::size_t>(g.dof_begin + k)];
    raise(&c, DofMode::kVelocity);
    c.has_velocity = true;
    c.velocity_rad_s = w_body_rad_s[k];
  }
}

void ControlFrame::set_free(int dof) {
  raise(&dofs_[static_cast<std::size_t>(dof)], DofMode::kFree);
}

}  // namespace biodyn::controllers
