// The velocity-based walker (velocity_walker.h): its phase machine and targets.
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "biodyn/controllers/control_pipeline.h"
#include "biodyn/controllers/velocity_walker.h"
#include "biodyn/controllers/velocity_walker_params.h"
#include "biodyn/models/mjcf.h"
#include "biodyn/models/rig.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/queries.h"
#include "biodyn/sim/units.h"
#include "character.h"
#include "test_support.h"

using namespace biodyn;
using models::JointGroup;

using Catch::Matchers::Contains;

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "The gait driver runs its states on time and sets the tabled targets", "[gait]") {
  sim::Simulation sim(testing::generated_character());
  const models::Rig rig(sim.model());
  const std::vector<controllers::JointGroup>& groups = rig.groups();
  controllers::ControlPipeline ctrl(&sim, rig, controllers::default_params(sim.model(), groups),
                                    {});
  ctrl.reset_in_pose(controllers::pose_scenario("stand", groups, 0).front());
  controllers::VelocityWalkerParams params = controllers::default_velocity_walker_params();
  controllers::VelocityWalker gait(sim.model(), rig, params);
  controllers::GaitCommand command;
  command.speed_m_s = 0.0;
  gait.set_command(command);
  gait.reset(sim.model(), sim.data());
  ctrl.set_driver(&gait);
  // From standing the first state is the lift of the right foot (left in stance).
  REQUIRE(gait.phase_name() == "lift");
  CHECK(gait.stance_side() == 0);
  ctrl.step();
  const int knee_r = models::find_group(groups, "knee_r");
  const Eigen::Quaterniond want = controllers::orientation_from_angles(
      groups[static_cast<std::size_t>(knee_r)], params.phases[1].targets_rad.at("swing_knee"));
  CHECK(controllers::rotation_angle(ctrl.frame().target(knee_r).orientation.conjugate() * want) <
        1e-9);
  // The right foot is released (swing), the left wanted in stance.
  CHECK_FALSE(ctrl.welds().stance(1));
  CHECK(ctrl.welds().stance(0));
  // The lift lasts its duration scaled to the cadence at this speed, then the swing starts.
  const double lift = params.phases[1].duration_s * params.posture.reference_cadence_steps_per_min /
                      params.cadence(0.0);
  while (sim.data().time < lift - 1e-9) ctrl.step();
  ctrl.step();
  CHECK(gait.phase_name() == "swing");
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "The gait driver names a target role the model does not have", "[gait]") {
  const sim::Model model = testing::generated_character();
  const models::Rig rig(*model.get());
  controllers::VelocityWalkerParams params = controllers::default_velocity_walker_params();
  params.phases[0].targets_rad["swing_tail"] = Eigen::Vector3d::Zero();
  CHECK_THROWS_WITH(controllers::VelocityWalker(*model.get(), rig, params),
                    Contains("targets_deg.swing_tail: the model has no joint 'tail_r'"));
}
