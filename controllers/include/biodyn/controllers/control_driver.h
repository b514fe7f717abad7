#pragma once
/// A control pipeline's drivers (control_pipeline.h): the stage that sets the joints' targets
/// and commands each step, what it reads, and what a step reports.

#include <mujoco/mujoco.h>

#include <algorithm>
#include <array>

#include "biodyn/controllers/control_frame.h"
#include "biodyn/controllers/foot_contact.h"
#include "biodyn/controllers/joint_controller.h"
#include "biodyn/controllers/poses.h"
#include "biodyn/models/rig.h"
#include "biodyn/sim/simulation.h"

namespace biodyn::controllers {

/// What one step did.
struct StepReport {
  sim::StepStatus status;          ///< MuJoCo warnings of the kept step
  JointControlStatus joints;       ///< torque ratios, saturation, solver iterations
  std::array<WeldWrench, 2> weld;  ///< each foot weld's wrench (zero when off)
  std::array<bool, 2> weld_active = {false, false};
  bool weld_tension = false;      ///< a kept step with a weld in tension (glue mode only)
  int redone = 0;                 ///< honest-mode redos of this step
  int joints_outside_limits = 0;  ///< ball joints outside their swing-twist limits
  BalanceOffsets balance;         ///< the standing balance's offsets (zero under another driver)
};

/// A foot's load, N: the vertical ground force on it (weld and contacts) in the report's step,
/// never negative. `side` 0 left, 1 right.
inline double foot_load_N(const StepReport& report, int side) {
  return std::max(report.weld[static_cast<std::size_t>(side)].ground_force_W.z(), 0.0);
}

/// What a driver reads each step.
struct ControlInput {
  const mjModel& m;
  const mjData& d;  ///< after mj_step1: positions, velocities and contacts of the current state
  const models::Rig& rig;
  const StepReport&
      last_report;  ///< the last kept step's (its weld wrenches give the feet's loads)
};

/// A stage that sets the joints' targets and commands each step: the standing controller, the
/// walkers, the motion tracker. Called inside the step; a step redone at the same time (honest
/// welds) calls it again with the same state: it must write the same frame and advance its own
/// state once. No allocation.
class ControlDriver {
 public:
  virtual ~ControlDriver() = default;
  virtual void drive(const ControlInput& in, ControlFrame* frame) = 0;
};

}  // namespace biodyn::controllers
