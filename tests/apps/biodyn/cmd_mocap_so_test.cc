// `biodyn mocap so` as a user runs it on walking5 (IK first, then static optimisation with the
// capture's force plates, or on the torques `mocap id` wrote): the files it writes and what they
// hold, and bad input refused in one line naming the file, field and value, with nothing written.
#include <unistd.h>
#include <algorithm>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "cli_runner.h"
#include "image_check.h"
#include "test_support.h"

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

using SoRun = biodyn::testing::CliRun;
using biodyn::testing::run_biodyn;
using biodyn::testing::slurp;
using biodyn::testing::write_text;

const char* const kSoOutputs[] = {"activations.csv", "forces.csv", "reserves.csv", "summary.json",
                                  "activations.png"};

std::string so_c3d() {
  return biodyn::testing::source_dir() + "/../shared/data/mocap/c3d/opensim_walking5.c3d";
}

/// The lines of a CSV text.
std::vector<std::string> csv_lines(const std::string& text) {
  std::istringstream in(text);
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

/// A directory with walking5's IK motion (motion.csv) and its inverse dynamics (id/), made once.
const fs::path& so_workdir() {
  static const fs::path dir = [] {
    // One directory per process: ctest runs this file's cases in parallel processes, and each
    // makes the shared IK and ID once.
    const fs::path d =
        biodyn::testing::fresh_dir("mocap_so_cli_test", "walking5_" + std::to_string(getpid()));
    const SoRun ik = run_biodyn("mocap ik --c3d '" + so_c3d() + "' -o motion.csv", d);
    INFO(ik.out << ik.err);
    REQUIRE(ik.exit_code == 0);
    const SoRun id =
        run_biodyn("mocap id --motion motion.csv --grf from-c3d --c3d '" + so_c3d() + "' -o id", d);
    INFO(id.out << id.err);
    REQUIRE(id.exit_code == 0);
    return d;
  }();
  return dir;
}

}  // namespace

TEST_CASE("mocap so on walking5 writes activations, forces, reserves, a summary and the plot",
          "[apps][mocap][so][slow]") {
  const fs::path& dir = so_workdir();
  fs::remove_all(dir / "so");
  const SoRun r = run_biodyn("mocap so --motion motion.csv --c3d '" + so_c3d() + "' -o so", dir);
  INFO(r.out << r.err);
  REQUIRE(r.exit_code == 0);
  CHECK(r.out.find("frames/s (the solve loop)") != std::string::npos);
  for (const char* f : kSoOutputs) CHECK(fs::exists(dir / "so" / f));
  int width = 0, height = 0, channels = 0;
  CHECK(stbi_info((dir / "so" / "activations.png").c_str(), &width, &height, &channels) == 1);
  CHECK(width == 1500);

  const json s = json::parse(slurp(dir / "so" / "summary.json"));
  CHECK(s["tendon_model"].get<std::string>().rfind("rigid", 0) == 0);
  CHECK(s["reserve_weight_per_Nm2"] == 1.0);
  CHECK(s["ground"] == "from-c3d");
  CHECK(s["solve"]["frames_per_second"].get<double>() > 0);
  CHECK(s["solve"]["qp_failures"] == 0);
  CHECK(s["dofs"].size() == 14);  // hips (3), knees, ankles (2), toes (the toe extensor), both legs
  for (const auto& [dof, d] : s["dofs"].items()) {
    INFO(dof);
    CHECK(d.contains("peak_abs_id_torque_Nm"));
    CHECK(d.contains("peak_abs_reserve_Nm"));
    CHECK(d.contains("reserve_to_peak_ratio"));
  }
  CHECK(s["muscles"].size() == 36);  // 18 per leg
  const json& soleus = s["muscles"]["soleus_r"];
  CHECK(soleus["cycle_mean_peak_percent"].get<double>() >= 0);
  CHECK(soleus["reference_emg_on_percent"] == json::array({json::array({10.0, 50.0})}));
  // A muscle in parts takes the whole muscle's on-times (gluteus medius: 95-35%).
  CHECK(s["muscles"]["glut_med_ant_r"]["reference_emg_on_percent"].size() == 2);
  // The right leg's heel strike on plate 2 starts the averaged cycle.
  const json& right = s["gait_cycle"]["right"];
  CHECK(right["heel_strikes"][0]["source"] == "force plate 2 onset");
  CHECK(right["cycles"][0]["averaged"] == true);
  CHECK(right["toe_off_percent"].get<double>() == Approx(62).margin(3));

  const std::vector<std::string> activations = csv_lines(slurp(dir / "so" / "activations.csv"));
  REQUIRE(activations.size() == s["frames"].get<std::size_t>() + 1);
  CHECK(activations[0].rfind("time,glut_max_l,", 0) == 0);
  CHECK(static_cast<std::size_t>(std::count(activations[0].begin(), activations[0].end(), ',')) ==
        s["muscles"].size());
  const std::vector<std::string> reserves = csv_lines(slurp(dir / "so" / "reserves.csv"));
  CHECK(reserves[0].rfind("time,hip_l_x_id,hip_l_x_muscles,hip_l_x_reserve,", 0) == 0);

  // The same from the torques mocap id wrote (to its CSV's 9 digits).
  fs::remove_all(dir / "so_id");
  const SoRun from_id = run_biodyn("mocap so --motion motion.csv --id id -o so_id", dir);
  INFO(from_id.out << from_id.err);
  REQUIRE(from_id.exit_code == 0);
  const json s_id = json::parse(slurp(dir / "so_id" / "summary.json"));
  CHECK(s_id["ground"] == "from-c3d");
  CHECK(s_id["muscles"]["soleus_r"]["peak_activation"].get<double>() ==
        Approx(soleus["peak_activation"].get<double>()).margin(1e-6));
  CHECK(s_id["gait_cycle"]["right"]["heel_strikes"][0]["source"] == "force plate 2 onset");
}

TEST_CASE("mocap so refuses bad input in one line naming the file, field and value",
          "[apps][mocap][so][slow]") {
  const fs::path& dir = so_workdir();
  // A torques.csv of other frames, a bad number, another body, no summary: each in its own DIR.
  const std::string torques = slurp(dir / "id" / "torques.csv");
  const std::string summary = slurp(dir / "id" / "summary.json");
  std::vector<std::string> lines = csv_lines(torques);
  const auto make_id = [&](const std::string& name, const std::string& t, const std::string& s) {
    fs::create_directories(dir / name);
    write_text(dir / name / "torques.csv", t);
    if (!s.empty()) write_text(dir / name / "summary.json", s);
  };
  std::string short_torques;
  for (std::size_t i = 0; i + 5 < lines.size(); ++i) short_torques += lines[i] + "\n";
  make_id("id_short", short_torques, summary);
  std::string bad_number = torques;
  bad_number.replace(bad_number.find('\n', bad_number.find('\n') + 1) - 3, 1, "x");
  make_id("id_bad_number", bad_number, summary);
  json heavier = json::parse(summary);
  heavier["character"]["mass_kg"] = 72.0;
  make_id("id_other_body", torques, heavier.dump());
  make_id("id_no_summary", torques, "");
  write_text(dir / "params.json", R"({"muscles": {"soleus": {"max_isometric_force": 5000}}})");
  write_text(dir / "a_file", "not a directory");

  const std::vector<std::pair<std::string, std::string>> cases = {
      {"--id id_short", "rows, but the motion's solved frames give 564"},
      {"--id id_bad_number", "id_bad_number/torques.csv:2: column"},
      {"--id id_other_body", "character.mass_kg is 72.0, but the body here has 80.0"},
      {"--id id_no_summary", "id_no_summary/summary.json"},
      {"--id id --muscle-params params.json",
       "params.json: muscles.soleus: unknown field 'max_isometric_force'"},
      {"--id id --reserve-weights hip_q=1", "no DOF the muscles span is called 'hip_q'"},
      {"--id id --reserve-weights hip_z=-1", "expected NAME=W with W > 0, got 'hip_z=-1'"},
      {"--id id --reserve-weight 0", "--reserve-weight: must be > 0"},
      {"--c3d missing.c3d", "missing.c3d"},
      {"--id id -o a_file", "'a_file' is a file, not a directory"},
      {"--id id -o id", "'id' is an input"},
  };
  for (const auto& [args, message] : cases) {
    const std::string out = args.find(" -o ") == std::string::npos ? " -o refused" : "";
    const SoRun r = run_biodyn("mocap so --motion motion.csv " + args + out, dir);
    INFO(args << ": " << r.out << r.err);
    CHECK(r.exit_code == 2);
    CHECK(r.err.find(message) != std::string::npos);
    CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);
    CHECK_FALSE(fs::exists(dir / "refused"));
  }
}

TEST_CASE("mocap so writes none of its outputs when the plot fails", "[apps][mocap][so][slow]") {
  const fs::path& dir = so_workdir();
  fs::remove_all(dir / "so_no_plot");
  const SoRun r = biodyn::testing::run_shell("PATH=/nonexistent '" + biodyn::testing::binary_dir() +
                                                 "/apps/biodyn' mocap so --motion motion.csv "
                                                 "--id id -o so_no_plot",
                                             dir);
  INFO(r.out << r.err);
  CHECK(r.exit_code == 1);
  CHECK(r.err.find("gnuplot") != std::string::npos);
  for (const char* f : kSoOutputs) CHECK_FALSE(fs::exists(dir / "so_no_plot" / f));
}
