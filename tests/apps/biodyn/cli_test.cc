// The `biodyn` executable as a user runs it: outputs, exit codes, one-line errors, and nothing
// written on bad input.
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "cli_runner.h"
#include "test_support.h"

namespace fs = std::filesystem;

namespace {

using Run = biodyn::testing::CliRun;
using biodyn::testing::run_biodyn;
using biodyn::testing::slurp;

fs::path fresh_dir(const std::string& name) { return biodyn::testing::fresh_dir("cli_test", name); }

}  // namespace

TEST_CASE("biodyn model writes the MJCF and a summary of every segment", "[apps][cli]") {
  const fs::path dir = fresh_dir("model");
  const Run r = run_biodyn(
      "model --height 1.80 --mass 80 --sex male --detail full -o character.xml "
      "--summary summary.json",
      dir);
  INFO(r.err);
  REQUIRE(r.exit_code == 0);
  CHECK(fs::exists(dir / "character.xml"));
  const auto j = nlohmann::json::parse(slurp(dir / "summary.json"));
  CHECK(j["total_mass_kg"].get<double>() == Approx(80.0).margin(1e-3));
  CHECK(j["segments"].size() == 21);
  for (const auto& s : j["segments"]) {
    CHECK(s.contains("mass_kg"));
    CHECK(s.contains("length_m"));
    CHECK(s["com_m"].size() == 3);
    CHECK(s["inertia_kg_m2"].contains("xx"));
  }
  // The file compiles in stock MuJoCo too.
  CHECK(std::system(("mujoco-compile '" + (dir / "character.xml").string() + "' '" +
                     (dir / "c.mjb").string() + "' > /dev/null 2>&1")
                        .c_str()) == 0);
}

TEST_CASE("Bad values exit non-zero with a one-line message and write nothing", "[apps][cli]") {
  const fs::path dir = fresh_dir("bad");
  std::ofstream(dir / "unknown.json") << R"({"segments": {"femur": {"mass_kg": 9}}})";
  std::ofstream(dir / "malformed.json") << R"({"segments": {"thigh": )";
  struct Case {
    const char* args;
    const char* must_mention;  // the field
    const char* value;         // and the value
  };
  const Case cases[] = {
      {"--height -1.7", "height", "-1.7"},
      {"--height 7", "height", "7"},
      {"--mass 0", "mass", "0"},
      {"--mass 9000", "mass", "9000"},
      {"--sex alien", "sex", "alien"},
      {"--detail medium", "detail", "medium"},
      {"--overrides unknown.json", "unknown.json", "femur"},
      {"--overrides malformed.json", "malformed.json", "malformed JSON"},
      {"--overrides missing.json", "missing.json", "cannot open"},
  };
  for (const Case& c : cases) {
    INFO(c.args);
    const Run r =
        run_biodyn(std::string("model ") + c.args + " -o out.xml --summary out.json", dir);
    INFO(r.err);
    CHECK(r.exit_code == 2);
    CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);
    CHECK_THAT(r.err, Catch::Contains(c.must_mention) && Catch::Contains(c.value));
    CHECK(!fs::exists(dir / "out.xml"));
    CHECK(!fs::exists(dir / "out.json"));
  }
  for (const char* args : {"model --height abc -o out.xml", "drop --duration -1 -o out.xml"}) {
    INFO(args);
    const Run r = run_biodyn(args, dir);
    CHECK(r.exit_code == 2);
    CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);
    CHECK_THAT(r.err,
               Catch::Contains(std::string(args).find("abc") != std::string::npos ? "abc" : "-1"));
    CHECK(!fs::exists(dir / "out.xml"));
  }
}

TEST_CASE("biodyn drop runs the main job and reports it", "[apps][cli]") {
  const fs::path dir = fresh_dir("drop");
  const Run r = run_biodyn("drop --duration 2 -o out/c.xml --json out/drop.json", dir);
  INFO(r.err);
  REQUIRE(r.exit_code == 0);
  CHECK_THAT(r.out, Catch::Contains("MuJoCo warnings: none"));
  const auto j = nlohmann::json::parse(slurp(dir / "out/drop.json"));
  CHECK(j["mujoco_warnings"].get<int>() == 0);
  CHECK(j["collapse_time_s"].get<double>() > 0);
  CHECK(j["total_mass_kg"].get<double>() == Approx(80).margin(1e-3));
  CHECK(!fs::exists(dir / "out/c.xml.tmp-biodyn"));
}

TEST_CASE("Outputs to devices and through symlinks leave them in place", "[apps][cli]") {
  const fs::path dir = fresh_dir("special");
  fs::create_symlink("real.xml", dir / "link.xml");
  const auto stdout_type = fs::symlink_status("/dev/stdout").type();
  REQUIRE(run_biodyn("model -o link.xml --summary /dev/stdout", dir).exit_code == 0);
  CHECK(fs::is_symlink(dir / "link.xml"));
  CHECK(fs::file_size(dir / "real.xml") > 1000);
  CHECK_THAT(slurp(dir / "stdout.txt"), Catch::Contains("\"total_mass_kg\""));
  CHECK(fs::symlink_status("/dev/stdout").type() == stdout_type);
}

TEST_CASE("biodyn pose, stand-push and bench write the fields the issue names",
          "[apps][cli][pose]") {
  const fs::path dir = fresh_dir("pose");
  {
    const Run r = run_biodyn(
        "pose --scenario squat --reaction-time 0.1 --json squat.json --csv squat.csv", dir);
    INFO(r.err);
    REQUIRE(r.exit_code == 0);
    CHECK_THAT(r.out, Catch::Contains("weld honest") && Catch::Contains("stayed up"));
    const auto j = nlohmann::json::parse(slurp(dir / "squat.json"));
    CHECK(j["fallen"] == false);
    CHECK(j["weld"] == "honest");
    CHECK(j["weld_tension_steps"] == 0);
    CHECK(j["max_orientation_error_deg"].get<double>() < 3);
    CHECK(j["max_torque_ratio"].get<double>() <= 1.0 + 1e-9);
    CHECK(j["realtime_factor"].get<double>() > 0);
    CHECK(j["targets"].size() == 3);
    // The per-step trace logs the weld force; every line has the header's columns.
    std::istringstream csv(slurp(dir / "squat.csv"));
    std::string header, line;
    std::getline(csv, header);
    CHECK_THAT(header, Catch::Contains("weld_fz_l") && Catch::Contains("tension_excess_r"));
    int lines = 0;
    while (std::getline(csv, line)) {
      ++lines;
      if (std::count(line.begin(), line.end(), ',') !=
          std::count(header.begin(), header.end(), ',')) {
        FAIL("line " << lines << " has a different number of columns: " << line);
      }
    }
    CHECK(lines == j["steps"].get<int>());
  }
  {
    // Every output says which weld mode produced it.
    const Run r = run_biodyn("pose --duration 2 --weld glue --controller pd --json glue.json", dir);
    INFO(r.err);
    REQUIRE(r.exit_code == 0);
    CHECK_THAT(r.out, Catch::Contains("weld glue") && Catch::Contains("pd controller"));
    const auto j = nlohmann::json::parse(slurp(dir / "glue.json"));
    CHECK(j["weld"] == "glue");
    CHECK(j["controller"] == "pd");
  }
  {
    const Run r = run_biodyn(
        "stand-push --directions 0 --welds honest --resolution 150 --max-force 300 --json "
        "push.json",
        dir);
    INFO(r.err);
    REQUIRE(r.exit_code == 0);
    const auto j = nlohmann::json::parse(slurp(dir / "push.json"));
    REQUIRE(j["results"].size() == 1);
    CHECK(j["results"][0]["max_survived_N"].get<double>() == 150);
    CHECK(j["results"][0]["first_failure_N"].get<double>() == 300);
    CHECK(j["results"][0]["weld"] == "honest");
  }
  {
    const Run r = run_biodyn("bench --detail gait --duration 0.5 --json bench.json", dir);
    INFO(r.err);
    REQUIRE(r.exit_code == 0);
    const auto j = nlohmann::json::parse(slurp(dir / "bench.json"));
    CHECK(j["bare_steps_per_second"].get<double>() > 0);
    CHECK(j["controlled_steps_per_second"].get<double>() > 0);
    CHECK(j["ratio"].get<double>() == Approx(j["controlled_steps_per_second"].get<double>() /
                                             j["bare_steps_per_second"].get<double>()));
  }
  {
    // Issue 25: both speed figures from one benchmark command.
    const Run r = run_biodyn("bench --muscles --duration 1 --repeats 1 --json bm.json", dir);
    INFO(r.out << r.err);
    REQUIRE(r.exit_code == 0);
    CHECK(r.out.find("speed ratio:") != std::string::npos);
    CHECK(r.out.find("static optimisation:") != std::string::npos);
    const auto j = nlohmann::json::parse(slurp(dir / "bm.json"));
    CHECK(j["speed_ratio"].get<double>() > 0);
    CHECK(j["static_optimization_frames"].get<int>() == 500);  // every 2 ms step of 1 s
    CHECK(j["static_optimization_frames_per_s"].get<double>() > 0);
  }
}

TEST_CASE("Bad pose options exit 2 with one line naming the value, nothing written",
          "[apps][cli][pose]") {
  const fs::path dir = fresh_dir("pose_bad");
  std::ofstream(dir / "bad_params.json") << R"({"joints": {"knee": {"reaction_time_s": -1}}})";
  const std::pair<const char*, const char*> cases[] = {
      {"pose --scenario cartwheel", "cartwheel"},
      {"pose --controller fuzzy", "fuzzy"},
      {"pose --weld tape", "tape"},
      {"pose --push 100,0.2", "100,0.2"},
      {"pose --params bad_params.json", "bad_params.json"},
      {"pose --reaction-time 5", "5"},
      {"stand-push --directions north", "north"},
      {"stand-push --welds superglue", "superglue"},
      {"stand-push --resolution 0", "resolution"},
      {"bench --weld tape", "tape"},
      {"walk --timestep 0.01", "--timestep"},
      {"push --timestep 0 --force 100", "--timestep"},
  };
  for (const auto& [args, value] : cases) {
    INFO(args);
    const Run r = run_biodyn(std::string(args) + " --json out.json", dir);
    INFO(r.err);
    CHECK(r.exit_code == 2);
    CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);
    CHECK_THAT(r.err, Catch::Contains(value));
    CHECK(!fs::exists(dir / "out.json"));
  }
}

TEST_CASE("biodyn walk writes the walk JSON and says what the weld assumes", "[apps][cli][walk]") {
  const fs::path dir = fresh_dir("walk");
  const Run r = run_biodyn("walk --duration 8 --weld glue --json walk.json --csv trace.csv", dir);
  INFO(r.out << r.err);
  REQUIRE(r.exit_code == 0);
  const auto j = nlohmann::json::parse(slurp(dir / "walk.json"));
  for (const char* key : {"fallen", "time_fallen", "distance", "mean_speed", "steps",
                          "step_lengths", "cadence", "joint_ranges_deg", "max_foot_slip", "weld",
                          "weld_tension_steps", "realtime_factor", "base_polygon_steps"})
    CHECK(j.contains(key));
  CHECK(j["weld"] == "glue");
  CHECK(j["step_lengths"].size() == j["steps"].get<std::size_t>());
  // The result depends on the glue weld: the output says so.
  CHECK(r.out.find("welded to the floor") != std::string::npos);
  CHECK(j["weld_assumption"].get<std::string>().find("welded to the floor") != std::string::npos);
  CHECK(fs::exists(dir / "trace.csv"));
  CHECK(j["inputs"]["timestep_s"] == 0.002);
}

TEST_CASE("biodyn walk --controller velocity walks on the velocity-based controllers",
          "[apps][cli][walk]") {
  const fs::path dir = fresh_dir("walk_velocity");
  const Run r = run_biodyn("walk --controller velocity --duration 1.5 --json w.json", dir);
  INFO(r.out << r.err);
  REQUIRE(r.exit_code == 0);
  CHECK(r.out.find("controller velocity") != std::string::npos);
  const auto j = nlohmann::json::parse(slurp(dir / "w.json"));
  CHECK(j["inputs"]["controller"] == "velocity");
  CHECK(j["max_root_force"] == 0.0);
  // The first step is taken (the walker has struck once) on the whole-body solve's torques.
  CHECK(j["steps"].get<int>() >= 1);
  const Run bad = run_biodyn("walk --controller pd --duration 1", dir);
  CHECK(bad.exit_code == 2);
  CHECK(bad.err.find("--controller: expected torque or velocity, got 'pd'") != std::string::npos);
}

TEST_CASE("biodyn walk --timestep steps the model at that timestep", "[apps][cli][walk]") {
  const fs::path dir = fresh_dir("walk_timestep");
  const Run r =
      run_biodyn("walk --duration 1.5 --timestep 0.003 --json w.json --csv trace.csv", dir);
  INFO(r.out << r.err);
  REQUIRE(r.exit_code == 0);
  CHECK(r.out.find("timestep 3 ms") != std::string::npos);
  CHECK(nlohmann::json::parse(slurp(dir / "w.json"))["inputs"]["timestep_s"] == 0.003);
  // One trace line per physics step after the header: 1.5 s / 3 ms = 500.
  const std::string trace = slurp(dir / "trace.csv");
  const auto lines = std::count(trace.begin(), trace.end(), '\n');
  CHECK(lines - 1 == Approx(500).margin(1));
  // The trace ends with each foot's origin (the ankle), world: at the start both stand on the
  // floor, the left foot left of the right one (the character faces +x).
  std::istringstream csv(trace);
  std::string header, first;
  std::getline(csv, header);
  std::getline(csv, first);
  REQUIRE_THAT(header, Catch::EndsWith(",foot_l_x,foot_l_y,foot_l_z,foot_r_x,foot_r_y,foot_r_z"));
  std::vector<double> row;
  std::istringstream cells(first);
  for (std::string cell; std::getline(cells, cell, ',');) row.push_back(std::stod(cell));
  REQUIRE(row.size() ==
          static_cast<std::size_t>(std::count(header.begin(), header.end(), ',') + 1));
  const double* feet = row.data() + row.size() - 6;
  CHECK(feet[1] - feet[4] > 0.1);                  // left of right, by the hips' spacing
  CHECK(feet[2] == Approx(feet[5]).margin(1e-3));  // both ankles at one height
  CHECK((feet[2] > 0.03 && feet[2] < 0.15));       // an ankle's height above the floor
}

TEST_CASE("biodyn walk --steps reports the stepping stones, a bad length is refused",
          "[apps][cli][walk][stones]") {
  const fs::path dir = fresh_dir("walk_stones");
  const Run r = run_biodyn(
      "walk --duration 9 --speed 0.8 --steps 0.5,0.3 --steps-start 4 --json s.json", dir);
  INFO(r.out << r.err);
  REQUIRE(r.exit_code == 0);
  const auto j = nlohmann::json::parse(slurp(dir / "s.json"));
  REQUIRE(j.contains("stones"));
  CHECK(j["stones"]["targets"].size() == 2);
  CHECK(j["stones"]["lengths"].size() == 2);
  CHECK(j["stones"]["complete"] == true);
  CHECK(j["stones"]["start_s"].get<double>() >= 4.0);
  CHECK(r.out.find("stepping stones") != std::string::npos);
  const Run bad = run_biodyn("walk --duration 9 --steps 0.5,x --json b.json", dir);
  CHECK(bad.exit_code == 2);
  CHECK(bad.err.find("--steps") != std::string::npos);
  CHECK_FALSE(fs::exists(dir / "b.json"));
  // Stones in 2D: one offset per length; alone, or of another count, refused.
  const Run offsets_alone = run_biodyn("walk --duration 9 --step-offsets 0.1 --json b.json", dir);
  CHECK(offsets_alone.exit_code == 2);
  CHECK(offsets_alone.err.find("--step-offsets") != std::string::npos);
  const Run miscount =
      run_biodyn("walk --duration 9 --steps 0.5,0.3 --step-offsets 0.1 --json b.json", dir);
  CHECK(miscount.exit_code == 2);
  CHECK(miscount.err.find("one per step length") != std::string::npos);
  const Run wide =
      run_biodyn("walk --duration 9 --steps 0.5,0.3 --step-offsets 0.1,0.5 --json b.json", dir);
  CHECK(wide.exit_code == 2);
  CHECK(wide.err.find("step offset 2") != std::string::npos);
  CHECK(wide.err.find("0.5") != std::string::npos);
  CHECK_FALSE(fs::exists(dir / "b.json"));
}

TEST_CASE("biodyn walk --terrain hill and steps: up 5 deg and down, up 5 cm and down, no fall",
          "[apps][cli][walk][terrain]") {
  const fs::path dir = fresh_dir("walk_terrain");
  for (const std::string terrain : {"hill", "steps"}) {
    const Run r = run_biodyn(
        "walk --terrain " + terrain + " --duration 22 --weld honest --csv t.csv --json t.json",
        dir);
    INFO(terrain << ": " << r.out << r.err);
    REQUIRE(r.exit_code == 0);
    CHECK(r.out.find("terrain: from 6 m") != std::string::npos);
    const auto j = nlohmann::json::parse(slurp(dir / "t.json"));
    CHECK_FALSE(j["fallen"].get<bool>());
    CHECK(j["inputs"]["terrain"]["kind"] == terrain);
    // Walked over it, not around: the CoM rose by the plateau's height (0.35 m, 0.05 m) and the
    // walk ended past the far side (x > 17 m, 13 m), back on the floor.
    std::istringstream csv(slurp(dir / "t.csv"));
    std::string line;
    std::getline(csv, line);  // header: time_s,com_x,com_y,com_z,...
    double z0 = -1, z_max = 0, x_end = 0, z_end = 0;
    while (std::getline(csv, line)) {
      std::istringstream row(line);
      std::string cell;
      double v[4];
      for (double& x : v) {
        std::getline(row, cell, ',');
        x = std::stod(cell);
      }
      if (z0 < 0) z0 = v[3];
      z_max = std::max(z_max, v[3]);
      x_end = v[1];
      z_end = v[3];
    }
    const bool hill = terrain == "hill";
    CHECK(z_max - z0 > (hill ? 0.3 : 0.04));
    CHECK(x_end > (hill ? 17.0 : 13.0));
    CHECK(std::abs(z_end - z0) < 0.05);
  }
  const Run bad = run_biodyn("walk --terrain mountain --duration 5 --json b.json", dir);
  CHECK(bad.exit_code == 2);
  CHECK(bad.err.find("--terrain") != std::string::npos);
  CHECK(bad.err.find("mountain") != std::string::npos);
  const Run steep = run_biodyn("walk --terrain hill --terrain-slope 40 --duration 5", dir);
  CHECK(steep.exit_code == 2);
  CHECK(steep.err.find("terrain slope") != std::string::npos);
}

TEST_CASE("biodyn walk --steps says which stone was out of reach and where the foot came down",
          "[apps][cli][walk][stones]") {
  const fs::path dir = fresh_dir("walk_stones_reach");
  const Run r = run_biodyn("walk --duration 8 --weld off --steps 0.5,1.5 --json s.json", dir);
  INFO(r.out << r.err);
  REQUIRE(r.exit_code <= 1);  // a split this long may end in a fall: the report is the subject
  // Either the foot came down short (measured 1.36 m) or the split felled the character first.
  CHECK(r.out.find("step 2: the stone at 1.500 m is out of reach; ") != std::string::npos);
  const auto j = nlohmann::json::parse(slurp(dir / "s.json"));
  CHECK(j["stones"]["out_of_reach_steps"] == nlohmann::json::array({2}));
  if (j["stones"]["lengths"].size() == 2) {
    CHECK(j["stones"]["lengths"][1].get<double>() < 1.45);
  } else {
    CHECK(r.out.find("the character fell reaching for it") != std::string::npos);
  }
  // A fall is on the stones line, whether before the last stone or after it.
  if (j["fallen"].get<bool>()) {
    CHECK((r.out.find("steps walked before the FALL at ") != std::string::npos ||
           r.out.find("steps walked, then FELL at ") != std::string::npos));
  } else {
    CHECK(r.out.find("FALL") == std::string::npos);
  }
  // A stop during the stones: its closing step (feet side by side) is not a stone.
  const Run stop = run_biodyn(
      "walk --duration 12 --steps 0.5,0.4,0.5,0.4,0.5 --stop-at 6 --json stop.json", dir);
  INFO(stop.out << stop.err);
  const auto js = nlohmann::json::parse(slurp(dir / "stop.json"));
  CHECK(js["stones"]["lengths"].size() == 5);
  CHECK(js["stones"]["complete"] == true);
  CHECK(stop.out.find("5 of 5 steps walked, error RMS") != std::string::npos);
  // Stones that never start say so (no start time, no RMS).
  const Run late = run_biodyn("walk --duration 6 --steps 0.5,0.4 --steps-start 5.9", dir);
  CHECK(late.out.find("stepping stones: not started") != std::string::npos);
}

TEST_CASE(
    "biodyn stones-sweep: the same sequences on 1 and 2 threads, a failure's replay line "
    "walks it again to the bit",
    "[apps][cli][walk][stones]") {
  const fs::path dir = fresh_dir("stones_sweep");
  // A turning walk: the replay line must carry every walk option (here --heading-rate).
  const std::string args = "stones-sweep --sequences 3 --seed 11 --lateral 0 --heading-rate 4 ";
  const Run one = run_biodyn(args + "--threads 1 -o one", dir);
  INFO(one.out << one.err);
  REQUIRE(one.exit_code == 0);
  const Run two = run_biodyn(args + "--threads 2 -o two", dir);
  REQUIRE(two.exit_code == 0);
  CHECK(slurp(dir / "one" / "sequences.csv") == slurp(dir / "two" / "sequences.csv"));
  CHECK(fs::file_size(dir / "one" / "errors.png") > 1000);
  const auto j = nlohmann::json::parse(slurp(dir / "one" / "summary.json"));
  CHECK(j["sequences"] == 3);
  const int passed = j["passed"].get<int>();
  CHECK(one.out.find(std::to_string(passed) + " of 3") != std::string::npos);
  // Every failure names its seed and a `biodyn walk` line; that line runs the same walk.
  REQUIRE(j["failed"].size() == static_cast<std::size_t>(3 - passed));
  for (const auto& f : j["failed"]) {
    const std::string seed = std::to_string(f["seed"].get<int>());
    CHECK(one.out.find("FAILED seed " + seed) != std::string::npos);
    const std::string replay = f["replay"].get<std::string>();
    REQUIRE(replay.rfind("biodyn walk ", 0) == 0);
    const Run again = run_biodyn(replay.substr(7) + " --json again.json", dir);
    INFO(again.out << again.err);
    const auto a = nlohmann::json::parse(slurp(dir / "again.json"));
    const std::string csv = slurp(dir / "one" / "sequences.csv");
    const std::size_t line = csv.find("\n" + seed + ",");
    REQUIRE(line != std::string::npos);
    std::ostringstream rms;
    rms << std::setprecision(10) << a["stones"]["rms_error"].get<double>();
    CHECK(csv.find(rms.str(), line) < csv.find('\n', line + 1));
  }
  const Run bad = run_biodyn("stones-sweep --sequences 0 -o bad", dir);
  CHECK(bad.exit_code == 2);
  CHECK(bad.err.find("sequences") != std::string::npos);
  // No sequence passed: the plot has the failed group only (not drawn as passed).
  const Run lateral = run_biodyn("stones-sweep --sequences 2 --seed 3 --threads 1 -o lat", dir);
  REQUIRE(lateral.exit_code == 0);
  REQUIRE(nlohmann::json::parse(slurp(dir / "lat" / "summary.json"))["passed"] == 0);
  const std::string gp = slurp(dir / "lat" / "errors.gp");
  CHECK(gp.find("failed") != std::string::npos);
  CHECK(gp.find("walked to the end") == std::string::npos);
  const Run speed = run_biodyn("stones-sweep --sequences 2 --speed 0.7 -o bad", dir);
  CHECK(speed.exit_code == 2);
  CHECK(speed.err.find("--speed-min") != std::string::npos);
  CHECK_FALSE(fs::exists(dir / "bad"));
}

TEST_CASE(
    "biodyn walk-sweep: the same walks on 1 and 2 threads, a fall's replay line walks it again "
    "to the bit",
    "[apps][cli][walk]") {
  const fs::path dir = fresh_dir("walk_sweep");
  const std::string args = "walk-sweep --bodies 2 --seed 11 --speeds 0.8,1.2 --duration 2 ";
  const Run one = run_biodyn(args + "--threads 1 -o one", dir);
  INFO(one.out << one.err);
  REQUIRE(one.exit_code == 0);
  const Run two = run_biodyn(args + "--threads 2 -o two", dir);
  REQUIRE(two.exit_code == 0);
  CHECK(slurp(dir / "one" / "walks.csv") == slurp(dir / "two" / "walks.csv"));
  CHECK(fs::file_size(dir / "one" / "walks.png") > 1000);
  const auto j = nlohmann::json::parse(slurp(dir / "one" / "summary.json"));
  CHECK(j["walks"] == 4);
  CHECK(one.out.find(std::to_string(j["walked"].get<int>()) + " of 4") != std::string::npos);
  // A walker without a torso (torso_kp 10) falls within a second: the failure names the body's
  // seed, and its `biodyn walk` line falls at the same time.
  std::ofstream(dir / "fall.json") << R"({"torso_kp": 10})";
  const Run fall = run_biodyn(
      "walk-sweep --bodies 1 --seed 4 --speeds 1.0 --duration 3 --params fall.json "
      "-o fall",
      dir);
  INFO(fall.out << fall.err);
  REQUIRE(fall.exit_code == 0);
  const auto jf = nlohmann::json::parse(slurp(dir / "fall" / "summary.json"));
  REQUIRE(jf["failed"].size() == 1);
  CHECK(fall.out.find("FELL seed 4") != std::string::npos);
  const std::string replay = jf["failed"][0]["replay"].get<std::string>();
  REQUIRE(replay.rfind("biodyn walk ", 0) == 0);
  const Run again = run_biodyn(replay.substr(7) + " --json again.json", dir);
  INFO(again.out << again.err);
  const auto a = nlohmann::json::parse(slurp(dir / "again.json"));
  std::ostringstream fell_at;
  fell_at << std::setprecision(10) << a["time_fallen"].get<double>();
  const std::string csv = slurp(dir / "fall" / "walks.csv");
  CHECK(csv.find("\n4,") != std::string::npos);
  CHECK(csv.find("," + fell_at.str() + ",") != std::string::npos);
  // Bad input: a clear error naming the option, nothing written.
  const Run bad = run_biodyn("walk-sweep --bodies 0 -o bad", dir);
  CHECK(bad.exit_code == 2);
  CHECK(bad.err.find("bodies") != std::string::npos);
  const Run speed = run_biodyn("walk-sweep --bodies 2 --speed 0.7 -o bad", dir);
  CHECK(speed.exit_code == 2);
  CHECK(speed.err.find("--speeds") != std::string::npos);
  const Run height = run_biodyn("walk-sweep --bodies 2 --height 1.7 -o bad", dir);
  CHECK(height.exit_code == 2);
  CHECK(height.err.find("--height-min") != std::string::npos);
  const Run list = run_biodyn("walk-sweep --bodies 2 --speeds 0.5,x -o bad", dir);
  CHECK(list.exit_code == 2);
  CHECK(list.err.find("--speeds") != std::string::npos);
  CHECK_FALSE(fs::exists(dir / "bad"));
}

TEST_CASE("biodyn push-sweep gives the same results on 1 and 2 threads, with a plot",
          "[apps][cli][push][slow]") {
  const fs::path dir = fresh_dir("push_sweep");
  const std::string args =
      "push-sweep --directions 2 --durations 0.2 --phases 2 --resolution 150 --max-force 450 "
      "--settle-strides 2 --weld off ";
  const Run one = run_biodyn(args + "--threads 1 --out one", dir);
  INFO(one.out << one.err);
  REQUIRE(one.exit_code == 0);
  const Run two = run_biodyn(args + "--threads 2 --out two", dir);
  INFO(two.out << two.err);
  REQUIRE(two.exit_code == 0);
  const std::string a = slurp(dir / "one" / "results.csv"), b = slurp(dir / "two" / "results.csv");
  CHECK(std::count(a.begin(), a.end(), '\n') == 5);  // header + 2 directions x 2 phases
  CHECK(a == b);
  const auto s = nlohmann::json::parse(slurp(dir / "two" / "summary.json"));
  REQUIRE(s["cells"].size() == 2);
  for (const auto& c : s["cells"]) {
    // The guaranteed envelope never exceeds the bisection figure's range, and is on the grid.
    const double f = c["max_survived_N_worst_phase"].get<double>();
    CHECK(std::fmod(f, 150.0) == 0.0);
    CHECK(f <= 450.0);
  }
  CHECK(fs::file_size(dir / "two" / "polar.png") > 1000);
}

TEST_CASE("biodyn push rejects a body it cannot push, by name", "[apps][cli][push]") {
  const fs::path dir = fresh_dir("push_bad");
  const Run r = run_biodyn("push --force 100 --body head --json p.json", dir);
  CHECK(r.exit_code == 2);
  CHECK(r.err.find("--body") != std::string::npos);
  CHECK(r.err.find("head") != std::string::npos);
  CHECK_FALSE(fs::exists(dir / "p.json"));
}

TEST_CASE("A bad walker parameter is refused before any run, by push-sweep as by walk",
          "[apps][cli][push]") {
  // The sweep's workers each built the walker and failed there: exit 1 after the banner.
  const fs::path dir = fresh_dir("sweep_bad_params");
  std::ofstream(dir / "bad.json") << R"({"speed_recovery_gain_rad_per_m_s": -1})";
  for (const char* args : {"push-sweep --params bad.json --controller velocity --out out",
                           "walk --params bad.json --duration 1 --json w.json"}) {
    INFO(args);
    const Run r = run_biodyn(args, dir);
    INFO(r.err);
    CHECK(r.exit_code == 2);
    CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);
    CHECK_THAT(r.err, Catch::Contains("bad.json") &&
                          Catch::Contains("walker.speed_recovery_gain_rad_per_m_s") &&
                          Catch::Contains("-1"));
    CHECK(r.out.find("cells") == std::string::npos);  // no sweep banner: nothing started
    CHECK_FALSE(fs::exists(dir / "out"));
    CHECK_FALSE(fs::exists(dir / "w.json"));
  }
}
