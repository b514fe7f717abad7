// The joint controllers' parameters (controller_params.h): defaults, JSON, errors.
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "biodyn/controllers/controller_params.h"
#include "biodyn/models/mjcf.h"
#include "biodyn/models/rig.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/queries.h"
#include "biodyn/sim/units.h"
#include "character.h"
#include "test_support.h"

using namespace biodyn;
using models::JointGroup;

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "Controller params: defaults from the motors, JSON overrides, clear errors",
                 "[controllers]") {
  const sim::Model model = testing::generated_character();
  const mjModel& m = *model.get();
  const std::vector<JointGroup> groups = models::find_joint_groups(m);
  controllers::ControllerParams p = controllers::default_params(m, groups);
  const int knee = m.actuator_trnid[2 * mj_name2id(&m, mjOBJ_ACTUATOR, "knee_flexion_l")];
  (void)knee;
  const double knee_motor =
      m.actuator_ctrlrange[2 * mj_name2id(&m, mjOBJ_ACTUATOR, "knee_flexion_l") + 1];
  CHECK(p.at("knee_l").tau_max_Nm[0] == Approx(knee_motor));
  CHECK(p.at("knee_l").reaction_time_s == Approx(0.02));  // paper §5.1
  // An unknown joint's error lists the joints there are (a viewer script's `set tau_scale
  // lumbar` on the paper's lower-body model, whose lower back is `trunk`).
  CHECK_THROWS_WITH(p.at("spine"), Catch::Contains("no joint named 'spine'") &&
                                       Catch::Contains("knee_l") && Catch::Contains("lumbar"));

  controllers::apply_params_json(
      R"({"joints": {"all": {"reaction_time_s": 0.1}, "knee": {"tau_max_Nm": 400},
                     "knee_r": {"reach_time_s": 0.5}}})",
      "p.json", groups, &p);
  CHECK(p.at("hip_l").reaction_time_s == Approx(0.1));
  CHECK(p.at("knee_l").tau_max_Nm[0] == Approx(400));
  CHECK(p.at("knee_r").tau_max_Nm[0] == Approx(400));
  CHECK(p.at("knee_r").reach_time_s == Approx(0.5));
  CHECK(p.at("knee_l").reach_time_s == Approx(0.3));

  // Round trip through JSON.
  controllers::ControllerParams q = controllers::default_params(m, groups);
  controllers::apply_params_json(controllers::params_to_json(p, groups).dump(), "x", groups, &q);
  for (std::size_t g = 0; g < groups.size(); ++g) {
    CHECK(q.joints[g].tau_max_Nm.isApprox(p.joints[g].tau_max_Nm));
    CHECK(q.joints[g].reaction_time_s == Approx(p.joints[g].reaction_time_s));
  }

  const auto error_of = [&](const std::string& json) {
    controllers::ControllerParams t = controllers::default_params(m, groups);
    try {
      controllers::apply_params_json(json, "p.json", groups, &t);
      t.validate(m.opt.timestep);
    } catch (const sim::InvalidArgument& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  CHECK_THAT(error_of(R"({"joints": {"kne": {}}})"), Catch::Contains("p.json: joints.kne"));
  CHECK_THAT(error_of(R"({"joints": {"hip_l": {"tau_max_Nm": [1, 2]}}})"),
             Catch::Contains("must have 3 entries"));
  CHECK_THAT(error_of(R"({"joints": {"knee": {"reaction_time_s": -1}}})"),
             Catch::Contains("joints.knee_l.reaction_time_s"));
  CHECK_THAT(error_of(R"({"joints": {"knee": {"speed": 1}}})"), Catch::Contains("unknown key"));
  CHECK_THAT(error_of("{not json"), Catch::Contains("p.json: not valid JSON"));
  // A number beyond a double's range is bad input too (nlohmann throws out_of_range for it).
  CHECK_THAT(error_of(R"({"joints": {"knee": {"reaction_time_s": 1e400}}})"),
             Catch::Contains("p.json: not valid JSON") && Catch::Contains("1e400"));
  CHECK_THAT(error_of(R"({"controller": {"velocity_horizon_s": 0.001}})"),
             Catch::Contains("velocity_horizon_s"));
}
