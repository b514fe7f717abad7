// `biodyn render` headless (issue 6): the video has the frames asked for and the PNG shows the
// character where the camera looks (non-background pixels in the middle, floor and sky at the
// edges); bad options are refused in one line with nothing written.
#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "cli_runner.h"
#include "image_check.h"
#include "test_support.h"

namespace fs = std::filesystem;
using biodyn::testing::run_biodyn;
using biodyn::testing::slurp;

TEST_CASE("biodyn render films the walk headless: MP4 frames and a PNG showing the character",
          "[apps][render][slow]") {
  const fs::path dir = biodyn::testing::fresh_dir("render_test", "walk");
  const auto r = run_biodyn(
      "render --scenario walk --duration 2 --fps 10 --size 320x240 -o walk.mp4 --png walk.png "
      "--summary summary.json",
      dir);
  INFO(r.out << r.err);
  REQUIRE(r.exit_code == 0);
  REQUIRE(fs::exists(dir / "walk.mp4"));
  CHECK_FALSE(fs::exists(dir / "walk.mp4.partial.mp4"));
  const nlohmann::json s = nlohmann::json::parse(slurp(dir / "summary.json"));
  CHECK(s["frames"] == 21);  // 0, 0.1, ..., 2.0 s
  CHECK(s["fallen"] == false);
  CHECK(s["simulated_s"].get<double>() == Approx(2.0).margin(0.002));
  CHECK(s["assumption"].get<std::string>().find("honest") != std::string::npos);

  // ffprobe counts the frames ffmpeg wrote.
  const auto probe = biodyn::testing::run_shell(
      "ffprobe -v error -count_frames -select_streams v:0 "
      "-show_entries stream=width,height,nb_read_frames -of csv=p=0 walk.mp4",
      dir);
  CHECK(probe.out.find("320,240,21") != std::string::npos);

  const biodyn::testing::CharacterPixels px =
      biodyn::testing::count_character_pixels((dir / "walk.png").string());
  REQUIRE(px.loaded);
  CHECK(px.width == 320);
  CHECK(px.height == 240);
  const int middle = px.middle, edges = px.edges;
  WARN("character pixels: " << middle << " in the middle third, " << edges << " at the edges");
  // Measured 1378 pixels (the figure ~45% of the frame height, ~25 px wide); half of it at least.
  CHECK(middle > 700);
  CHECK(edges == 0);
}

TEST_CASE("biodyn render --scenario stones walks the paper's stones and draws them",
          "[apps][render][stones]") {
  const fs::path dir = biodyn::testing::fresh_dir("render_test", "stones");
  const auto r = run_biodyn(
      "render --scenario stones --duration 9 --size 640x360 --png stones.png --summary "
      "summary.json",
      dir);
  INFO(r.out << r.err);
  REQUIRE(r.exit_code == 0);
  CHECK(r.out.find("stepping stones: 6 of 6 planned steps walked") != std::string::npos);
  const nlohmann::json s = nlohmann::json::parse(slurp(dir / "summary.json"));
  CHECK(s["fallen"] == false);
  REQUIRE(s.contains("stones"));
  CHECK(s["stones"]["targets_m"] == nlohmann::json({0.60, 0.20, 0.50, 0.16, 0.50, 0.30}));
  REQUIRE(s["stones"]["walked_m"].size() == 6);
  // At 0.7 m/s (the stones' default speed), honest welds: measured RMS 1.6 cm.
  CHECK(s["stones"]["rms_error_m"].get<double>() < 0.03);
  // Green in the frame: the stepped-on stones (and the small weld markers, all there is before
  // the stones begin at 5 s).
  const auto before =
      run_biodyn("render --scenario stones --duration 4.9 --size 640x360 --png before.png", dir);
  REQUIRE(before.exit_code == 0);
  const int green = biodyn::testing::count_green_stone_pixels((dir / "stones.png").string());
  const int green_before = biodyn::testing::count_green_stone_pixels((dir / "before.png").string());
  WARN("green pixels: " << green << " at 9 s, " << green_before << " at 4.9 s (weld markers only)");
  CHECK(green_before >= 0);
  CHECK(green_before < 60);
  CHECK(green > green_before + 200);

  // The stones' options belong to the stones scenario; an empty plan is refused.
  for (const char* args : {"render --scenario walk --steps 0.5 --png x.png",
                           "render --scenario walk --steps-start 3 --png x.png",
                           "render --scenario stones --steps \"\" --png x.png"}) {
    const auto bad = run_biodyn(args, dir);
    INFO(args << ": " << bad.err);
    CHECK(bad.exit_code == 2);
    CHECK(bad.err.find("--steps") != std::string::npos);
    CHECK_FALSE(fs::exists(dir / "x.png"));
  }
}

TEST_CASE("biodyn render --scenario stones --step-offsets films stones in 2D",
          "[apps][render][stones]") {
  const fs::path dir = biodyn::testing::fresh_dir("render_test", "stones_2d");
  const auto r = run_biodyn(
      "render --scenario stones --steps 0.5,0.5 --step-offsets 0.03,-0.03 --duration 7.5 --size "
      "320x240 --png s2d.png --summary s2d.json",
      dir);
  INFO(r.out << r.err);
  REQUIRE(r.exit_code == 0);
  CHECK(r.out.find("stepping stones: 2 of 2 planned steps walked") != std::string::npos);
  const nlohmann::json s = nlohmann::json::parse(slurp(dir / "s2d.json"));
  const nlohmann::json& st = s["stones"];
  CHECK(st["lateral_offsets_m"] == nlohmann::json({0.03, -0.03}));
  REQUIRE(st["target_across_m"].size() == 2);
  REQUIRE(st["walked_across_m"].size() == 2);
  // The first stone: its foot's line moved 3 cm left (towards the stance foot: the right foot
  // swings first), and the foot came down within 2 cm of it across (measured 0.1 cm).
  const double miss =
      std::abs(st["walked_across_m"][0].get<double>() - st["target_across_m"][0].get<double>());
  CHECK(miss < 0.02);
  CHECK(st["definition"].get<std::string>().find("2D") != std::string::npos);
  // Offsets need lengths, one each, and the stones scenario.
  for (const char* args :
       {"render --scenario stones --step-offsets 0.1 --png x.png",
        "render --scenario stones --steps 0.5,0.5 --step-offsets 0.1 --png x.png",
        "render --scenario walk --step-offsets 0.1 --png x.png"}) {
    const auto bad = run_biodyn(args, dir);
    INFO(args << ": " << bad.err);
    CHECK(bad.exit_code == 2);
    const bool names_offsets = bad.err.find("step offsets") != std::string::npos ||
                               bad.err.find("--step-offsets") != std::string::npos;
    CHECK(names_offsets);
    CHECK_FALSE(fs::exists(dir / "x.png"));
  }
}

TEST_CASE(
    "biodyn render --track films a captured motion tracked by the controllers and reports the fall",
    "[apps][render][track][slow]") {
  const fs::path dir = biodyn::testing::fresh_dir("render_test", "track");
  const std::string bvh =
      biodyn::testing::source_dir() + "/../shared/data/mocap/bvh/cmu_131_01_start_walk_stop.bvh";
  const auto r = run_biodyn(
      "render --scenario mocap --motion " + bvh +
          " --track --duration 3 --size 320x240 --png tracked.png --summary summary.json",
      dir);
  INFO(r.out << r.err);
  REQUIRE(r.exit_code == 0);
  CHECK(r.out.find("tracked by the joint controllers") != std::string::npos);
  CHECK(r.out.find("tracking: joint error RMS") != std::string::npos);
  const nlohmann::json s = nlohmann::json::parse(slurp(dir / "summary.json"));
  REQUIRE(s.contains("tracking"));
  const nlohmann::json& t = s["tracking"];
  CHECK(t["balance_feedback"] == true);
  CHECK(t["motion_length_s"].get<double>() > 8.0);
  // The whole clip (standing with retargeted feet that slide, then a walk): the body falls
  // within the first second (README); the fall is reported, with its time.
  CHECK(s["fallen"] == t["fell_at_s"].is_number());
  CHECK(t["kept_up_through_motion"] == false);
  CHECK(t["joint_error_rms_deg"].get<double>() > 0);

  // The clip's walk (4.0 to 6.2 s of it, about four steps): kept up to its end (measured: joints
  // 8.9 deg RMS; the body falls 0.4 s after, holding the last frame mid-stride).
  const auto walk =
      run_biodyn("render --scenario mocap --motion " + bvh +
                     " --motion-from 4.0 --motion-to 6.2 --track --duration 2.2 --size 320x240 "
                     "--png walk.png --summary walk.json",
                 dir);
  INFO(walk.out << walk.err);
  REQUIRE(walk.exit_code == 0);
  CHECK(walk.out.find("(its part from 4 s to 6.2 s)") != std::string::npos);
  const nlohmann::json w = nlohmann::json::parse(slurp(dir / "walk.json"));
  WARN("the clip's walk: " << w["tracking"].dump());
  CHECK(w["tracking"]["motion_length_s"].get<double>() == Approx(2.2).margin(0.02));
  CHECK(w["tracking"]["kept_up_through_motion"] == true);
  CHECK(w["fallen"] == false);

  const auto bad = run_biodyn("render --scenario walk --track --png x.png", dir);
  CHECK(bad.exit_code == 2);
  CHECK(bad.err.find("only the mocap scenario") != std::string::npos);
  const auto loose =
      run_biodyn("render --scenario mocap --motion " + bvh + " --track-open-loop --png x.png", dir);
  CHECK(loose.exit_code == 2);
  CHECK(loose.err.find("only with --track") != std::string::npos);
  const auto part = run_biodyn("render --scenario walk --motion-from 2 --png x.png", dir);
  CHECK(part.exit_code == 2);
  CHECK(part.err.find("--motion-from: only --scenario mocap") != std::string::npos);
  CHECK_FALSE(fs::exists(dir / "x.png"));
}

TEST_CASE("biodyn render --muscles on draws the muscles' paths coloured by activation",
          "[apps][render][muscles]") {
  const fs::path dir = biodyn::testing::fresh_dir("render_test", "muscles");
  // 0.6 s into the walk, early in the first step, several muscles are near full activation
  // (red); a close camera makes the paths a few pixels wide.
  const std::string frame = "--scenario walk --duration 0.6 --size 640x480 --distance 2.0 ";
  const auto on =
      run_biodyn("render " + frame + "--muscles on --png on.png --summary on.json", dir);
  INFO(on.out << on.err);
  REQUIRE(on.exit_code == 0);
  CHECK(on.out.find("Hill muscles") != std::string::npos);
  CHECK(on.out.find("muscles:  36") != std::string::npos);
  const nlohmann::json s = nlohmann::json::parse(slurp(dir / "on.json"));
  REQUIRE(s.contains("muscles"));
  CHECK(s["muscles"]["muscles"].size() == 36);  // 18 per leg
  CHECK(s["muscles"]["per_joint"].contains("hip_l"));
  const auto off = run_biodyn("render " + frame + "--png off.png", dir);
  REQUIRE(off.exit_code == 0);
  const int red = biodyn::testing::count_active_muscle_pixels((dir / "on.png").string());
  const int red_off = biodyn::testing::count_active_muscle_pixels((dir / "off.png").string());
  WARN("active-muscle red pixels: " << red << " with muscles, " << red_off << " without");
  // Measured 929 at 640x480; without muscles nothing in the frame is that red.
  CHECK(red > 200);
  CHECK(red_off == 0);

  // The muscle options are checked before any work; a kinematic playback has no muscles.
  const std::string bvh =
      biodyn::testing::source_dir() + "/../shared/data/mocap/bvh/cmu_131_01_start_walk_stop.bvh";
  for (const std::string& args :
       {std::string("render --muscles on --tendons springy --png x.png"),
        std::string("render --tendons rigid --png x.png"),
        "render --scenario mocap --motion " + bvh + " --muscles on --png x.png"}) {
    const auto bad = run_biodyn(args, dir);
    INFO(args << ": " << bad.err);
    CHECK(bad.exit_code == 2);
    CHECK_FALSE(fs::exists(dir / "x.png"));
  }
}

TEST_CASE("biodyn render refuses bad options and writes nothing", "[apps][render]") {
  const fs::path dir = biodyn::testing::fresh_dir("render_test", "bad");
  for (const char* args :
       {"render --scenario dance -o v.mp4", "render --size 321x240 -o v.mp4",
        "render --size big -o v.mp4", "render --duration 0 -o v.mp4", "render --scenario walk"}) {
    const auto r = run_biodyn(args, dir);
    INFO(args << ": " << r.err);
    CHECK(r.exit_code == 2);
    CHECK(r.err.find("error") != std::string::npos);
    CHECK_FALSE(fs::exists(dir / "v.mp4"));
  }
}

TEST_CASE("biodyn render plays an IK motion on the body the IK solved, refuses another",
          "[apps][render][mocap]") {
  // Issue 24: a motion carries its body in its header; on 777bb0d render and view put it on
  // the default 1.8 m body without a word.
  const fs::path dir = biodyn::testing::fresh_dir("render_test", "ik_body");
  const std::string c3d =
      biodyn::testing::source_dir() + "/../shared/data/mocap/c3d/opensim_walking5.c3d";
  const auto ik = run_biodyn("mocap ik --c3d '" + c3d + "' -o motion.csv --json ik.json", dir);
  REQUIRE(ik.exit_code == 0);
  const double ik_height =
      nlohmann::json::parse(slurp(dir / "ik.json"))["scaling"]["height_m"].get<double>();
  const auto r = run_biodyn(
      "render --scenario mocap --motion motion.csv --duration 0.1 --size 160x120 --png f.png "
      "--summary s.json",
      dir);
  INFO(r.out << r.err);
  REQUIRE(r.exit_code == 0);
  const auto s = nlohmann::json::parse(slurp(dir / "s.json"));
  CHECK(s["character"]["height_m"].get<double>() == Approx(ik_height).epsilon(1e-9));
  const auto other = run_biodyn(
      "render --scenario mocap --motion motion.csv --height 1.6 --duration 0.1 --size 160x120 "
      "--png g.png",
      dir);
  CHECK(other.exit_code == 2);
  CHECK(other.err.find("retarget") != std::string::npos);
  CHECK_FALSE(fs::exists(dir / "g.png"));
}
