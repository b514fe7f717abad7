// The control pipeline (control_pipeline.h).
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "biodyn/controllers/control_pipeline.h"
#include "biodyn/models/mjcf.h"
#include "biodyn/models/rig.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/queries.h"
#include "biodyn/sim/units.h"
#include "character.h"
#include "test_support.h"

using namespace biodyn;

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "Sparse and dense constraint Jacobians give the same control and weld wrenches",
                 "[controllers][dynamics][weld]") {
  // The generated characters use sparse rows (faster Newton); the whole-body solve and the
  // weld wrench read rows either way. Stand glued with bent knees, both models in lockstep.
  models::PhysicsOptions dense_options;
  dense_options.sparse_jacobian = false;
  const models::Character c = models::generate_character({});
  sim::Simulation sparse(testing::load_inline(models::to_mjcf(c)));
  sim::Simulation dense(testing::load_inline(models::to_mjcf(c, dense_options)));
  REQUIRE(mj_isSparse(&sparse.model()));
  REQUIRE_FALSE(mj_isSparse(&dense.model()));
  const models::Rig rig_sparse(sparse.model()), rig_dense(dense.model());
  const auto& groups = rig_sparse.groups();
  controllers::ControlPipelineConfig cfg;
  cfg.weld.mode = controllers::WeldMode::kGlue;
  controllers::ControlPipeline a(&sparse, rig_sparse,
                                 controllers::default_params(sparse.model(), groups), cfg);
  controllers::ControlPipeline b(&dense, rig_dense,
                                 controllers::default_params(dense.model(), groups), cfg);
  const controllers::Pose squat = controllers::pose_scenario("squat", groups, 0).front();
  for (controllers::ControlPipeline* ctrl : {&a, &b}) {
    ctrl->reset_in_pose(controllers::pose_scenario("stand", groups, 0).front());
    ctrl->set_pose(squat);
  }
  double worst_torque = 0, worst_weld = 0, peak_weld = 0;
  int welded = 0;
  for (int step = 0; step < 150; ++step) {
    const controllers::StepReport ra = a.step(), rb = b.step();
    for (int i = 0; i < sparse.model().nv; ++i)
      worst_torque = std::max(
          worst_torque, std::abs(sparse.data().qfrc_applied[i] - dense.data().qfrc_applied[i]));
    for (std::size_t s = 0; s < 2; ++s) {
      welded += ra.weld_active[s] && rb.weld_active[s];
      worst_weld = std::max(worst_weld, (ra.weld[s].force_W - rb.weld[s].force_W).norm());
      peak_weld = std::max(peak_weld, rb.weld[s].force_W.norm());
    }
  }
  INFO("worst torque difference " << worst_torque << " N m, weld force " << worst_weld
                                  << " N of peak " << peak_weld << " N");
  CHECK(welded > 200);
  CHECK(peak_weld > 1);  // the welds carry some load (the contacts carry most)
  // Rounding only: the two factorisations add in different orders.
  CHECK(worst_torque < 1e-6);
  CHECK(worst_weld < 1e-6 * peak_weld);
}
