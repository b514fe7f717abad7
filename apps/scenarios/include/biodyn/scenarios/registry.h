#pragma once
/// The explicit registry of scenarios (MuJoCo MPC's task registry is the model): a name, a line
/// that says what it is, and how to build it. `biodyn pose`, `walk`, `render`, `view` and the
/// push sweep find their scenarios here; a new scenario is one entry in registry.cc.

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "biodyn/scenarios/scenario.h"

namespace biodyn::scenarios {

struct ScenarioInfo {
  std::string name;
  std::string summary;  ///< one line for --help
  /// Builds the scenario at t = 0 on `sim` (which it resets; it must outlive the scenario).
  std::function<std::unique_ptr<Scenario>(sim::Simulation* sim, const ScenarioConfig& config)> make;
};

/// Every scenario, in the order --help lists them.
const std::vector<ScenarioInfo>& scenario_registry();
/// Their names.
std::vector<std::string> scenario_names();
/// Throws sim::InvalidArgument "scenario: must be one of ..., got '<name>'" for an unknown name.
void check_scenario_name(const std::string& name);
/// Whether `name` is one of the pose scenarios (stand, squat, reach, one-leg).
bool is_pose_scenario(const std::string& name);

/// Validates `config` and builds its scenario on `sim` at t = 0. Throws sim::InvalidArgument
/// for a bad config (naming the field or file) or a model without the parts it needs.
std::unique_ptr<Scenario> make_scenario(sim::Simulation* sim, const ScenarioConfig& config);

}  // namespace biodyn::scenarios
