// `biodyn gait` and `biodyn walk-search` as a user runs them: a simulated walk's gait figures
// and plot beside normative walking and a captured walk (walking5 through marker IK: its hip and
// knee curves must correlate with the normative ones, a check of the table and of the analysis
// on data neither was made from); the search's output walks; bad input refused.
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>

#include "cli_runner.h"
#include "image_check.h"
#include "test_support.h"

namespace biodyn::testing::cmd_gait_test {

namespace fs = std::filesystem;
using nlohmann::json;

/// Pixels of the plot's simulated walk (its first colour, #b2182b) in `png`.
int walk_curve_pixels(const std::string& png) {
  return count_pixels(
      png, [](int r, int g, int b) { return r > 150 && r < 200 && g < 50 && b > 20 && b < 70; });
}

TEST_CASE("biodyn gait: a simulated walk beside normative walking and walking5's IK",
          "[apps][cli][gait]") {
  const fs::path dir = fresh_dir("gait_cli_test", "walk");
  const std::string c3d = source_dir() + "/../shared/data/mocap/c3d/opensim_walking5.c3d";
  const CliRun ik = run_biodyn("mocap ik --c3d '" + c3d + "' -o w5.csv", dir);
  INFO(ik.out << ik.err);
  REQUIRE(ik.exit_code == 0);
  const CliRun r = run_biodyn("gait --duration 12 --reference w5.csv -o g", dir);
  INFO(r.out << r.err);
  REQUIRE(r.exit_code == 0);
  CHECK(r.out.find("knee swing peak") != std::string::npos);
  const json j = json::parse(slurp(dir / "g" / "gait.json"));
  REQUIRE(j["walks"].size() == 2);
  const json& walk = j["walks"][0];
  CHECK(walk["events"] == "ground force");
  CHECK(walk["cycles"].get<int>() >= 6);
  CHECK(walk["figures"].size() == 13);
  CHECK(walk["mean_cycle_deg"]["knee_flexion"].size() == 101);
  const json& w5 = j["walks"][1];
  CHECK(w5["reference"] == true);
  CHECK(w5["cycles"].get<int>() >= 1);
  for (const json& f : w5["figures"]) {
    if (f["name"] == "hip curve correlation" || f["name"] == "knee curve correlation") {
      INFO(f["name"]);
      CHECK(f["value"].get<double>() >= 0.95);
    }
  }
  CHECK(std::count(
            std::istreambuf_iterator<char>(std::ifstream(dir / "g" / "gait_cycle.csv").rdbuf()),
            std::istreambuf_iterator<char>(), '\n') == 102);
  CHECK(walk_curve_pixels((dir / "g" / "gait.png").string()) > 500);

  // A walk written by biodyn walk --motion-out: its ground forces give the events.
  const CliRun w = run_biodyn("walk --duration 9 --motion-out m/walk.csv", dir);
  REQUIRE(w.exit_code == 0);
  const CliRun m = run_biodyn("gait --motion m/walk.csv --from 3 -o g2", dir);
  INFO(m.out << m.err);
  REQUIRE(m.exit_code == 0);
  CHECK(json::parse(slurp(dir / "g2" / "gait.json"))["walks"][0]["events"] == "ground force");
}

TEST_CASE("biodyn gait refuses a missing motion and a motion without a step, writing nothing",
          "[apps][cli][gait]") {
  const fs::path dir = fresh_dir("gait_cli_test", "bad");
  CliRun r = run_biodyn("gait --motion missing.csv -o g", dir);
  CHECK(r.exit_code == 2);
  CHECK(r.err.find("missing.csv") != std::string::npos);
  CHECK_FALSE(fs::exists(dir / "g"));
  // The first second of a walk: the character has not taken a step yet.
  REQUIRE(run_biodyn("walk --duration 1 --motion-out stand.csv", dir).exit_code == 0);
  r = run_biodyn("gait --motion stand.csv --from 0 -o g", dir);
  CHECK(r.exit_code == 2);
  CHECK(r.err.find("no complete gait cycle") != std::string::npos);
  CHECK_FALSE(fs::exists(dir / "g"));
}

TEST_CASE("biodyn walk-search: the same search on 1 and 2 threads, and its result walks",
          "[apps][cli][gait][slow]") {
  const fs::path dir = fresh_dir("gait_cli_test", "search");
  const std::string search = "walk-search --generations 1 --population 4 --duration 10 --seed 7 ";
  const CliRun one = run_biodyn(search + "--threads 1 -o s1", dir);
  INFO(one.out << one.err);
  REQUIRE(one.exit_code == 0);
  const CliRun two = run_biodyn(search + "--threads 2 -o s2", dir);
  REQUIRE(two.exit_code == 0);
  CHECK(slurp(dir / "s1" / "best.json") == slurp(dir / "s2" / "best.json"));
  CHECK(slurp(dir / "s1" / "search.csv") == slurp(dir / "s2" / "search.csv"));
  const json report = json::parse(slurp(dir / "s1" / "best_report.json"));
  CHECK(report["cases"].size() == 6);
  const CliRun walk = run_biodyn("walk --duration 4 --params s1/best.json", dir);
  INFO(walk.out << walk.err);
  CHECK(walk.exit_code <= 1);  // it ran (a candidate of one generation may fall)
  CHECK(walk.err.find("error") == std::string::npos);
}

TEST_CASE(
    "biodyn walk-search: push cases, push bodies and spread out of range are refused, naming the "
    "option",
    "[apps][cli][gait]") {
  const fs::path dir = fresh_dir("gait_cli_test", "search_bad");
  CliRun r = run_biodyn("walk-search --pushes 12 -o s", dir);
  CHECK(r.exit_code == 2);
  CHECK(r.err.find("pushes") != std::string::npos);
  CHECK(r.err.find("12") != std::string::npos);
  r = run_biodyn("walk-search --spread 0 -o s", dir);
  CHECK(r.exit_code == 2);
  CHECK(r.err.find("spread") != std::string::npos);
  r = run_biodyn("walk-search --pushes 8 --push-bodies 0 -o s", dir);
  CHECK(r.exit_code == 2);
  CHECK(r.err.find("push bodies") != std::string::npos);
  CHECK_FALSE(fs::exists(dir / "s" / "best.json"));
}

}  // namespace biodyn::testing::cmd_gait_test
