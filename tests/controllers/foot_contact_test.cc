// The foot welds (foot_contact.h): glue pulls, honest never does.
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "biodyn/controllers/control_pipeline.h"
#include "biodyn/controllers/foot_contact.h"
#include "biodyn/models/mjcf.h"
#include "biodyn/models/rig.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/queries.h"
#include "biodyn/sim/units.h"
#include "character.h"
#include "test_support.h"

using namespace biodyn;

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "Glue weld goes into tension when the body is lifted, honest does not",
                 "[controllers][weld]") {
  for (const controllers::WeldMode mode :
       {controllers::WeldMode::kGlue, controllers::WeldMode::kHonest}) {
    sim::Simulation sim(testing::generated_character(models::Detail::kGait));
    const mjModel& m = sim.model();
    const models::Rig rig(m);
    const auto& groups = rig.groups();
    controllers::ControlPipelineConfig cfg;
    cfg.weld.mode = mode;
    controllers::ControlPipeline ctrl(&sim, rig, controllers::default_params(m, groups), cfg);
    ctrl.reset();
    ctrl.set_pose(controllers::pose_scenario("stand", groups, 0).front());
    double mass = 0;
    for (int b = 0; b < m.nbody; ++b) mass += m.body_mass[b];
    // Lift with 1.5x body weight on the pelvis from t = 0.5 s for 0.3 s.
    sim.schedule_push({rig.pelvis(), Eigen::Vector3d(0, 0, 1.5 * mass * 9.81), 0.5, 0.3});
    int tension = 0, welded_before_lift = 0;
    for (int step = 0; step < 500; ++step) {
      const controllers::StepReport r = ctrl.step();
      tension += r.weld_tension;
      if (sim.data().time < 0.5 && r.weld_active[0] && r.weld_active[1]) ++welded_before_lift;
    }
    INFO(controllers::to_string(mode));
    if (mode == controllers::WeldMode::kGlue) {
      CHECK(welded_before_lift > 100);
      CHECK(tension > 0);
    } else {
      CHECK(tension == 0);
    }
  }
}
