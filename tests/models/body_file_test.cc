// Body files (issue 24): the body an output was computed on, written and read back exactly, and
// told apart from another body by its geometry only.
#include "biodyn/models/body_file.h"

#include "biodyn/models/marker_set.h"
#include "biodyn/sim/errors.h"
#include "test_support.h"

using namespace biodyn;

namespace {

/// A scaled body like the one mocap ik writes: odd height, per-segment lengths, placed markers.
models::CharacterSpec scaled_body() {
  models::CharacterSpec spec;
  spec.height_m = 1.8721423456789012;
  spec.mass_kg = 72.5;
  spec.sex = models::Sex::kFemale;
  spec.overrides["thigh_l"].length_m = 0.4461234567890123;
  spec.overrides["pelvis"].width_m = 0.1987654321;
  spec.markers = models::builtin_marker_set("opensim_walking5").markers;
  spec.markers[0].along += 0.0123456789;
  return spec;
}

}  // namespace

TEST_CASE("A body file reads back as the same body, compact or indented", "[models][body]") {
  const models::CharacterSpec spec = scaled_body();
  for (bool compact : {true, false}) {
    const std::string text = models::format_body_json(spec, compact);
    CHECK((text.find('\n') == std::string::npos) == compact);
    const models::CharacterSpec back = models::parse_body_json(text, "body.json");
    CHECK(back.height_m == spec.height_m);  // exact: 17 digits
    CHECK(back.mass_kg == spec.mass_kg);
    CHECK(back.sex == spec.sex);
    CHECK(back.detail == spec.detail);
    CHECK(*back.overrides.at("thigh_l").length_m == *spec.overrides.at("thigh_l").length_m);
    CHECK(*back.overrides.at("pelvis").width_m == *spec.overrides.at("pelvis").width_m);
    REQUIRE(back.markers.size() == spec.markers.size());
    CHECK(back.markers[0].along == spec.markers[0].along);
    CHECK(models::geometry_difference(spec, back).empty());
  }
}

TEST_CASE("Two bodies differ by geometry, not by mass or markers", "[models][body]") {
  const models::CharacterSpec a = scaled_body();
  models::CharacterSpec b = a;
  b.mass_kg = 95.0;
  b.markers.clear();
  CHECK(models::geometry_difference(a, b).empty());
  b = a;
  b.height_m = 1.8;
  CHECK(models::geometry_difference(a, b).find("height") != std::string::npos);
  b = a;
  b.overrides.erase("thigh_l");
  CHECK(models::geometry_difference(a, b).find("thigh_l") != std::string::npos);
  b = a;
  b.sex = models::Sex::kMale;
  CHECK_FALSE(models::geometry_difference(a, b).empty());
}

TEST_CASE("A bad body file is refused naming the file and the field", "[models][body]") {
  auto message = [](const std::string& text) {
    try {
      models::parse_body_json(text, "b.json");
    } catch (const sim::InvalidArgument& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  CHECK(message("{").find("b.json") != std::string::npos);
  CHECK(message(R"({"height_m": "tall", "mass_kg": 80, "sex": "male", "detail": "full"})")
            .find("height_m") != std::string::npos);
  CHECK(message(R"({"height_m": 1.8, "mass_kg": 80, "sex": "other", "detail": "full"})")
            .find("sex") != std::string::npos);
  CHECK(message(R"({"height_m": 1.8, "mass_kg": 80, "sex": "male", "detail": "full", "x": 1})")
            .find("x") != std::string::npos);
}
