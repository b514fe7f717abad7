#include "biodyn/models/character.h"
#include "biodyn/models/mjcf.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/simulation.h"
#include "model_checks.h"
#include "test_support.h"

using namespace biodyn;

TEST_CASE("A mass override fixes the segment and the tables share the rest",
          "[models][overrides]") {
  models::CharacterSpec spec;
  const models::Character base = models::generate_character(spec);
  spec.overrides["thigh"].mass_kg = 10.0;  // both sides
  const models::Character c = models::generate_character(spec);
  CHECK(c.find("thigh_l")->mass_kg == Approx(10.0).epsilon(1e-12));
  CHECK(c.find("thigh_r")->mass_kg == Approx(10.0).epsilon(1e-12));
  CHECK(c.total_mass_kg() == Approx(80.0).epsilon(1e-12));
  // The others keep the tables' proportions among themselves, scaled to the remaining mass.
  const double remaining = 80.0 - 20.0;
  const double base_remaining = 80.0 - 2 * base.find("thigh_l")->mass_kg;
  for (const char* name : {"pelvis", "head", "shank_r", "hand_l"}) {
    CHECK(c.find(name)->mass_kg == Approx(base.find(name)->mass_kg * remaining / base_remaining));
  }
  // A side-specific override wins over the generic one.
  spec.overrides["thigh_l"].mass_kg = 12.0;
  const models::Character asym = models::generate_character(spec);
  CHECK(asym.find("thigh_l")->mass_kg == Approx(12.0));
  CHECK(asym.find("thigh_r")->mass_kg == Approx(10.0));
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "A length override changes the segment and the stature", "[models][overrides]") {
  models::CharacterSpec spec;
  const models::Character base = models::generate_character(spec);
  spec.overrides["shank"].length_m = base.find("shank_l")->length_m + 0.05;
  const models::Character c = models::generate_character(spec);
  CHECK(c.find("shank_r")->length_m == Approx(base.find("shank_r")->length_m + 0.05));
  CHECK(c.standing_height_m == Approx(base.standing_height_m + 0.05));
  sim::Simulation sim(testing::load_inline(models::to_mjcf(c)));
  const auto [lo, hi] = testing::geom_z_span(sim.model(), sim.data());
  CHECK(std::abs(lo) < 2e-3);
  CHECK(hi - lo == Approx(1.85).epsilon(1e-6));
  // Gait trunk: the whole spine-to-vertex chain scales.
  models::CharacterSpec gait;
  gait.detail = models::Detail::kGait;
  gait.overrides["trunk"].length_m = 0.9;
  CHECK(models::generate_character(gait).find("trunk")->length_m == Approx(0.9));
}

TEST_CASE("Bad overrides are rejected with the segment and field named", "[models][overrides]") {
  models::CharacterSpec spec;
  spec.overrides["femur"].mass_kg = 9.0;
  CHECK_THROWS_WITH(models::generate_character(spec),
                    Catch::Contains("femur") && Catch::Contains("thigh_l"));
  spec.overrides.clear();
  spec.detail = models::Detail::kGait;
  spec.overrides["hand"].mass_kg = 0.5;  // no hands in the gait model
  CHECK_THROWS_WITH(models::generate_character(spec), Catch::Contains("hand"));
  spec.overrides.clear();
  spec.overrides["trunk"].mass_kg = 80.0;  // leaves nothing for the others
  CHECK_THROWS_WITH(models::generate_character(spec), Catch::Contains("80 kg"));
  spec.overrides["trunk"].mass_kg = -3.0;
  CHECK_THROWS_WITH(models::generate_character(spec), Catch::Contains("trunk.mass_kg"));
}

TEST_CASE("Override JSON is parsed strictly", "[models][overrides]") {
  const auto o = models::parse_overrides(
      R"({"segments": {"thigh": {"mass_kg": 9.5, "length_m": 0.45}}})", "seg.json");
  REQUIRE(o.count("thigh") == 1);
  CHECK(*o.at("thigh").mass_kg == 9.5);
  CHECK(*o.at("thigh").length_m == 0.45);
  CHECK_THROWS_WITH(models::parse_overrides("{\"segments\": {", "seg.json"),
                    Catch::StartsWith("seg.json: malformed JSON"));
  CHECK_THROWS_WITH(
      models::parse_overrides(R"({"segments": {"thigh": {"mass_kg": 1e400}}})", "seg.json"),
      Catch::StartsWith("seg.json: malformed JSON") && Catch::Contains("1e400"));
  CHECK_THROWS_WITH(models::parse_overrides(R"({"segments": {"thigh": {"mass": 9}}})", "seg.json"),
                    Catch::Contains("segments.thigh") && Catch::Contains("'mass'"));
  CHECK_THROWS_WITH(
      models::parse_overrides(R"({"segments": {"thigh": {"mass_kg": "9"}}})", "seg.json"),
      Catch::Contains("segments.thigh.mass_kg") && Catch::Contains("\"9\""));
  CHECK_THROWS_WITH(models::parse_overrides(R"([1, 2])", "seg.json"), Catch::Contains("seg.json"));
  CHECK_THROWS_WITH(models::parse_overrides(R"({"segments": {}, "extra": 1})", "seg.json"),
                    Catch::Contains("extra"));
}
