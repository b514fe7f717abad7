// The character rig (models/rig.h): a character's parts resolved once, one typed error for a
// missing part.
#include "biodyn/models/rig.h"

#include <string>
#include <vector>

#include "biodyn/models/character.h"
#include "biodyn/models/mjcf.h"
#include "character.h"
#include "test_support.h"

using namespace biodyn;
using models::JointGroup;

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "Joint groups cover every actuated DOF with anatomical names", "[models]") {
  const sim::Model model = testing::generated_character();
  const mjModel& m = *model.get();
  const std::vector<JointGroup> groups = models::find_joint_groups(m);
  int dofs = 0;
  for (const JointGroup& g : groups) dofs += g.dof_count;
  CHECK(dofs == m.nv - 6);  // everything but the free root
  for (const char* name : {"hip_l", "knee_r", "ankle_l", "toe_r", "shoulder_l", "elbow_r",
                           "wrist_l", "lumbar", "thorax", "neck", "head", "clavicle_r"}) {
    INFO(name);
    CHECK(models::find_group(groups, name) >= 0);
  }
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "The rig resolves the generated character's parts to the ids MuJoCo names them by",
                 "[models]") {
  for (const models::Detail detail : {models::Detail::kFull, models::Detail::kGait}) {
    INFO(models::to_string(detail));
    const sim::Model model = testing::generated_character(detail);
    const mjModel& m = *model.get();
    const models::Rig rig(m);
    CHECK(rig.floor_geom() == mj_name2id(&m, mjOBJ_GEOM, "floor"));
    CHECK(rig.pelvis() == mj_name2id(&m, mjOBJ_BODY, "pelvis"));
    REQUIRE(rig.root_joint() >= 0);
    CHECK(m.jnt_type[rig.root_joint()] == mjJNT_FREE);
    CHECK(m.jnt_bodyid[rig.root_joint()] == rig.pelvis());
    const char* trunk = detail == models::Detail::kFull ? "thorax" : "trunk";
    CHECK(rig.trunk_body() == mj_name2id(&m, mjOBJ_BODY, trunk));
    double mass = 0;
    for (int b = 1; b < m.nbody; ++b) mass += m.body_mass[b];
    CHECK(rig.mass_kg() == Approx(mass).epsilon(1e-12));
    for (int side : {models::kLeft, models::kRight}) {
      const std::string sfx = models::kSideSuffix[side];
      INFO("side " << sfx);
      const models::RigLeg& leg = rig.leg(side);
      CHECK(leg.thigh == mj_name2id(&m, mjOBJ_BODY, ("thigh" + sfx).c_str()));
      CHECK(leg.shank == mj_name2id(&m, mjOBJ_BODY, ("shank" + sfx).c_str()));
      CHECK(leg.foot == mj_name2id(&m, mjOBJ_BODY, ("foot" + sfx).c_str()));
      CHECK(leg.toes == mj_name2id(&m, mjOBJ_BODY, ("toes" + sfx).c_str()));
      CHECK(leg.hip == rig.group("hip" + sfx));
      CHECK(leg.knee == rig.group("knee" + sfx));
      CHECK(leg.ankle == rig.group("ankle" + sfx));
      CHECK(leg.foot_weld ==
            mj_name2id(&m, mjOBJ_EQUALITY,
                       (std::string(models::kFootWeldPrefix) + sfx.substr(1)).c_str()));
      CHECK(leg.foot_weld >= 0);
      REQUIRE(leg.has_sole);
      const models::Sole sole = models::find_sole(m, leg.foot);
      CHECK(leg.sole.x_min == sole.x_min);
      CHECK(leg.sole.x_max == sole.x_max);
      CHECK(leg.sole.z == sole.z);
      CHECK(leg.sole.length_m() > 0.15);  // heel to toe tip of a 1.80 m adult
      CHECK(leg.thigh_length_m > 0.3);
      CHECK(leg.shank_length_m > 0.3);
      CHECK(rig.is_foot_part(leg.foot));
      if (leg.toes >= 0) CHECK(rig.is_foot_part(leg.toes));
      CHECK_FALSE(rig.is_foot_part(leg.shank));
    }
    CHECK_FALSE(rig.is_foot_part(rig.pelvis()));
    CHECK_FALSE(rig.is_foot_part(-1));
    CHECK(rig.hip_spacing_m() > 0.1);
    CHECK(rig.marker_site("LASI") == mj_name2id(&m, mjOBJ_SITE, "marker_LASI"));
    CHECK(rig.marker_site("LASI") >= 0);
    CHECK(rig.marker_site("NOPE") == -1);
    CHECK(rig.body("pelvis") == rig.pelvis());
    CHECK(rig.body("no_such_body") == -1);
    CHECK_NOTHROW(rig.require_legs("test"));
    CHECK_NOTHROW(rig.require_foot_welds("test"));
    CHECK(rig.require_group("knee_l", "test") == rig.leg(models::kLeft).knee);
    if (detail == models::Detail::kGait) {  // no spine: a part only the full body has says so
      CHECK_THROWS_WITH(rig.require_group("lumbar", "pose"), Catch::Contains("pose") &&
                                                                 Catch::Contains("'lumbar'") &&
                                                                 Catch::Contains("--detail full"));
      // The lower back is the one-segment upper body's joint (the walkers hold it).
      CHECK(rig.require_lower_back("test") == rig.require_group("trunk", "test"));
    } else {
      CHECK(rig.require_lower_back("test") == rig.require_group("lumbar", "test"));
    }
  }
}

TEST_CASE_METHOD(
    biodyn::testing::SimulationTest,
    "A model without a part its user needs gets one RigError naming the part and the user",
    "[models]") {
  // A pelvis on a free joint over a floor, one leg's thigh only: everything else absent.
  const sim::Model model = testing::load_inline(R"(
    <mujoco>
      <worldbody>
        <geom name="floor" type="plane" size="5 5 0.1"/>
        <body name="pelvis" pos="0 0 1">
          <freejoint/>
          <geom type="box" size="0.1 0.1 0.1"/>
          <body name="thigh_l" pos="0 0.1 -0.1">
            <joint name="hip_l" type="ball"/>
            <geom type="capsule" fromto="0 0 0 0 0 -0.4" size="0.05"/>
          </body>
        </body>
      </worldbody>
    </mujoco>)");
  const mjModel& m = *model.get();
  const models::Rig rig(m);  // absent parts are not an error until someone needs them
  CHECK(rig.pelvis() >= 0);
  CHECK(rig.floor_geom() >= 0);
  CHECK(rig.leg(models::kLeft).thigh >= 0);
  CHECK(rig.leg(models::kLeft).foot == -1);
  CHECK(rig.leg(models::kRight).thigh == -1);
  CHECK_FALSE(rig.leg(models::kLeft).has_sole);
  CHECK(rig.trunk_body() == -1);
  CHECK_NOTHROW(rig.require_root("walker"));
  CHECK_NOTHROW(rig.require_floor("walker"));
  CHECK_THROWS_AS(rig.require_legs("walker"), models::RigError);
  CHECK_THROWS_WITH(rig.require_legs("the torque walker"),
                    Catch::Contains("the torque walker") && Catch::Contains("shank_l"));
  CHECK_THROWS_WITH(rig.require_foot_welds("honest welds"),
                    Catch::Contains("honest welds") && Catch::Contains("foot_weld_l"));
  CHECK_THROWS_WITH(rig.require_group("knee_r", "pose"),
                    Catch::Contains("pose") && Catch::Contains("knee_r"));
  CHECK_THROWS_WITH(rig.require_lower_back("torque walker"),
                    Catch::Contains("torque walker") && Catch::Contains("'lumbar' or 'trunk'"));
  CHECK_THROWS_WITH(rig.require_body("thorax", "push"),
                    Catch::Contains("push") && Catch::Contains("thorax"));
  CHECK(rig.require_body("thigh_l", "push") == rig.leg(models::kLeft).thigh);
  // A RigError is an InvalidArgument: the CLI reports it as bad input, not as a crash.
  CHECK_THROWS_AS(rig.require_group("knee_r", "pose"), sim::InvalidArgument);

  const sim::Model floating = testing::load_inline(R"(
    <mujoco><worldbody><body name="box"><geom type="box" size="0.1 0.1 0.1"/></body></worldbody></mujoco>)");
  const models::Rig bare(*floating.get());
  CHECK_THROWS_WITH(bare.require_root("stand"), Catch::Contains("pelvis"));
  CHECK_THROWS_WITH(bare.require_floor("stand"), Catch::Contains("floor"));
}
