#pragma once
// What the joints carry beside their motors. A joint's range stop (MuJoCo's joint-limit
// constraint, rigid and unbounded) is passive structure: a motion that leans on it is carried by
// bone and ligament, not by the body's strength. The meter adds the stops' torque to the
// motors' and compares the sum with each DOF's tau_max, so a result can say how far it leaned.

#include <mujoco/mujoco.h>

#include <vector>

namespace biodyn::sim {

/// Running figures of a JointLoadMeter (a copyable aggregate: saved and restored with a
/// scenario's state). "Load" is |motor + stop| / tau_max of a judged DOF, the motor being every
/// torque applied on the DOF (qfrc_actuator + qfrc_applied: controllers apply joint torques
/// either way; the ball joints' swing-twist limits come with them). Joint damping is not counted.
struct JointLoadStats {
  long steps = 0;         ///< steps measured
  long over_steps = 0;    ///< steps with some judged DOF's load above 1 (any DOF: a stretch may
                          ///< pass from one joint to another)
  long over_run = 0;      ///< steps in the stretch above 1 going on now
  long over_longest = 0;  ///< steps in the longest stretch above 1
  double stop_peak_Nm = 0, load_peak_ratio = 0;
  int stop_peak_dof = -1, load_peak_dof = -1;  ///< -1: none yet
  int over_longest_dof = -1;  ///< the worst DOF at the last step of the longest stretch
  double excess_sum = 0;      ///< sum over steps of max(0, worst load - 1)^2
};

class JointLoadMeter {
 public:
  /// `tau_max` per DOF (nv): the strength a DOF's load is judged against; <= 0: not judged (its
  /// stop torque still counts for stop_peak). `impact_s`: stretches above 1 up to this long add
  /// nothing to excess_sum. Allocates its buffers.
  JointLoadMeter(const mjModel& m, std::vector<double> tau_max, double impact_s = 0.01);
  /// Adds this step (d after mj_step: its motor forces and constraint forces belong together).
  /// Returns the worst load. No allocation.
  double measure(const mjModel& m, const mjData& d, JointLoadStats* stats);

 private:
  std::vector<double> tau_max_;
  long impact_steps_;
  std::vector<mjtNum> row_, stop_;
};

}  // namespace biodyn::sim
