#include <fstream>

#include "biodyn/sim/errors.h"
#include "biodyn/sim/model.h"
#include "biodyn/sim/simulation.h"
#include "test_support.h"

using biodyn::sim::Model;
using biodyn::sim::ModelLoadError;
using biodyn::testing::MujocoWarningGuard;

namespace {
const char* kPendulum = R"(
<mujoco>
  <worldbody>
    <body name="link" pos="0 0 1">
      <joint name="hinge" type="hinge" axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0.5 0 0" size="0.05" mass="1"/>
    </body>
  </worldbody>
</mujoco>)";
}  // namespace

TEST_CASE_METHOD(biodyn::testing::SimulationTest, "Model loads MJCF text and names objects",
                 "[sim][model]") {
  Model m = Model::from_string(kPendulum);
  CHECK(m->nv == 1);
  CHECK(m.id(mjOBJ_JOINT, "hinge") == 0);
  CHECK_THROWS_WITH(m.id(mjOBJ_BODY, "nope"), Catch::Contains("body") && Catch::Contains("nope"));
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "MuJoCo's compile error becomes a ModelLoadError naming the source",
                 "[sim][model]") {
  const std::string bad =
      "<mujoco><worldbody><body><joint type='hinge'/></body></worldbody></mujoco>";
  try {
    Model::from_string(bad, "my_model.xml");
    FAIL("expected ModelLoadError");
  } catch (const ModelLoadError& e) {
    CHECK(e.source() == "my_model.xml");
    CHECK_THAT(e.what(), Catch::StartsWith("my_model.xml: "));
    CHECK(std::string(e.what()).size() > std::string("my_model.xml: ").size());
  }
  CHECK_THROWS_AS(Model::from_string("<mujoco><worldbody>", "truncated.xml"), ModelLoadError);
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest, "Loading a missing or broken file names the file",
                 "[sim][model]") {
  CHECK_THROWS_WITH(Model::from_file("/nonexistent/dir/model.xml"),
                    Catch::StartsWith("/nonexistent/dir/model.xml: "));
  const std::string path = biodyn::testing::binary_dir() + "/broken_model_test.xml";
  std::ofstream(path) << "<mujoco><worldbody><geom type='sphere' size='-1'/></worldbody></mujoco>";
  CHECK_THROWS_WITH(Model::from_file(path), Catch::StartsWith(path + ": "));
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest, "Model::copy is deep and independent",
                 "[sim][model]") {
  Model a = Model::from_string(kPendulum);
  Model b = a.copy();
  b->opt.timestep = 0.5;
  CHECK(a->opt.timestep != 0.5);
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest, "copy_state transfers the state bit-exactly",
                 "[sim][model]") {
  Model m = Model::from_string(kPendulum);
  biodyn::sim::Data a(*m), b(*m);
  a->qpos[0] = 0.3;
  a->qvel[0] = -1.25;
  a->time = 2.0;
  biodyn::sim::copy_state(*m, *a, b.get());
  CHECK(b->qpos[0] == 0.3);
  CHECK(b->qvel[0] == -1.25);
  CHECK(b->time == 2.0);
}
