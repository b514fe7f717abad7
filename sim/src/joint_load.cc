// Motor plus range-stop load per DOF (joint_load.h).
#include "biodyn/sim/joint_load.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "biodyn/sim/errors.h"
#include "biodyn/sim/queries.h"

namespace biodyn::sim {

JointLoadMeter::JointLoadMeter(const mjModel& m, std::vector<double> tau_max, double impact_s)
    : tau_max_(std::move(tau_max)),
      impact_steps_(std::lround(std::max(0.0, impact_s) / m.opt.timestep)),
      row_(static_cast<std::size_t>(m.nv)),
      stop_(static_cast<std::size_t>(m.nv)) {
  if (static_cast<int>(tau_max_.size()) != m.nv) {
    throw InvalidArgument("joint load: tau_max has " + std::to_string(tau_max_.size()) +
                          " values, the model " + std::to_string(m.nv) + " DOFs");
  }
}

double JointLoadMeter::measure(const mjModel& m, const mjData& d, JointLoadStats* stats) {
  joint_stop_torques(m, d, row_.data(), stop_.data());
  double worst = 0;
  int worst_dof = -1;
  for (int i = 0; i < m.nv; ++i) {
    const auto k = static_cast<std::size_t>(i);
    if (std::abs(stop_[k]) > stats->stop_peak_Nm) {
      stats->stop_peak_Nm = std::abs(stop_[k]);
      stats->stop_peak_dof = i;
    }
    if (tau_max_[k] <= 0) continue;
    // The joint's torque: its motors (MuJoCo actuators, or torques the controllers apply as
    // qfrc_applied: control_pipeline.h, with the ball joints' swing-twist limits) plus its stop.
    const double load = std::abs(d.qfrc_actuator[i] + d.qfrc_applied[i] + stop_[k]) / tau_max_[k];
    if (load > worst) {
      worst = load;
      worst_dof = i;
    }
    if (load > stats->load_peak_ratio) {
      stats->load_peak_ratio = load;
      stats->load_peak_dof = i;
    }
  }
  ++stats->steps;
  if (worst > 1) {
    ++stats->over_steps;
    if (++stats->over_run > stats->over_longest) {
      stats->over_longest = stats->over_run;
      stats->over_longest_dof = worst_dof;  // the worst DOF as the longest stretch ended
    }
    if (stats->over_run > impact_steps_) stats->excess_sum += (worst - 1) * (worst - 1);
  } else {
    stats->over_run = 0;
  }
  return worst;
}

}  // namespace biodyn::sim
