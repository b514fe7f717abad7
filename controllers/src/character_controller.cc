#include "biodyn/controllers/character_controller.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>

#include "biodyn/sim/queries.h"

namespace biodyn::controllers {
namespace {

constexpr int kMaxRedos = 2;  // one per foot weld
// Hinge targets stay this far inside the joint stops: the limit spring starts at the stop
// and a target on it is never reached exactly.
constexpr double kTargetLimitMargin_rad = 2.0 * M_PI / 180.0;
// Hip flexion per radian of ankle tilt the ankle could not take: the trunk (about half the
// mass, its CoM ~0.3 m above the hips) moves the CoM about a third as far per radian as
// the whole body leaning about the ankles (CoM ~1 m up), so it needs about three times the
// angle; 2 keeps it gentler (the balance integrator asks for more if needed).
constexpr double kUnmetTiltToHip = 2.0;

// A geom of `foot` or of its children (toes) has a contact with the floor (any MuJoCo lists,
// margin included).
bool foot_on_floor(const mjModel& m, const mjData& d, int floor_geom, int foot) {
  constexpr double kAnyDistance = std::numeric_limits<double>::infinity();
  for (int b = foot; b < m.nbody; ++b) {
    if (b != foot && m.body_parentid[b] != foot) continue;
    if (sim::floor_contact_count(m, d, floor_geom, b, kAnyDistance) > 0) return true;
  }
  return false;
}

std::vector<JointGroup> groups_of(const sim::Simulation& sim) {
  return find_joint_groups(sim.model());
}

}  // namespace

CharacterController::CharacterController(sim::Simulation* sim, ControllerParams params,
                                         CharacterControllerConfig config)
    : sim_(sim),
      config_(config),
      joints_(sim->model(), groups_of(*sim), params, config.kind),
      limiter_(joints_.groups(), params),
      welds_(sim->model(), config.weld),
      balance_(sim->model(), config.balance),
      snapshot_(sim->model()),
      base_angles_(joints_.groups().size(), Eigen::Vector3d::Zero()),
      qfrc_limit_(static_cast<std::size_t>(sim->model().nv)),
      qfrc_other_(static_cast<std::size_t>(sim->model().nv)),
      torque_(static_cast<std::size_t>(sim->model().nv)) {
  floor_geom_ = mj_name2id(&sim->model(), mjOBJ_GEOM, "floor");
  const char* sides[2] = {"_l", "_r"};
  for (int s = 0; s < 2; ++s) {
    foot_[s] = mj_name2id(&sim->model(), mjOBJ_BODY, (std::string("foot") + sides[s]).c_str());
    group_ankle_[s] = find_group(groups(), std::string("ankle") + sides[s]);
    group_hip_[s] = find_group(groups(), std::string("hip") + sides[s]);
  }
}

void CharacterController::restore_state(const CharacterController& saved) {
  sim::Simulation* const sim = sim_;
  TargetDriver* const driver = driver_;
  *this = saved;
  sim_ = sim;
  driver_ = driver;
}

void CharacterController::set_params(const ControllerParams& params) {
  joints_.set_params(params);
  limiter_.set_params(params);
}

void CharacterController::set_weld_mode(WeldMode mode) {
  config_.weld.mode = mode;
  welds_.set_mode(sim_->mutable_model(), mode);
}

void CharacterController::reset() {
  welds_.reset(sim_->mutable_model());
  balance_.reset();
  sim_->forward();
  // The PD gains see the feet as supports (the character starts standing on both).
  joints_.reset(sim_->model(), sim_->data(), {foot_[0], foot_[1]});
  pose_ = Pose{};
  pose_.name = "initial";
  std::fill(base_angles_.begin(), base_angles_.end(), Eigen::Vector3d::Zero());
  pose_start_s_ = sim_->data().time;
}

void CharacterController::reset_in_pose(const Pose& pose) {
  const double tilt = place_in_pose(sim_->model(), sim_->data(), groups(), pose, balance_.params());
  reset();
  balance_.preset_sagittal_tilt(tilt);
  set_pose(pose);
}

void CharacterController::set_pose(const Pose& pose) {
  pose_ = pose;
  pose_start_s_ = sim_->data().time;
  const std::vector<JointGroup>& gs = groups();
  for (std::size_t g = 0; g < gs.size(); ++g) {
    const auto it = pose.angles_rad.find(gs[g].name);
    base_angles_[g] = it == pose.angles_rad.end() ? Eigen::Vector3d::Zero() : it->second;
  }
  for (int s = 0; s < 2; ++s) welds_.set_stance(sim_->mutable_model(), s, pose.stance[static_cast<std::size_t>(s)]);
}

void CharacterController::apply_targets() {
  const std::vector<JointGroup>& gs = groups();
  const double reach_at = pose_start_s_ + pose_.reach_time_s;
  // The sagittal tilt leans the stance legs about the ankles; the hips take it back so the
  // trunk stays upright. Whatever the ankle cannot take (its target would pass the joint
  // stop, e.g. in a deep squat) becomes hip flexion instead: leaning the trunk forward moves
  // the CoM the same way, by less per radian (paper §4.1 balances with the hips as well).
  double applied_tilt[2] = {0, 0}, unmet_tilt[2] = {0, 0};
  for (int s = 0; s < 2; ++s) {
    const int g = group_ankle_[s];
    if (g < 0) continue;
    const Eigen::Vector3d& base = base_angles_[static_cast<std::size_t>(g)];
    Eigen::Vector3d wanted = base;
    wanted[0] += offsets_.sagittal_tilt;
    const double reachable = clamp_to_range(gs[static_cast<std::size_t>(g)], wanted, kTargetLimitMargin_rad)[0];
    applied_tilt[s] = reachable - base[0];
    unmet_tilt[s] = wanted[0] - reachable;
  }
  for (std::size_t g = 0; g < gs.size(); ++g) {
    Eigen::Vector3d angles = base_angles_[g];
    // Both legs, stance or lifted: a lifted leg keeps the stance leg's lean (parallel to
    // it, foot level) instead of swinging back to the pelvis's vertical as it leaves the
    // floor, which would roll the body onto the foot being lifted.
    for (int s = 0; s < 2; ++s) {
      const double side_sign = s == 0 ? -1.0 : 1.0;  // frontal tilt: see poses.h
      if (static_cast<int>(g) == group_ankle_[s]) {
        angles[0] += applied_tilt[s];  // dorsiflexion leans the shank forward
        if (gs[g].dof_count > 1) angles[1] += side_sign * offsets_.frontal_tilt;
      }
      if (static_cast<int>(g) == group_hip_[s]) {
        angles[0] += -applied_tilt[s] + kUnmetTiltToHip * unmet_tilt[s] + offsets_.hip_flexion;
        angles[1] += side_sign * offsets_.frontal_tilt;
      }
    }
    angles = clamp_to_range(gs[g], angles, kTargetLimitMargin_rad);
    joints_.set_target(static_cast<int>(g), orientation_from_angles(gs[g], angles), reach_at);
  }
}

void CharacterController::set_joint_target(int group, const Eigen::Quaterniond& orientation,
                                           double reach_at_s) {
  joints_.set_target(group, orientation, reach_at_s);
}

void CharacterController::set_joint_angles(int group, Eigen::Vector3d angles_rad, double reach_at_s) {
  const JointGroup& g = groups()[static_cast<std::size_t>(group)];
  angles_rad = clamp_to_range(g, angles_rad, kTargetLimitMargin_rad);
  joints_.set_target(group, orientation_from_angles(g, angles_rad), reach_at_s);
}

void CharacterController::set_stance(int side, bool stance) {
  if (welds_.stance(side) != stance) welds_.set_stance(sim_->mutable_model(), side, stance);
}

void CharacterController::control(mjData& d, bool* outside) {
  mjModel& m = sim_->mutable_model();
  const int nv = m.nv;
  if (driver_ != nullptr) {
    offsets_ = BalanceOffsets{};
    driver_->drive(*this, m, d);
  } else {
    offsets_ = balance_.update(m, d, pose_.support, m.opt.timestep);
    apply_targets();
  }
  welds_.engage_at_strikes(m, d);

  std::fill(qfrc_limit_.begin(), qfrc_limit_.end(), 0.0);
  last_outside_ = limiter_.compute(m, d, qfrc_limit_.data());
  *outside = last_outside_ > 0;
  // Other forces acting this step: the limits and the pushes (xfrc_applied at body CoMs).
  std::copy(qfrc_limit_.begin(), qfrc_limit_.end(), qfrc_other_.begin());
  for (int b = 1; b < m.nbody; ++b) {
    const mjtNum* f = d.xfrc_applied + 6 * b;
    if (f[0] == 0 && f[1] == 0 && f[2] == 0 && f[3] == 0 && f[4] == 0 && f[5] == 0) continue;
    mj_applyFT(&m, &d, f, f + 3, d.xipos + 3 * b, b, qfrc_other_.data());
  }
  if (joints_.kind() == ControllerKind::kPd) {
    int supports[2], n = 0;
    for (int s = 0; s < 2; ++s)
      if (foot_on_floor(m, d, floor_geom_, foot_[s])) supports[n++] = foot_[s];
    joints_.update_pd_gains(m, d, supports, n);
  }
  last_status_ = joints_.compute(m, d, qfrc_other_.data(), torque_.data());
  for (int i = 0; i < nv; ++i) {
    d.qfrc_applied[i] = qfrc_limit_[static_cast<std::size_t>(i)] + torque_[static_cast<std::size_t>(i)];
  }
  for (int a = 0; a < m.nu; ++a) d.ctrl[a] = 0;  // the torques go through qfrc_applied
}

StepReport CharacterController::step() {
  mjModel& m = sim_->mutable_model();
  mjData& d = sim_->data();
  StepReport report;
  snapshot_.save(m, d);
  const StandingBalance balance_before = balance_;
  bool outside = false;
  bool released[2] = {false, false};
  for (int attempt = 0;; ++attempt) {
    report.status = sim_->step([&](const mjModel&, mjData& data) { control(data, &outside); });
    const int tense = welds_.measure(m, d);
    if (tense >= 0 && config_.weld.mode == WeldMode::kHonest && attempt < kMaxRedos) {
      // Undo, switch the offending weld off (and any released before in this step: the
      // snapshot has them on), and take the step again (foot_contact.h).
      snapshot_.restore(m, d);
      balance_ = balance_before;
      released[tense] = true;
      for (int s = 0; s < 2; ++s)
        if (released[s]) welds_.release_for_tension(m, s, d.time);
      ++report.redone;
      continue;
    }
    report.weld_tension = tense >= 0;
    break;
  }
  welds_.release_near_edges(m, d.time);
  joints_.commit();
  report.joints = last_status_;
  report.joints_outside_limits = last_outside_;
  report.balance = offsets_;
  for (int s = 0; s < 2; ++s) {
    report.weld[static_cast<std::size_t>(s)] = welds_.wrench(s);
    report.weld_active[static_cast<std::size_t>(s)] = welds_.active(m, s);
  }
  last_report_ = report;
  return report;
}

}  // namespace biodyn::controllers
