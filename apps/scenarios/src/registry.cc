// The explicit registry of scenarios (registry.h).
#include "biodyn/scenarios/registry.h"

#include <algorithm>

#include "biodyn/scenarios/mocap_scenario.h"
#include "biodyn/scenarios/pose_scenario.h"
#include "biodyn/scenarios/walk_scenario.h"
#include "biodyn/sim/errors.h"

namespace biodyn::scenarios {
namespace {

template <typename T>
std::unique_ptr<Scenario> build(sim::Simulation* sim, const ScenarioConfig& config) {
  return std::make_unique<T>(sim, config);
}

}  // namespace

const std::vector<ScenarioInfo>& scenario_registry() {
  static const std::vector<ScenarioInfo> registry = {
      {"stand", "quiet standing under the standing balance", build<PoseScenario>},
      {"squat", "a deep squat with heels down and back up", build<PoseScenario>},
      {"reach", "reaching forward with the right arm (full detail)", build<PoseScenario>},
      {"one-leg", "the weight shifted onto the left leg and back", build<PoseScenario>},
      {"walk", "walking from standing under the torque walker", build<WalkScenario>},
      {"stones", "walking, then the stepping stones (paper §4.2)", build<WalkScenario>},
      {"mocap", "a captured motion, played kinematically or tracked by the controllers",
       build<MocapScenario>},
  };
  return registry;
}

std::vector<std::string> scenario_names() {
  std::vector<std::string> names;
  for (const ScenarioInfo& s : scenario_registry()) names.push_back(s.name);
  return names;
}

void check_scenario_name(const std::string& name) {
  std::string known;
  for (const ScenarioInfo& s : scenario_registry()) {
    if (s.name == name) return;
    known += (known.empty() ? "" : ", ") + s.name;
  }
  throw sim::InvalidArgument("scenario: must be one of " + known + ", got '" + name + "'");
}

bool is_pose_scenario(const std::string& name) {
  const std::vector<std::string> poses = controllers::pose_scenario_names();
  return std::find(poses.begin(), poses.end(), name) != poses.end();
}

std::unique_ptr<Scenario> make_scenario(sim::Simulation* sim, const ScenarioConfig& config) {
  config.validate();
  for (const ScenarioInfo& s : scenario_registry())
    if (s.name == config.scenario) return s.make(sim, config);
  check_scenario_name(config.scenario);  // throws
  return nullptr;
}

}  // namespace biodyn::scenarios
