#pragma once
/// Stepping a model: one Simulation owns a Model, its mjData and a scratch mjData for queries
/// that must not disturb the simulation. Steps as mj_step1 -> controller -> mj_step2
/// (walking-notes.md: consistent kinematics for the controller at half the cost of
/// mj_forward + mj_step). Counts MuJoCo's warnings instead of printing them.

#include <mujoco/mujoco.h>

#include <Eigen/Core>
#include <array>
#include <string>
#include <vector>

#include "biodyn/sim/model.h"
#include "biodyn/sim/snapshot.h"

namespace biodyn::sim {

/// Number of times each MuJoCo warning (mjtWarning) fired.
struct WarningCounts {
  std::array<long, mjNWARNING> count{};  ///< indexed by mjtWarning

  long total() const;
  /// Bad qpos, qvel or qacc: the state diverged, and MuJoCo reset the data itself.
  long diverged() const;
  /// "contact list full x3, bad qacc x1", or "none".
  std::string describe() const;
  WarningCounts& operator+=(const WarningCounts& other);
};

/// Name of a MuJoCo warning, e.g. "contact list full" for mjWARN_CONTACTFULL.
const char* warning_name(int warning);

/// A horizontal or any other external force on one body, applied at the body's centre of mass
/// through `xfrc_applied` (references.md, push protocol).
struct Push {
  int body = -1;                                      ///< body id receiving the force
  Eigen::Vector3d force_W = Eigen::Vector3d::Zero();  ///< N, world frame
  double start_s = 0.0;                               ///< s, simulation time of onset
  double duration_s = 0.0;                            ///< s, > 0
};

/// Result of one step.
struct StepStatus {
  WarningCounts new_warnings;  ///< warnings raised during this step
  bool ok() const { return new_warnings.total() == 0; }
};

/// Owns a model, its data and a scratch data. Not copyable; one per thread.
class Simulation {
 public:
  /// Takes the model; allocates data and scratch, resets to the initial state and runs
  /// mj_forward so derived quantities are valid.
  explicit Simulation(Model model);

  const mjModel& model() const { return *model_; }
  /// Mutable model access: equality activation (`eq_active`) is a model field in 2.2.2.
  mjModel& mutable_model() { return *model_; }
  mjData& data() { return *data_; }
  const mjData& data() const { return *data_; }

  /// Restores the model's initial state (qpos0 or keyframe `key` if >= 0), clears pushes and
  /// the warning counts, and runs mj_forward.
  void reset(int key = -1);

  /// Recomputes derived quantities for the current state (mj_forward).
  void forward();

  /// Advances one timestep with no controller (ctrl as currently set).
  StepStatus step() {
    return step([](const mjModel&, mjData&) {});
  }

  /// Advances one timestep. `control(model, data)` runs between mj_step1 and mj_step2, when
  /// positions, velocities and contacts of the current state are computed; it writes ctrl or
  /// qfrc_applied. No allocation happens here.
  template <typename Control>
  StepStatus step(Control&& control) {
    apply_pushes();
    mj_step1(model_.get(), data_.get());
    control(static_cast<const mjModel&>(*model_), *data_);
    mj_step2(model_.get(), data_.get());
    return collect_warnings();
  }

  /// Schedules an external push (validated: body exists, duration > 0, finite force).
  /// Throws InvalidArgument. Allocation happens here, never in step().
  void schedule_push(const Push& push);
  const std::vector<Push>& pushes() const { return pushes_; }

  /// Everything this simulation's future depends on: the data (DataCheckpoint: state, derived
  /// fields a controller may read, the welds' model fields), the pushes and the warning counts.
  struct Checkpoint {
    DataCheckpoint data;
    std::vector<Push> pushes;
    std::vector<Eigen::Vector3d> push_applied_W;
    std::array<int, mjNWARNING> seen{};
    WarningCounts warnings;
  };
  /// Saves into `c` (its storage is reused once grown). Restoring it later makes the following
  /// steps bit-identical to those that followed the save (rewind: scenarios/live.h).
  void save(Checkpoint* c) const;
  void restore(const Checkpoint& c);

  /// Warnings accumulated since construction or the last reset().
  const WarningCounts& warnings() const { return warnings_total_; }

  /// The scratch mjData with the current simulation state copied in (copy_state) and
  /// mj_forward run. Use it for queries that overwrite fields (mj_inverse, mj_jac*, ...).
  mjData& synced_scratch();

 private:
  void apply_pushes();
  StepStatus collect_warnings();

  Model model_;
  Data data_;
  Data scratch_;
  std::vector<Push> pushes_;
  std::vector<Eigen::Vector3d> push_applied_W_;  // what each push wrote into xfrc_applied
  std::array<int, mjNWARNING> seen_{};           // warning[i].number already counted
  WarningCounts warnings_total_;
};

}  // namespace biodyn::sim
