// The standing controller: a pose held by the standing balance (standing_controller.h).
#include "biodyn/controllers/standing_controller.h"

#include "biodyn/controllers/joint_groups.h"

namespace biodyn::controllers {
namespace {

// Hip flexion per radian of ankle tilt the ankle could not take: the trunk (about half the
// mass, its CoM ~0.3 m above the hips) moves the CoM about a third as far per radian as
// the whole body leaning about the ankles (CoM ~1 m up), so it needs about three times the
// angle; 2 keeps it gentler (the balance integrator asks for more if needed).
constexpr double kUnmetTiltToHip = 2.0;

}  // namespace

StandingController::StandingController(const mjModel& m, const models::Rig& rig,
                                       BalanceParams balance)
    : rig_(&rig), balance_(m, rig, balance) {
  state_.base_angles.assign(rig.groups().size(), Eigen::Vector3d::Zero());
  for (int s = 0; s < 2; ++s) {
    group_ankle_[s] = rig.leg(s).ankle;
    group_hip_[s] = rig.leg(s).hip;
  }
}

void StandingController::reset(double time_s) {
  balance_.reset();
  state_.pose = Pose{};
  state_.pose.name = "initial";
  std::fill(state_.base_angles.begin(), state_.base_angles.end(), Eigen::Vector3d::Zero());
  state_.pose_start_s = time_s;
  state_.offsets = BalanceOffsets{};
}

void StandingController::set_pose(const Pose& pose, double time_s) {
  state_.pose = pose;
  state_.pose_start_s = time_s;
  const std::vector<JointGroup>& gs = rig_->groups();
  for (std::size_t g = 0; g < gs.size(); ++g) {
    const auto it = pose.angles_rad.find(gs[g].name);
    state_.base_angles[g] = it == pose.angles_rad.end() ? Eigen::Vector3d::Zero() : it->second;
  }
}

StandingControllerState StandingController::state() const {
  StandingControllerState s = state_;
  s.balance = balance_.state();
  return s;
}

void StandingController::restore(const StandingControllerState& state) {
  state_ = state;
  balance_.restore(state.balance);
}

void StandingController::drive(const ControlInput& in, ControlFrame* frame) {
  state_.offsets = balance_.update(in.m, in.d, state_.pose.support, in.m.opt.timestep);
  apply_targets(frame);
}

void StandingController::apply_targets(ControlFrame* frame) const {
  const std::vector<JointGroup>& gs = rig_->groups();
  const BalanceOffsets& offsets = state_.offsets;
  const double reach_at = state_.pose_start_s + state_.pose.reach_time_s;
  // The sagittal tilt leans the stance legs about the ankles; the hips take it back so the
  // trunk stays upright. Whatever the ankle cannot take (its target would pass the joint
  // stop, e.g. in a deep squat) becomes hip flexion instead: leaning the trunk forward moves
  // the CoM the same way, by less per radian (paper §4.1 balances with the hips as well).
  double applied_tilt[2] = {0, 0}, unmet_tilt[2] = {0, 0};
  for (int s = 0; s < 2; ++s) {
    const int g = group_ankle_[s];
    if (g < 0) continue;
    const Eigen::Vector3d& base = state_.base_angles[static_cast<std::size_t>(g)];
    Eigen::Vector3d wanted = base;
    wanted[0] += offsets.sagittal_tilt;
    const double reachable = clamp_to_range(gs[static_cast<std::size_t>(g)], wanted,
                                            ControlFrame::kTargetLimitMargin_rad)[0];
    applied_tilt[s] = reachable - base[0];
    unmet_tilt[s] = wanted[0] - reachable;
  }
  for (std::size_t g = 0; g < gs.size(); ++g) {
    Eigen::Vector3d angles = state_.base_angles[g];
    // Both legs, stance or lifted: a lifted leg keeps the stance leg's lean (parallel to
    // it, foot level) instead of swinging back to the pelvis's vertical as it leaves the
    // floor, which would roll the body onto the foot being lifted.
    for (int s = 0; s < 2; ++s) {
      const double side_sign = s == 0 ? -1.0 : 1.0;  // frontal tilt: see poses.h
      if (static_cast<int>(g) == group_ankle_[s]) {
        angles[0] += applied_tilt[s];  // dorsiflexion leans the shank forward
        if (gs[g].dof_count > 1) angles[1] += side_sign * offsets.frontal_tilt;
      }
      if (static_cast<int>(g) == group_hip_[s]) {
        angles[0] += -applied_tilt[s] + kUnmetTiltToHip * unmet_tilt[s] + offsets.hip_flexion;
        angles[1] += side_sign * offsets.frontal_tilt;
      }
    }
    frame->set_joint_angles(static_cast<int>(g), angles, reach_at);
  }
}

}  // namespace biodyn::controllers
