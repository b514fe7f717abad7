// `biodyn evaluate` as a user runs it: the CMU clip on two bodies (no tracking: the costly part
// has its own tests), a CSV per body, summary.json, and report.html opened in a real browser
// (Debian's Chromium, headless): it renders the feasibility table and the torque plot.
// A C3D capture goes through marker IK first.
#include <algorithm>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "cli_runner.h"
#include "image_check.h"
#include "test_support.h"

namespace biodyn::testing::cmd_evaluate_test {

namespace fs = std::filesystem;
using nlohmann::json;

TEST_CASE("biodyn evaluate: CSV per body, summary.json, and an HTML report a browser renders",
          "[apps][cli][evaluate]") {
  const fs::path dir = fresh_dir("evaluate_cli_test", "cmu");
  write_text(dir / "bodies.json", R"({"bodies": [
      {"name": "light", "height_m": 1.7, "mass_kg": 60},
      {"name": "heavy", "height_m": 1.8, "mass_kg": 140, "tau_max": "fixed",
       "profile": "heavy_trunk_thighs"}]})");
  const std::string bvh = source_dir() + "/../shared/data/mocap/bvh/cmu_131_01_start_walk_stop.bvh";
  const CliRun r =
      run_biodyn("evaluate --motion '" + bvh + "' --bodies bodies.json --tracking off -o out", dir);
  INFO(r.out << r.err);
  REQUIRE(r.exit_code == 0);
  CHECK(fs::file_size(dir / "out" / "light.csv") > 10000);
  CHECK(fs::file_size(dir / "out" / "heavy.csv") > 10000);
  const json s = json::parse(slurp(dir / "out" / "summary.json"));
  REQUIRE(s["bodies"].size() == 2);
  for (const json& b : s["bodies"]) {
    CHECK(b.contains("verdict"));
    CHECK(b["joints"].size() > 10);
    CHECK(b["ground_force_peak_bw"].get<double>() < 3.0);  // no contact spikes
    CHECK(b["static_optimisation"]["peak_activation"].size() == 36);
  }
  CHECK(s["assumptions"].contains("ground_forces"));
  const std::string html = slurp(dir / "out" / "report.html");
  CHECK(html.find("data:image/png;base64,") != std::string::npos);  // self-contained
  CHECK(html.find("src=\"http") == std::string::npos);

  // A real browser: the DOM it builds has the table's rows, and its screenshot shows the plot's
  // coloured curves (gnuplot's line colours are not grey).
  const std::string chromium =
      "chromium --headless --no-sandbox --disable-gpu --disable-quic --no-first-run "
      "--disable-background-networking --disable-component-update --disable-sync "
      "--user-data-dir=" +
      (dir / "profile").string() + " ";
  const CliRun dom = run_shell(
      chromium + "--dump-dom 'file://" + fs::absolute(dir / "out" / "report.html").string() + "'",
      dir);
  INFO(dom.err);
  REQUIRE(dom.exit_code == 0);
  CHECK(dom.out.find("<td class=\"l\">light</td>") != std::string::npos);
  CHECK(dom.out.find("<td class=\"l\">heavy</td>") != std::string::npos);
  CHECK(dom.out.find("id=\"assumptions\"") != std::string::npos);
  const CliRun shot =
      run_shell(chromium + "--window-size=1600,1600 --screenshot=" + (dir / "shot.png").string() +
                    " 'file://" + fs::absolute(dir / "out" / "report.html").string() + "'",
                dir);
  REQUIRE(shot.exit_code == 0);
  const int coloured = count_pixels((dir / "shot.png").string(), [](int red, int green, int blue) {
    return std::max({red, green, blue}) - std::min({red, green, blue}) > 80;
  });
  CHECK(coloured > 2000);
}

TEST_CASE("biodyn evaluate: a C3D capture is solved by marker IK first, then evaluated",
          "[apps][cli][evaluate]") {
  const fs::path dir = fresh_dir("evaluate_cli_test", "c3d");
  write_text(dir / "bodies.json", R"({"bodies": [{"name": "same", "height_m": 1.87}]})");
  const std::string c3d = source_dir() + "/../shared/data/mocap/c3d/opensim_walking5.c3d";
  const CliRun r =
      run_biodyn("evaluate --motion '" + c3d + "' --bodies bodies.json --tracking off -o out", dir);
  INFO(r.out << r.err);
  REQUIRE(r.exit_code == 0);
  CHECK(r.out.find("mocap ik:") != std::string::npos);  // the IK's own summary
  CHECK(fs::file_size(dir / "out" / "capture_ik.csv") > 10000);
  CHECK(fs::exists(dir / "out" / "capture_ik.body.json"));
  const json s = json::parse(slurp(dir / "out" / "summary.json"));
  CHECK(s["motion_ik"]["file"].get<std::string>().find("capture_ik.csv") != std::string::npos);
  CHECK(s["motion_ik"]["status"]["level"].is_string());  // the IK's fit, as mocap ik judges it
  REQUIRE(s["bodies"].size() == 1);
  CHECK(s["bodies"][0]["joints"].size() > 10);
  CHECK(s["bodies"][0]["ground_force_peak_bw"].get<double>() < 3.0);

  // A body named as the IK's output is refused before anything runs; IK options only with a
  // capture.
  write_text(dir / "clash.json", R"({"bodies": [{"name": "capture_ik"}]})");
  const CliRun clash =
      run_biodyn("evaluate --motion '" + c3d + "' --bodies clash.json --tracking off -o o2", dir);
  CHECK(clash.exit_code != 0);
  CHECK(clash.err.find("capture_ik") != std::string::npos);
  const CliRun lab =
      run_biodyn("evaluate --motion out/capture_ik.csv --bodies bodies.json --lab-up y -o o3", dir);
  CHECK(lab.exit_code != 0);
  CHECK(lab.err.find("--lab-up") != std::string::npos);
}

}  // namespace biodyn::testing::cmd_evaluate_test
