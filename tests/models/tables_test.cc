#include <fstream>
#include <sstream>

#include "biodyn/models/tables.h"
#include "biodyn/sim/errors.h"
#include "test_support.h"

using namespace biodyn::models;

TEST_CASE("de Leva's table is transcribed consistently", "[models][tables]") {
  const Tables& t = default_tables();
  for (const Sex sex : {Sex::kMale, Sex::kFemale}) {
    INFO(to_string(sex));
    const auto& up = t.de_leva_row("upper_trunk", sex);
    const auto& mid = t.de_leva_row("middle_trunk", sex);
    const auto& low = t.de_leva_row("lower_trunk", sex);
    const auto& trunk = t.de_leva_row("trunk", sex);
    // The three trunk parts add up to de Leva's whole trunk, in mass and in length.
    CHECK(up.mass_pct + mid.mass_pct + low.mass_pct == Approx(trunk.mass_pct).margin(0.005));
    CHECK(up.length_mm + mid.length_mm + low.length_mm == Approx(trunk.length_mm).margin(0.05));
    // All segments add up to the body (rounding in the published table: <= 0.02%).
    double sum = t.de_leva_row("head", sex).mass_pct + trunk.mass_pct;
    for (const char* s : {"upper_arm", "forearm", "hand", "thigh", "shank", "foot"}) {
      sum += 2 * t.de_leva_row(s, sex).mass_pct;
    }
    CHECK(sum == Approx(100.0).margin(0.02));
  }
  // references.md's excerpt of Table 4.
  CHECK(t.de_leva_row("thigh", Sex::kMale).mass_pct == 14.16);
  CHECK(t.de_leva_row("shank", Sex::kFemale).com_pct == 44.16);
  CHECK(t.de_leva_row("foot", Sex::kFemale).r_long_pct == 13.9);
  CHECK(de_leva_reference_height_m(Sex::kMale) == 1.741);
}

TEST_CASE("The compiled-in tables are the files in models/data", "[models][tables]") {
  const std::string src = biodyn::testing::source_dir();
  for (const char* name :
       {"de_leva_1996.csv", "body_proportions.csv", "joints.csv", "markers_26.csv"}) {
    std::ifstream in(src + "/models/data/" + name, std::ios::binary);
    REQUIRE(in);
    std::ostringstream s;
    s << in.rdbuf();
    INFO(name);
    CHECK(s.str() == std::string(embedded_data_file(name)));
    // Every table names its source in its first line.
    CHECK(s.str().rfind("# source: ", 0) == 0);
  }
}

TEST_CASE("Malformed tables are reported by file, line and column", "[models][tables]") {
  const std::string_view leva = embedded_data_file("de_leva_1996.csv");
  const std::string_view prop = embedded_data_file("body_proportions.csv");
  const std::string_view joints = embedded_data_file("joints.csv");
  const std::string_view markers = embedded_data_file("markers_26.csv");
  std::string bad_joints(joints);
  bad_joints += "knee_flexion,hinge,0,abc,600,paper,0.1,1.0\n";
  CHECK_THROWS_WITH(
      parse_tables(leva, prop, bad_joints, markers),
      Catch::StartsWith("joints.csv:") && Catch::Contains("max_deg") && Catch::Contains("'abc'"));
  std::string bad_leva(leva);
  bad_leva += "thigh,male,HJC,KJC,422.2,14.16\n";
  CHECK_THROWS_WITH(parse_tables(bad_leva, prop, joints, markers),
                    Catch::StartsWith("de_leva_1996.csv:") && Catch::Contains("10 fields"));
  CHECK_THROWS_WITH(parse_tables(leva, "name,value\n", joints, markers),
                    Catch::StartsWith("body_proportions.csv:1: header"));
}
