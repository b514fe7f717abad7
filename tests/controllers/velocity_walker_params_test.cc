// The velocity walker's gait as data (velocity_walker_params.h): JSON in and out, errors.
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "biodyn/controllers/velocity_walker_params.h"
#include "biodyn/models/mjcf.h"
#include "biodyn/models/rig.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/queries.h"
#include "biodyn/sim/units.h"
#include "character.h"
#include "test_support.h"

using namespace biodyn;

using Catch::Matchers::Contains;

TEST_CASE("Gait parameters round-trip through JSON and reject bad input by name", "[gait]") {
  const controllers::VelocityWalkerParams defaults = controllers::default_velocity_walker_params();
  REQUIRE_NOTHROW(defaults.validate());
  const nlohmann::json j = controllers::velocity_walker_json(defaults);
  controllers::VelocityWalkerParams back;
  back.phases.clear();
  controllers::apply_velocity_walker_json(j.dump(), "test.json", &back);
  CHECK(controllers::velocity_walker_json(back) == j);

  controllers::VelocityWalkerParams p = defaults;
  controllers::apply_velocity_walker_json(R"({"placement": {"capture_gain": 1.3}})", "g.json", &p);
  CHECK(p.placement.capture_gain == 1.3);
  CHECK(p.phases.size() == defaults.phases.size());
  controllers::apply_velocity_walker_json(
      R"({"compliance": {"stance_knee": 2.5}, "placement": {"swing_clearance_m": 0.08}})", "g.json",
      &p);
  CHECK(p.compliance.stance_knee == 2.5);
  CHECK(p.placement.swing_clearance_m == 0.08);

  const auto fails = [&](const std::string& text, const std::string& expected) {
    controllers::VelocityWalkerParams q = defaults;
    INFO(text);
    CHECK_THROWS_WITH(controllers::apply_velocity_walker_json(text, "g.json", &q),
                      Contains(expected));
    CHECK(controllers::velocity_walker_json(q) == j);  // untouched on error
  };
  fails(R"({"placement": {"capture_gian": 1}})", "g.json.placement.capture_gian: unknown key");
  fails(R"({"placement": {"capture_gain": "big"}})",
        "g.json.placement.capture_gain: must be a number");
  fails(R"({"placement": {"tolerance_fraction": 0.9}})",
        "gait.placement.tolerance_fraction: must be in (0, 0.5]");
  fails(R"({"states": [{"name": "a", "duration_s": 0.2}]})", "must end at the strike");
  fails(R"({"states": [{"duration_s": 0.2, "end": "strike"}]})",
        "g.json.states[0].name: is required");
  fails(R"({"states": [{"name": "a", "end": "later"}]})",
        "g.json.states[0].end: must be \"time\" or \"strike\"");
  fails(R"({"posture": {"cadence_steps_per_min": [100]}})", "needs one cadence per speed");
  fails(R"({"compliance": {"stance_knee": -1}})",
        "gait.compliance.stance_knee: must be in [0, 50]");
  fails(R"({"compliance": {"stiffness": 1}})", "g.json.compliance.stiffness: unknown key");
  fails(R"({"placement": {"swing_clearance_m": 0.5}})",
        "gait.placement.swing_clearance_m: must be in [0, 0.3] m");
  fails("{", "g.json: not valid JSON");
  fails(R"({"compliance": {"stance_knee": 1e400}})", "g.json: not valid JSON");  // out of range
}
