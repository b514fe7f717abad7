// The muscle set (muscles/muscle_set.h): parameter files refused in one message naming the file,
// the muscle, the field and the value, a good one applied (a side-less name to both sides); the
// set bound to the generated character's tendons (which DOFs each muscle spans); and the muscle
// drive holding a constant wanted torque (muscles/muscle_drive.h).
#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <string>
#include <vector>

#include "biodyn/models/character.h"
#include "biodyn/models/mjcf.h"
#include "biodyn/models/rig.h"
#include "biodyn/muscles/muscle_drive.h"
#include "biodyn/muscles/muscle_set.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/model.h"
#include "biodyn/sim/units.h"
#include "character.h"
#include "test_support.h"

namespace biodyn::muscles::muscle_set_test {
namespace {

constexpr const char* kSource = "legs.json";

using testing::muscled_character;

const MuscleParams& find(const std::vector<MuscleParams>& params, const std::string& name) {
  for (const MuscleParams& p : params)
    if (p.name == name) return p;
  FAIL("no muscle " << name);
  return params.front();
}

// The message apply_muscle_overrides throws for `json` (empty if it does not throw).
std::string refusal(const std::string& json, std::vector<MuscleParams> params) {
  try {
    apply_muscle_overrides(json, kSource, &params);
  } catch (const sim::InvalidArgument& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST_CASE("muscle parameter files: a good one applies, side-less names to both sides",
          "[muscles]") {
  const models::Character c = muscled_character();
  REQUIRE(c.muscles.size() == 36);  // 18 per leg
  const std::vector<MuscleParams> before = muscle_params(c.muscles, TendonChoice::kPerMuscle);
  std::vector<MuscleParams> params = before;
  apply_muscle_overrides(R"({"muscles": {
      "soleus": {"max_isometric_force_N": 5000, "tendon": "rigid", "fiber_damping": 0.2},
      "tib_ant_l": {"scale_max_isometric_force": 2, "pennation_at_optimal_deg": 10},
      "vasti_r": {"optimal_fiber_length_m": 0.09, "tendon_slack_length_m": 0.2,
                  "max_contraction_velocity_lopt_per_s": 12, "activation_time_constant_s": 0.01,
                  "deactivation_time_constant_s": 0.04, "min_activation": 0.02}}})",
                         kSource, &params);
  for (const char* side : {"soleus_l", "soleus_r"}) {
    CHECK(find(params, side).max_isometric_force_N == 5000);
    CHECK(find(params, side).tendon == TendonModel::kRigid);
    CHECK(find(params, side).fiber_damping == 0.2);
  }
  CHECK(find(params, "tib_ant_l").max_isometric_force_N ==
        Approx(2 * find(before, "tib_ant_l").max_isometric_force_N));
  CHECK(find(params, "tib_ant_l").pennation_at_optimal_rad == Approx(10 * kRadPerDeg));
  CHECK(find(params, "tib_ant_r").max_isometric_force_N ==
        find(before, "tib_ant_r").max_isometric_force_N);
  const MuscleParams& v = find(params, "vasti_r");
  CHECK(v.optimal_fiber_length_m == 0.09);
  CHECK(v.tendon_slack_length_m == 0.2);
  CHECK(v.max_contraction_velocity_lopt_per_s == 12);
  CHECK(v.activation_time_constant_s == 0.01);
  CHECK(v.deactivation_time_constant_s == 0.04);
  CHECK(v.min_activation == 0.02);
  CHECK(find(params, "vasti_l").optimal_fiber_length_m ==
        find(before, "vasti_l").optimal_fiber_length_m);
  // Untouched muscles keep their values.
  CHECK(find(params, "glut_max_l").max_isometric_force_N ==
        find(before, "glut_max_l").max_isometric_force_N);
  // The anatomy's defaults: compliant soleus and gastrocnemius, rigid others.
  CHECK(find(before, "gastroc_r").tendon == TendonModel::kCompliant);
  CHECK(find(before, "vasti_r").tendon == TendonModel::kRigid);
  for (const MuscleParams& p : muscle_params(c.muscles, TendonChoice::kAllRigid))
    CHECK(p.tendon == TendonModel::kRigid);
}

TEST_CASE("muscle parameter files: bad ones are refused naming file, muscle, field and value",
          "[muscles]") {
  const std::vector<MuscleParams> params =
      muscle_params(muscled_character().muscles, TendonChoice::kPerMuscle);
  struct Case {
    const char* what;
    std::string json;
    std::vector<std::string> named;  // every one must be in the message
  };
  const std::vector<Case> cases = {
      {"unknown muscle",
       R"({"muscles": {"soleos": {"max_isometric_force_N": 5000}}})",
       {kSource, "soleos", "soleus_l", "tib_post_r"}},
      {"unknown field",
       R"({"muscles": {"soleus_l": {"max_force_N": 5000}}})",
       {kSource, "soleus_l", "max_force_N", "max_isometric_force_N"}},
      {"not a number",
       R"({"muscles": {"soleus": {"max_isometric_force_N": "lots"}}})",
       {kSource, "soleus", "max_isometric_force_N", "lots"}},
      {"negative F_max",
       R"({"muscles": {"gastroc_r": {"max_isometric_force_N": -1500}}})",
       {kSource, "gastroc_r", "max_isometric_force_N", "-1500"}},
      {"bad tendon string",
       R"({"muscles": {"tib_ant": {"tendon": "springy"}}})",
       {kSource, "tib_ant", "tendon", "springy", "rigid", "compliant"}},
      {"tendon not a string",
       R"({"muscles": {"tib_ant": {"tendon": 3}}})",
       {kSource, "tib_ant", "tendon", "3"}},
      {"scale out of range",
       R"({"muscles": {"vasti": {"scale_max_isometric_force": 0}}})",
       {kSource, "vasti", "scale_max_isometric_force", "0"}},
      {"pennation too large",
       R"({"muscles": {"soleus_r": {"pennation_at_optimal_deg": 90}}})",
       {kSource, "soleus_r", "pennation_at_optimal_deg", "90"}},
      {"negative time constant",
       R"({"muscles": {"rect_fem": {"activation_time_constant_s": -0.01}}})",
       {kSource, "rect_fem", "activation_time_constant_s", "-0.01"}},
      {"invalid JSON", R"({"muscles": {"soleus": {)", {kSource, "JSON"}},
      {"no muscles object", R"({"soleus": {}})", {kSource, "muscles"}},
      {"muscle not an object", R"({"muscles": {"soleus": 5}})", {kSource, "soleus"}},
  };
  for (const Case& k : cases) {
    const std::string message = refusal(k.json, params);
    INFO(k.what << ": " << message);
    REQUIRE_FALSE(message.empty());
    for (const std::string& word : k.named) CHECK(message.find(word) != std::string::npos);
    CHECK(message.find('\n') == std::string::npos);  // one line
  }
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "muscle set: bound to the tendons, spans its joints, refuses a model without them",
                 "[muscles]") {
  const models::Character c = muscled_character();
  const sim::Model model = sim::Model::from_string(models::to_mjcf(c));
  const mjModel& m = *model;
  const MuscleSet set(m, muscle_params(c.muscles, TendonChoice::kPerMuscle));
  REQUIRE(set.size() == 36);
  const auto dof_names = [&](int i) {
    std::vector<std::string> names;
    for (std::size_t k = 0; k < set.covered_dofs().size(); ++k) {
      const auto& of = set.muscles_of_dof()[k];
      if (std::find(of.begin(), of.end(), i) == of.end()) continue;
      const int dof = set.covered_dofs()[k];
      std::string name = mj_id2name(&m, mjOBJ_JOINT, m.dof_jntid[dof]);
      if (m.jnt_type[m.dof_jntid[dof]] == mjJNT_BALL)
        name += std::string("_") + "xyz"[dof - m.jnt_dofadr[m.dof_jntid[dof]]];
      names.push_back(name);
    }
    return names;
  };
  const auto index = [&](const std::string& name) {
    for (int i = 0; i < set.size(); ++i)
      if (set.params(i).name == name) return i;
    return -1;
  };
  using V = std::vector<std::string>;
  CHECK(dof_names(index("soleus_r")) == V{"ankle_dorsiflexion_r", "ankle_inversion_r"});
  CHECK(dof_names(index("vasti_l")) == V{"knee_flexion_l"});
  CHECK(dof_names(index("glut_med_ant_l")) == V{"hip_l_x", "hip_l_y", "hip_l_z"});
  CHECK(dof_names(index("rect_fem_r")) == V{"hip_r_x", "hip_r_y", "hip_r_z", "knee_flexion_r"});
  CHECK(dof_names(index("gastroc_l")) ==
        V{"knee_flexion_l", "ankle_dorsiflexion_l", "ankle_inversion_l"});
  CHECK(dof_names(index("ext_dig_r")) ==
        V{"ankle_dorsiflexion_r", "ankle_inversion_r", "toe_dorsiflexion_r"});
  // 2 legs x (hip 3 + knee 1 + ankle 2 + toes 1, by the toe extensor): no root, no trunk.
  CHECK(set.covered_dofs().size() == 14);
  // A model generated without muscles has no tendons to bind.
  models::CharacterSpec bare;
  bare.detail = models::Detail::kGait;
  const sim::Model plain =
      sim::Model::from_string(models::to_mjcf(models::generate_character(bare)));
  CHECK_THROWS_WITH(MuscleSet(*plain, muscle_params(c.muscles, TendonChoice::kPerMuscle)),
                    Catch::Contains("glut_max_l") && Catch::Contains("--muscles"));
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "muscle drive: a constant wanted torque is reached and held by the muscles",
                 "[muscles]") {
  constexpr double kWantedAnkle_Nm = -40.0;  // plantarflexion, as in quiet standing
  constexpr double kWantedKnee_Nm = -20.0;   // extension
  constexpr double kTauMax_Nm = 300.0;
  constexpr int kSteps = 1000;  // 2 s at 2 ms: 40 deactivation time constants, 13 of the
                                // compliant fibres' relaxation (~0.15 s)
  constexpr double kHeldTolerance_Nm = 1e-6;  // muscles + backups = wanted
  constexpr double kMuscleShare = 0.99;       // the muscles give (nearly) all of it
  constexpr double kSettled = 1e-9;           // activation change per step at the end
  const models::Character c = muscled_character();
  const sim::Model model = sim::Model::from_string(models::to_mjcf(c));
  const mjModel& m = *model;
  sim::Data data(m);
  mjData& d = *data;
  mj_forward(&m, &d);
  const models::Rig rig(m);
  const int ankle = rig.groups()[static_cast<std::size_t>(rig.leg(models::kRight).ankle)].dof_begin;
  const int knee = rig.groups()[static_cast<std::size_t>(rig.leg(models::kLeft).knee)].dof_begin;
  MuscleDrive drive(m, MuscleSet(m, muscle_params(c.muscles, TendonChoice::kPerMuscle)),
                    std::vector<double>(static_cast<std::size_t>(m.nv), kTauMax_Nm));
  std::vector<double> wanted(static_cast<std::size_t>(m.nv), 0.0);
  std::vector<double> zero = wanted, qfrc = wanted;
  drive.reset(m, d, zero.data());
  wanted[static_cast<std::size_t>(ankle)] = kWantedAnkle_Nm;
  wanted[static_cast<std::size_t>(knee)] = kWantedKnee_Nm;
  std::vector<double> last_activation;
  for (int step = 0; step < kSteps; ++step) {
    drive.compute(m, d, wanted.data(), qfrc.data());
    drive.commit();
    if (step == kSteps - 2) last_activation = drive.state().activation;
  }
  const MuscleDriveState& s = drive.state();
  CHECK(s.qp_failures == 0);
  CHECK(s.fiber_failures == 0);
  const std::vector<int>& dofs = drive.set().covered_dofs();
  for (std::size_t k = 0; k < dofs.size(); ++k) {
    INFO("dof " << dofs[k] << ": wanted " << wanted[static_cast<std::size_t>(dofs[k])]
                << ", muscles " << s.muscle_torque_Nm[k] << ", backup " << s.backup_torque_Nm[k]);
    CHECK(qfrc[static_cast<std::size_t>(dofs[k])] ==
          Approx(wanted[static_cast<std::size_t>(dofs[k])]).margin(kHeldTolerance_Nm));
  }
  const auto row = [&](int dof) {
    return static_cast<std::size_t>(std::find(dofs.begin(), dofs.end(), dof) - dofs.begin());
  };
  CHECK(s.muscle_torque_Nm[row(ankle)] == Approx(kWantedAnkle_Nm).epsilon(1 - kMuscleShare));
  CHECK(s.muscle_torque_Nm[row(knee)] == Approx(kWantedKnee_Nm).epsilon(1 - kMuscleShare));
  // Settled: the activations no longer change.
  for (std::size_t i = 0; i < last_activation.size(); ++i)
    CHECK(s.activation[i] == Approx(last_activation[i]).margin(kSettled));
}

}  // namespace biodyn::muscles::muscle_set_test

namespace biodyn::muscles::muscle_set_test {

TEST_CASE(
    "muscle parameter files: side-specific entries win, scales do not compound, a refused "
    "file changes nothing",
    "[muscles]") {
  const models::Character c = muscled_character();
  const std::vector<MuscleParams> table = muscle_params(c.muscles, TendonChoice::kPerMuscle);
  const auto find = [](const std::vector<MuscleParams>& ps, const std::string& name) {
    for (const MuscleParams& p : ps)
      if (p.name == name) return p;
    FAIL("no muscle " << name);
    return MuscleParams{};
  };
  std::vector<MuscleParams> params = table;
  // Keys in the order nlohmann would not sort them into: the side-specific one first.
  apply_muscle_overrides(R"({"muscles": {"soleus_l": {"scale_max_isometric_force": 3},
                                         "soleus": {"scale_max_isometric_force": 2}}})",
                         "m.json", &params);
  CHECK(find(params, "soleus_l").max_isometric_force_N ==
        Approx(3 * find(table, "soleus_l").max_isometric_force_N));
  CHECK(find(params, "soleus_r").max_isometric_force_N ==
        Approx(2 * find(table, "soleus_r").max_isometric_force_N));
  std::vector<MuscleParams> refused = table;
  CHECK_THROWS(apply_muscle_overrides(
      R"({"muscles": {"soleus": {"max_isometric_force_N": 100}, "vasti": {"tendon": "springy"}}})",
      "m.json", &refused));
  CHECK(find(refused, "soleus_l").max_isometric_force_N ==
        find(table, "soleus_l").max_isometric_force_N);
}

}  // namespace biodyn::muscles::muscle_set_test
