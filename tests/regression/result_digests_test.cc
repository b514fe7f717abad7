// Every figure the tool prints, pinned: each case runs `biodyn` as a user does and compares a
// digest of every output file with the one the tool wrote before the restructuring of issue 23
// (tests/regression/result_digests.json). A restructuring changes none of them; a change that
// is meant to change results regenerates the file (BIODYN_WRITE_DIGESTS=<path>) and says so.
//
// What a digest covers: JSON with the wall-clock fields removed (wall_s, real-time factors,
// frames per second: they measure the machine, not the result), CSV and PNG byte for byte.
// Data files are reached through a link `data` in the run directory, so no absolute path enters
// an output.
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "cli_runner.h"
#include "test_support.h"

namespace fs = std::filesystem;
using biodyn::testing::run_biodyn;
using biodyn::testing::run_shell;
using biodyn::testing::slurp;
using nlohmann::json;

namespace {

// Fields that measure the machine (time, rates), not the result.
const std::set<std::string> kTimingFields = {"wall_s",
                                             "realtime_factor",
                                             "frames_per_second",
                                             "solved_frames_per_second",
                                             "frames_per_s",
                                             "physics_s",
                                             "render_s",
                                             "encode_s",
                                             "render_frames_per_s",
                                             "physics_realtime_factor",
                                             "physics_steps_per_s"};

struct Output {
  std::string file;
  std::set<std::string> also_drop = {};  // more wall-clock fields of this file
};

struct Case {
  Case(std::string name_, std::string args_, std::vector<Output> outputs_, int exit_code_ = 0)
      : name(std::move(name_)),
        args(std::move(args_)),
        outputs(std::move(outputs_)),
        exit_code(exit_code_) {}
  std::string name;
  std::string args;             // biodyn's arguments, run in <build>/digests/<name>
  std::vector<Output> outputs;  // files compared
  int exit_code = 0;
  bool viewer = false;  // run under xvfb-run (biodyn view)
  std::string script;   // biodyn view --script
};

void drop_fields(json* j, const std::set<std::string>& drop) {
  if (j->is_object()) {
    for (auto it = j->begin(); it != j->end();) {
      if (drop.count(it.key()) > 0) {
        it = j->erase(it);
      } else {
        drop_fields(&it.value(), drop);
        ++it;
      }
    }
  } else if (j->is_array()) {
    for (json& e : *j) drop_fields(&e, drop);
  }
}

// FNV-1a, 64 bit: a fixed, dependency-free digest (not a security hash).
std::string fnv1a(const std::string& bytes) {
  std::uint64_t h = 14695981039346656037ull;
  for (unsigned char c : bytes) {
    h ^= c;
    h *= 1099511628211ull;
  }
  std::ostringstream s;
  s << std::hex << std::setw(16) << std::setfill('0') << h;
  return s.str();
}

std::string digest(const fs::path& path, const Output& out) {
  const std::string bytes = slurp(path);
  if (path.extension() != ".json") return fnv1a(bytes);
  json j = json::parse(bytes);
  std::set<std::string> drop = kTimingFields;
  drop.insert(out.also_drop.begin(), out.also_drop.end());
  drop_fields(&j, drop);
  return fnv1a(j.dump());
}

fs::path digest_file() {
  return fs::path(biodyn::testing::source_dir()) / "tests/regression/result_digests.json";
}

// Runs the cases and compares (or, with BIODYN_WRITE_DIGESTS, records) their digests.
void check_cases(const std::vector<Case>& cases) {
  const char* write_to = std::getenv("BIODYN_WRITE_DIGESTS");
  json expected = json::object();
  if (write_to == nullptr) {
    expected = json::parse(slurp(digest_file()));
  }
  json written =
      write_to != nullptr && fs::exists(write_to) ? json::parse(slurp(write_to)) : json::object();
  const fs::path data =
      fs::path(biodyn::testing::source_dir()) / ".." / "shared" / "data" / "mocap";
  const fs::path root = fs::path(biodyn::testing::binary_dir()) / "digests";
  fs::create_directories(root);
  for (const Case& c : cases) {
    const fs::path dir = root / c.name;
    fs::remove_all(dir);
    fs::create_directories(dir);
    fs::create_directory_symlink(fs::canonical(data), dir / "data");
    biodyn::testing::CliRun r;
    if (c.viewer) {
      std::ofstream(dir / "script.txt") << c.script;
      const std::string exe = biodyn::testing::binary_dir() + "/apps/biodyn";
      r = run_shell(biodyn::testing::under_xvfb() + "'" + exe + "' " + c.args, dir);
    } else {
      r = run_biodyn(c.args, dir);
    }
    INFO(c.name << ": biodyn " << c.args << "\n" << r.out << r.err);
    CHECK(r.exit_code == c.exit_code);
    if (r.exit_code != c.exit_code) continue;
    for (const Output& out : c.outputs) {
      INFO(c.name << ": " << out.file);
      CHECK(fs::exists(dir / out.file));
      if (!fs::exists(dir / out.file)) continue;
      const std::string d = digest(dir / out.file, out);
      if (write_to != nullptr) {
        written[c.name][out.file] = d;
      } else {
        CHECK(expected.contains(c.name));
        CHECK(expected.value(c.name, json::object()).value(out.file, std::string("missing")) == d);
      }
    }
  }
  if (write_to != nullptr) std::ofstream(write_to) << written.dump(2) << "\n";
}

const std::vector<Output> kWalkOutputs = {{"r.json"}, {"r.csv"}};

}  // namespace

TEST_CASE("Result digests: biodyn walk", "[regression][digests][slow]") {
  check_cases({
      {"walk_default", "walk --duration 20 --json r.json --csv r.csv", kWalkOutputs},
      {"walk_weld_off", "walk --weld off --duration 20 --json r.json --csv r.csv", kWalkOutputs},
      {"walk_speed_15", "walk --speed 1.5 --duration 20 --json r.json --csv r.csv", kWalkOutputs},
      // The paper's stones at 1 m/s (it fell 3 s after them until the lean followed the plan's
      // speed, plan_speed_gain).
      {"walk_steps",
       "walk --steps 0.60,0.20,0.50,0.16,0.50,0.30 --duration 12 --json r.json --csv r.csv",
       kWalkOutputs},
      {"walk_stop", "walk --stop-at 8 --duration 14 --json r.json --csv r.csv", kWalkOutputs},
      {"walk_small",
       "walk --height 1.55 --mass 50 --sex female --duration 20 --json r.json --csv r.csv",
       kWalkOutputs},
      {"walk_glue",
       "walk --weld glue --reaction-time 0.1 --heading-rate 10 --duration 12 --json r.json --csv "
       "r.csv",
       kWalkOutputs},
      // The legs' Hill muscles (issue 25): drive, activation and fibre states, backups.
      {"walk_muscles", "walk --muscles on --duration 6 --json r.json --csv r.csv", kWalkOutputs},
  });
}

TEST_CASE("Result digests: biodyn pose and stand-push", "[regression][digests][slow]") {
  check_cases({
      {"pose_stand", "pose --scenario stand --json r.json --csv r.csv", kWalkOutputs},
      {"pose_squat", "pose --scenario squat --json r.json --csv r.csv", kWalkOutputs},
      {"pose_reach", "pose --scenario reach --json r.json --csv r.csv", kWalkOutputs},
      {"pose_one-leg", "pose --scenario one-leg --json r.json --csv r.csv", kWalkOutputs},
      {"pose_pd", "pose --scenario stand --controller pd --duration 3 --json r.json --csv r.csv",
       kWalkOutputs},
      {"pose_push",
       "pose --scenario stand --weld glue --push 150,0.2,90 --duration 4 --json r.json --csv r.csv",
       kWalkOutputs},
      {"stand_push",
       "stand-push --directions 0,90 --welds off,honest --resolution 40 --json r.json",
       {{"r.json"}}},
  });
}

TEST_CASE("Result digests: biodyn push and push-sweep", "[regression][digests][slow]") {
  const std::vector<Output> sweep = {
      {"out/results.csv"}, {"out/summary.json"}, {"out/polar.dat"}, {"out/polar.gp"}};
  check_cases({
      {"push_side", "push --force 250 --direction 90 --json r.json --csv r.csv", kWalkOutputs},
      {"push_trunk",
       "push --force 300 --body trunk --onset-phase 0.5 --weld off --json r.json",
       {{"r.json"}}},
      {"sweep",
       "push-sweep --directions 2 --durations 0.2 --phases 2 --resolution 100 --max-force 300 "
       "--threads 2 --out out",
       sweep},
      {"sweep_fixed",
       "push-sweep --directions 4 --durations 0.2 --phases 1 --fixed-force 200 --threads 2 --out "
       "out",
       sweep},
  });
}

TEST_CASE("Result digests: biodyn mocap ik retarget and id", "[regression][digests][slow]") {
  check_cases({
      {"mocap",
       "mocap ik --c3d data/c3d/opensim_walking5.c3d --static data/c3d/opensim_walking5.c3d -o "
       "motion.csv "
       "--json stats.json && '" +
           biodyn::testing::binary_dir() +
           "/apps/biodyn' mocap id --motion motion.csv --mass 72 --grf from-c3d "
           "--c3d data/c3d/opensim_walking5.c3d -o id",
       {{"motion.csv"},
        {"stats.json"},
        {"id/torques.csv"},
        {"id/residuals.csv"},
        {"id/summary.json"}}},
      {"retarget",
       "mocap retarget --bvh data/bvh/cmu_131_01_start_walk_stop.bvh --height 2.0 --mass 90 -o out "
       "&& '" +
           biodyn::testing::binary_dir() +
           "/apps/biodyn' mocap id --motion out/motion.csv --height 2.0 --mass 90 --grf estimate "
           "-o "
           "id",
       {{"out/motion.csv"},
        {"out/stats.json"},
        {"out/character.bvh"},
        {"id/torques.csv"},
        {"id/residuals.csv"},
        {"id/ground.csv"},
        {"id/summary.json"}}},
  });
}

TEST_CASE("Result digests: biodyn render and the viewer's scripted session",
          "[regression][digests][slow]") {
  const std::vector<Output> render = {{"s.json"}, {"f.png"}};
  Case view{"view",
            "view --size 640x360 --msaa 0 --script script.txt --summary s.json",
            {{"s.json", {"frames"}}, {"walker.json"}, {"controller.json"}}};
  view.viewer = true;
  view.script =
      "at 1.0 set walker.pelvis_pitch_rad 0.2\n"
      "at 2.0 push pelvis 150 90 0.2\n"
      "at 2.5 rewind 1.5\n"
      "at 3.0 save-params walker.json controller.json\n"
      "at 3.0 quit\n";
  check_cases({
      {"render_walk",
       "render --scenario walk --duration 3 --size 320x240 --png f.png --summary s.json", render},
      {"render_stones",
       "render --scenario stones --duration 9 --size 320x240 --png f.png --summary s.json", render},
      {"render_squat",
       "render --scenario squat --duration 4 --size 320x240 --png f.png --summary s.json", render},
      {"render_track",
       "render --scenario mocap --motion data/bvh/cmu_131_01_start_walk_stop.bvh --motion-from 4.0 "
       "--motion-to 6.2 "
       "--track --duration 2.5 --size 320x240 --png f.png --summary s.json",
       render},
      view,
  });
}
