// biodyn evaluate's core (scenarios/evaluate.h): bodies.json is checked field by field; a motion
// on bodies of growing mass under the fixed tau_max rule needs growing shares of tau_max; the
// same results on 1 and 2 threads.
#include <catch2/catch.hpp>
#include <cmath>
#include <filesystem>

#include "biodyn/mocap_io/motion_csv.h"
#include "biodyn/models/mjcf.h"
#include "biodyn/scenarios/evaluate.h"
#include "biodyn/scenarios/motion_recorder.h"
#include "biodyn/scenarios/walk.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/file_io.h"
#include "biodyn/sim/model.h"
#include "recorded_walk.h"
#include "test_support.h"

using namespace biodyn;

TEST_CASE("bodies.json: each bad field is named with its body", "[scenarios][evaluate]") {
  const auto fails_with = [](const std::string& text, const std::string& expected) {
    try {
      scenarios::parse_bodies(text, "b.json");
      FAIL("accepted " << text);
    } catch (const sim::InvalidArgument& e) {
      INFO(e.what());
      CHECK(std::string(e.what()).find(expected) != std::string::npos);
    }
  };
  fails_with("not json", "b.json: not JSON");
  fails_with("{\"bodies\": []}", "at least one body");
  fails_with("{\"bodies\": [{\"mass_kg\": \"heavy\"}]}", "body 1: mass_kg must be a number");
  fails_with("{\"bodies\": [{\"sex\": \"x\"}]}", "body 1: sex must be male or female");
  fails_with("{\"bodies\": [{\"name\": \"a\"}, {\"name\": \"a\"}]}", "body 2: name 'a' twice");
  fails_with("{\"bodies\": [{\"tau_max\": \"strong\"}]}", "tau_max must be scaled or fixed");
  fails_with("{\"bodies\": [{\"profile\": \"round\"}]}", "profile must be standard");
  fails_with("{\"bodies\": [{\"name\": \"x\", \"mass_kg\": 2}]}", "body 1 ('x'): mass");
  const std::vector<scenarios::EvaluationBody> ok = scenarios::parse_bodies(
      R"({"bodies": [{"name": "h", "height_m": 1.6, "mass_kg": 120, "sex": "female",
          "profile": "heavy_trunk_thighs", "tau_max": "fixed"}]})",
      "b.json");
  REQUIRE(ok.size() == 1);
  CHECK(ok[0].spec.height_m == 1.6);
  CHECK(ok[0].spec.sex == models::Sex::kFemale);
  CHECK(ok[0].tau_rule == scenarios::TauMaxRule::kFixed);
}

TEST_CASE("evaluate's verdict: saturation, a fall, or a tracking that leans on a stop",
          "[scenarios][evaluate]") {
  scenarios::BodyEvaluation e;
  e.tracked = true;
  e.kept_up = true;
  e.joint_load_tracked.over_longest_s = 0.04;  // impacts: under 50 ms
  e.joint_load_tracked.over_longest_dof = "ankle_dorsiflexion_r";
  scenarios::judge(&e);
  CHECK(e.feasible);
  CHECK(e.verdict == "can do it");
  e.joint_load_tracked.over_longest_s = 0.05;
  scenarios::judge(&e);
  CHECK_FALSE(e.feasible);
  CHECK(e.verdict ==
        "cannot do it: the tracking keeps up only with its joints over tau_max (motor + joint "
        "stop) for 0.05 s (last ankle_dorsiflexion_r)");
  e.first_saturating_joint = "hip_r";
  e.kept_up = false;
  e.fell_at_s = 2.5;
  scenarios::judge(&e);
  CHECK_FALSE(e.feasible);
  CHECK(e.verdict.find("hip_r exceeds tau_max first; the tracking falls at 2.5") !=
        std::string::npos);
  CHECK(e.verdict.find("keeps up only") == std::string::npos);  // it did not keep up
}

TEST_CASE_METHOD(
    biodyn::testing::SimulationTest,
    "evaluate: under fixed tau_max a heavier body needs more of it, on any thread count",
    "[scenarios][evaluate]") {
  // The body's own walk (1.8 m, 80 kg), recorded at 100 Hz.
  const std::string dir = biodyn::testing::binary_dir() + "/evaluate_test";
  std::filesystem::create_directories(dir);
  biodyn::testing::record_walk_csv(models::CharacterSpec{}, 1.0, 3.0, dir + "/walk.csv");

  const std::vector<scenarios::EvaluationBody> bodies = scenarios::parse_bodies(
      R"({"bodies": [{"name": "m80", "mass_kg": 80, "tau_max": "fixed"},
                     {"name": "m150", "mass_kg": 150, "tau_max": "fixed"}]})",
      "bodies");
  scenarios::EvaluateOptions o;
  o.samcon.parents = 4;
  o.samcon.children = 4;
  const std::vector<scenarios::BodyEvaluation> one = scenarios::evaluate_motion(
      dir + "/walk.csv", bodies,
      [&] {
        auto x = o;
        x.threads = 1;
        return x;
      }(),
      dir);
  const std::vector<scenarios::BodyEvaluation> two = scenarios::evaluate_motion(
      dir + "/walk.csv", bodies,
      [&] {
        auto x = o;
        x.threads = 2;
        return x;
      }(),
      dir);
  REQUIRE(one.size() == 2);
  for (const scenarios::BodyEvaluation& e : one) {
    INFO(e.body.name << ": " << e.verdict << "; tracking joint RMS " << e.joint_rms_deg
                     << " deg, fell at " << e.fell_at_s << " s");
    REQUIRE(e.error.empty());
    CHECK(e.tracked);
  }
  const auto peak = [](const scenarios::BodyEvaluation& e, const std::string& joint) {
    for (const scenarios::JointEvaluation& j : e.joints)
      if (j.joint == joint) return j.peak_ratio;
    return -1.0;
  };
  // Same motion, same tau_max, 150/80 of the mass: the stance joints need ~1.9x the share.
  for (const char* joint : {"hip_l", "knee_l", "ankle_l", "hip_r", "knee_r", "ankle_r"}) {
    INFO(joint << ": " << peak(one[0], joint) << " -> " << peak(one[1], joint));
    CHECK(peak(one[1], joint) > 1.5 * peak(one[0], joint));
  }
  CHECK(one[0].kept_up);  // its own body keeps up with its own walk
  // Not asserted here: that 150 kg tracks worse. The paper's tau_max leave an 80 kg walk 2-3x
  // reserve (next test case: 4x).
  // Deterministic whatever the thread count.
  for (size_t b = 0; b < 2; ++b) {
    CHECK(one[b].torque_Nm == two[b].torque_Nm);
    CHECK(one[b].joint_rms_deg == two[b].joint_rms_deg);
    CHECK(one[b].fell_at_s == two[b].fell_at_s);
  }
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "evaluate: under fixed tau_max, 4x the mass tracks worse, leaning on the stops",
                 "[scenarios][evaluate]") {
  // A 50 kg body's walk at 1.3 m/s, 4 s; the same motion on 50 kg and 200 kg with 50 kg's
  // tau_max (the paper's limits leave a walk 2-3x reserve: 4x is past it).
  const std::string dir = biodyn::testing::binary_dir() + "/evaluate_mass_test";
  std::filesystem::create_directories(dir);
  models::CharacterSpec light;
  light.mass_kg = 50;
  biodyn::testing::record_walk_csv(light, 1.3, 4.0, dir + "/walk.csv");
  const std::vector<scenarios::EvaluationBody> bodies = scenarios::parse_bodies(
      R"({"bodies": [{"name": "m50", "mass_kg": 50, "tau_max": "fixed"},
                     {"name": "m200", "mass_kg": 200, "tau_max": "fixed"}]})",
      "bodies");
  scenarios::EvaluateOptions o;
  o.samcon.parents = 4;
  o.samcon.children = 4;
  const std::vector<scenarios::BodyEvaluation> e =
      scenarios::evaluate_motion(dir + "/walk.csv", bodies, o, dir);
  REQUIRE(e.size() == 2);
  const scenarios::BodyEvaluation &own = e[0], &heavy = e[1];
  for (const scenarios::BodyEvaluation& b : e) {
    INFO(b.body.name << ": " << b.verdict << "; joint RMS " << b.joint_rms_deg << " deg, root "
                     << b.root_max_m << " m, fell at " << b.fell_at_s << " s; motor + stop "
                     << b.joint_load_tracked.load_peak_ratio << " x tau_max ("
                     << b.joint_load_tracked.load_peak_dof << ")");
    REQUIRE(b.error.empty());
    REQUIRE(b.tracked);
  }
  CHECK(own.kept_up);
  CHECK(own.feasible);
  CHECK_FALSE(heavy.feasible);
  // Seeds 1-3 (4x4 search): 200 kg fell at 3.9 s and 2.9 s, or kept up with 5.98 deg joint RMS,
  // against 2.44/2.01/1.79 deg for 50 kg; its joints over tau_max (motor + range stop) for
  // 0.32-0.61 s against 0.006-0.014 s (SAMCON charges what lasts over 10 ms).
  INFO("50 kg: " << own.joint_rms_deg << " deg, over tau_max " << own.joint_load_tracked.over_s
                 << " s; 200 kg: " << heavy.joint_rms_deg << " deg, fell at " << heavy.fell_at_s
                 << " s, over tau_max " << heavy.joint_load_tracked.over_s << " s");
  CHECK((!heavy.kept_up || heavy.joint_rms_deg > 2 * own.joint_rms_deg));
  CHECK(heavy.joint_load_tracked.over_s > 5 * own.joint_load_tracked.over_s);
  CHECK(heavy.joint_load_tracked.load_peak_ratio > 1.5 * own.joint_load_tracked.load_peak_ratio);
  CHECK_FALSE(heavy.joint_load_tracked.load_peak_dof.empty());
}
