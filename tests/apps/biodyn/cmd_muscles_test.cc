// `biodyn muscles curves` as a user runs it: the normalised curves' CSV at their documented
// points and their plot, one muscle's isometric force-angle curve, and bad input refused with
// nothing written.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "cli_runner.h"
#include "test_support.h"

namespace fs = std::filesystem;

namespace biodyn::testing::cmd_muscles_test {
namespace {

constexpr double kCsvDigits = 1e-9;  // values printed with 9-12 significant digits

fs::path muscles_dir(const std::string& name) { return fresh_dir("muscles_cli_test", name); }

using Table = std::vector<std::vector<std::string>>;

// The rows of a CSV (header first), split at commas.
Table read_csv(const fs::path& p) {
  Table rows;
  std::istringstream in(slurp(p));
  for (std::string line; std::getline(in, line);) {
    std::vector<std::string> cells;
    std::istringstream l(line);
    for (std::string cell; std::getline(l, cell, ',');) cells.push_back(cell);
    rows.push_back(cells);
  }
  return rows;
}

// curves.csv's value of `curve` at x (the row whose x is exactly that), or NaN.
double curve_value(const Table& t, const std::string& curve, double x) {
  for (std::size_t r = 1; r < t.size(); ++r)
    if (t[r][0] == curve && std::stod(t[r][1]) == x) return std::stod(t[r][2]);
  return std::nan("");
}

bool is_png(const fs::path& p) {
  const std::string bytes = slurp(p);
  return bytes.size() > 1000 && bytes.compare(1, 3, "PNG") == 0;
}

}  // namespace

TEST_CASE("muscles curves writes the normalised curves at their documented values",
          "[apps][cli][muscles]") {
  const fs::path dir = muscles_dir("curves");
  const CliRun r = run_biodyn("muscles curves -o out", dir);
  INFO(r.out << r.err);
  REQUIRE(r.exit_code == 0);
  const Table t = read_csv(dir / "out" / "curves.csv");
  REQUIRE(!t.empty());
  CHECK(t[0] == std::vector<std::string>{"curve", "x", "value", "slope"});
  std::map<std::string, int> rows;
  for (std::size_t i = 1; i < t.size(); ++i) {
    REQUIRE(t[i].size() == 4);
    ++rows[t[i][0]];
  }
  // l~ in [0.4, 1.8] and v~ in [-1, 1] by 0.01, strain in [0, 0.06] by 0.0001.
  CHECK(rows["active_force_length"] == 141);
  CHECK(rows["passive_force_length"] == 141);
  CHECK(rows["force_velocity"] == 201);
  CHECK(rows["tendon_force_strain"] == 601);
  CHECK(curve_value(t, "active_force_length", 1.0) == 1.0);
  CHECK(curve_value(t, "force_velocity", -1.0) == 0.0);
  CHECK(curve_value(t, "force_velocity", 0.0) == 1.0);
  CHECK(curve_value(t, "tendon_force_strain", 0.04) == Approx(0.9994).margin(1e-4));
  CHECK(curve_value(t, "tendon_force_strain", 0.0) == 0.0);
  CHECK(curve_value(t, "passive_force_length", 1.6) == Approx(1.0).margin(kCsvDigits));
  CHECK(curve_value(t, "passive_force_length", 1.0) == 0.0);
  CHECK(curve_value(t, "force_velocity", 1.0) == Approx(14.4 / 10.4).margin(kCsvDigits));
  CHECK(is_png(dir / "out" / "curves.png"));
  CHECK(fs::exists(dir / "out" / "curves.gp"));
  CHECK_FALSE(fs::exists(dir / "out" / "curves.png.tmp"));
  CHECK(r.out.find("F_T(0.04) = 0.9993") != std::string::npos);
}

TEST_CASE("muscles curves --muscle soleus: its isometric force and moment across the ankle",
          "[apps][cli][muscles]") {
  const fs::path dir = muscles_dir("soleus");
  const CliRun right = run_biodyn("muscles curves --muscle soleus -o out", dir);
  INFO(right.out << right.err);
  REQUIRE(right.exit_code == 0);
  const CliRun left = run_biodyn("muscles curves --muscle soleus_l -o out", dir);
  REQUIRE(left.exit_code == 0);
  CHECK(right.out.find("soleus_r") != std::string::npos);
  CHECK(right.out.find("ankle_dorsiflexion_r") != std::string::npos);
  CHECK(right.out.find("compliant tendon") != std::string::npos);
  const Table t = read_csv(dir / "out" / "soleus_r_isometric.csv");
  const Table l = read_csv(dir / "out" / "soleus_l_isometric.csv");
  REQUIRE(t.size() == 1 + 71);  // -50 to 20 deg by 1 deg
  CHECK(t[0] == std::vector<std::string>{"angle_deg", "path_length_m", "moment_arm_m",
                                         "fiber_length_m", "force_N", "moment_Nm",
                                         "passive_force_N", "passive_moment_Nm"});
  CHECK(std::stod(t[1][0]) == -50.0);
  CHECK(std::stod(t.back()[0]) == 20.0);
  REQUIRE(l.size() == t.size());
  double previous_length = 0.0;
  for (std::size_t i = 1; i < t.size(); ++i) {
    INFO("row " << i);
    const double length = std::stod(t[i][1]), arm = std::stod(t[i][2]);
    const double force = std::stod(t[i][4]), moment = std::stod(t[i][5]);
    CHECK(arm < 0.0);                 // a plantarflexor: dorsiflexion lengthens it
    CHECK(length > previous_length);  // longer as the ankle dorsiflexes
    CHECK(force > 0.0);
    CHECK(force < 2.0 * 6578.27);  // F_max of the default body's soleus
    CHECK(moment == Approx(arm * force).epsilon(1e-6));
    CHECK(std::stod(t[i][6]) <= force);            // passive below active
    for (std::size_t c = 0; c < t[i].size(); ++c)  // the body is symmetric
      CHECK(std::stod(l[i][c]) == Approx(std::stod(t[i][c])).epsilon(1e-9));
    previous_length = length;
  }
  CHECK(is_png(dir / "out" / "soleus_r_isometric.png"));
  CHECK(is_png(dir / "out" / "curves.png"));
}

TEST_CASE("muscles curves --muscle on another body and about a chosen DOF",
          "[apps][cli][muscles]") {
  const fs::path dir = muscles_dir("gastroc");
  const CliRun r = run_biodyn(
      "muscles curves --muscle gastroc --dof knee_flexion_r --tendon rigid --height 1.55 "
      "--mass 50 --sex female -o out",
      dir);
  INFO(r.out << r.err);
  REQUIRE(r.exit_code == 0);
  CHECK(r.out.find("rigid tendon") != std::string::npos);
  CHECK(r.out.find("1.55 m, 50 kg, female") != std::string::npos);
  const Table t = read_csv(dir / "out" / "gastroc_r_isometric.csv");
  REQUIRE(t.size() == 1 + 136);                                                // knee 0 to 135 deg
  for (std::size_t i = 1; i < t.size(); ++i) CHECK(std::stod(t[i][2]) > 0.0);  // a knee flexor
}

TEST_CASE("muscles curves refuses a bad muscle, DOF or output naming it, nothing written",
          "[apps][cli][muscles]") {
  const fs::path dir = muscles_dir("bad");
  {
    const CliRun r = run_biodyn("muscles curves --muscle solues -o out", dir);
    CHECK(r.exit_code == 2);
    INFO(r.err);
    for (const char* word : {"--muscle", "solues", "soleus", "tib_ant", "glut_max", "per_long"})
      CHECK(r.err.find(word) != std::string::npos);
    CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);
    CHECK_FALSE(fs::exists(dir / "out"));
  }
  {
    const CliRun r = run_biodyn("muscles curves --muscle soleus --dof knee_flexion_r -o out", dir);
    CHECK(r.exit_code == 2);
    INFO(r.err);
    for (const char* word :
         {"--dof", "knee_flexion_r", "ankle_dorsiflexion_r", "ankle_inversion_r"})
      CHECK(r.err.find(word) != std::string::npos);
    CHECK_FALSE(fs::exists(dir / "out"));
  }
  {
    const CliRun r = run_biodyn("muscles curves --muscle soleus --tendon springy -o out", dir);
    CHECK(r.exit_code == 2);
    CHECK(r.err.find("springy") != std::string::npos);
    CHECK_FALSE(fs::exists(dir / "out"));
  }
  {
    write_text(dir / "a_file", "not a directory");
    const CliRun r = run_biodyn("muscles curves -o a_file", dir);
    CHECK(r.exit_code == 2);
    CHECK(r.err.find("a_file") != std::string::npos);
    CHECK(slurp(dir / "a_file") == "not a directory");
  }
  {
    const CliRun r = run_biodyn("muscles curves", dir);  // -o is required
    CHECK(r.exit_code == 2);
    CHECK(r.err.find("--output") != std::string::npos);
  }
}

}  // namespace biodyn::testing::cmd_muscles_test
