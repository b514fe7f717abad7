// BVH reader, writer and forward kinematics on small hand-written files: conventions checked
// against hand-computed poses, and every malformed input reported as a ParseError on its line.

#include <algorithm>
#include <cmath>
#include <fstream>
#include <random>
#include <sstream>

#include "biodyn/mocap_io/bvh.h"
#include "biodyn/mocap_io/errors.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/units.h"
#include "test_support.h"

using namespace biodyn;
using Catch::Matchers::Contains;
using mocap_io::BvhChannel;
using mocap_io::BvhMotion;
using mocap_io::BvhUnits;
using mocap_io::ParseError;
using mocap_io::UpAxis;

namespace {

constexpr double kExact = 1e-12;  // hand-computed poses: exact up to rounding
/// File axes and units unchanged, so expected positions are the hand-computed file coordinates.
const BvhUnits kFileUnits{1.0, UpAxis::kZ};

/// Two joints and an end site; every error case below edits one line of it (line numbers in
/// the comments on the right).
const std::string kBase =
    "HIERARCHY\n"                                                                 // 1
    "ROOT Hips\n"                                                                 // 2
    "{\n"                                                                         // 3
    "  OFFSET 0 0 0\n"                                                            // 4
    "  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\n"  // 5
    "  JOINT Chest\n"                                                             // 6
    "  {\n"                                                                       // 7
    "    OFFSET 0 1 0\n"                                                          // 8
    "    CHANNELS 3 Zrotation Xrotation Yrotation\n"                              // 9
    "    End Site\n"                                                              // 10
    "    {\n"                                                                     // 11
    "      OFFSET 0 1 0\n"                                                        // 12
    "    }\n"                                                                     // 13
    "  }\n"                                                                       // 14
    "}\n"                                                                         // 15
    "MOTION\n"                                                                    // 16
    "Frames: 2\n"                                                                 // 17
    "Frame Time: 0.01\n"                                                          // 18
    "0 0 0 0 0 0 0 0 0\n"                                                         // 19
    "1 2 3 4 5 6 7 8 9\n";                                                        // 20

/// `text` with its line `n` (1-based) replaced by `line` (which may hold several lines).
std::string replace_line(const std::string& text, int n, const std::string& line) {
  std::istringstream in(text);
  std::string out, l;
  for (int i = 1; std::getline(in, l); ++i) out += (i == n ? line : l) + "\n";
  return out;
}

/// A one-joint file whose end site sits at `child` in the joint's frame.
std::string one_joint(const std::string& channels, const std::string& values,
                      const std::string& child = "0 0 1") {
  const int n = static_cast<int>(std::count(channels.begin(), channels.end(), ' ')) + 1;
  return "HIERARCHY\nROOT R\n{\n OFFSET 0 0 0\n CHANNELS " + std::to_string(n) + " " + channels +
         "\n End Site\n {\n  OFFSET " + child + "\n }\n}\nMOTION\nFrames: 1\nFrame Time: 0.1\n" +
         values + "\n";
}

/// Elementary rotations written out (not through Eigen::AngleAxis, which bvh.cc uses).
Eigen::Matrix3d rx(double a) {
  Eigen::Matrix3d r;
  r << 1, 0, 0, 0, std::cos(a), -std::sin(a), 0, std::sin(a), std::cos(a);
  return r;
}
Eigen::Matrix3d ry(double a) {
  Eigen::Matrix3d r;
  r << std::cos(a), 0, std::sin(a), 0, 1, 0, -std::sin(a), 0, std::cos(a);
  return r;
}
Eigen::Matrix3d rz(double a) {
  Eigen::Matrix3d r;
  r << std::cos(a), -std::sin(a), 0, std::sin(a), std::cos(a), 0, 0, 0, 1;
  return r;
}

Eigen::Vector3d position(const BvhMotion& m, const std::string& joint, int f = 0,
                         const BvhUnits& units = kFileUnits) {
  const int j = m.find(joint);
  REQUIRE(j >= 0);
  return mocap_io::forward_kinematics(m, f, units).positions_W.col(j);
}

/// parse_bvh(text) throws a ParseError on `line` whose expected/found contain the given words.
void check_parse_error(const std::string& text, long line, const std::string& expected,
                       const std::string& found) {
  INFO("text:\n" << text);
  try {
    mocap_io::parse_bvh(text, "test.bvh");
    FAIL("no ParseError");
  } catch (const ParseError& e) {
    INFO("what(): " << e.what());
    CHECK(e.file() == "test.bvh");
    CHECK(e.where() == ParseError::line(line));
    CHECK_THAT(e.expected(), Contains(expected));
    CHECK_THAT(e.found(), Contains(found));
    const std::string what = e.what();
    CHECK_THAT(what, Contains("test.bvh: line " + std::to_string(line) + ": expected "));
    CHECK_THAT(what, Contains(", found "));
  }
}

/// True if the text parses or throws ParseError; anything else (another exception) fails.
bool parses_or_parse_error(const std::string& text) {
  try {
    mocap_io::parse_bvh(text, "fuzz.bvh");
    return true;
  } catch (const ParseError&) {
    return false;
  }
}

}  // namespace

TEST_CASE("BVH: the base file parses into joints, channels and values", "[bvh]") {
  const BvhMotion m = mocap_io::parse_bvh(kBase, "base.bvh");
  REQUIRE(m.joints.size() == 3);
  CHECK(m.joints[0].name == "Hips");
  CHECK(m.joints[0].parent == -1);
  CHECK(m.joints[0].first_channel == 0);
  CHECK(m.joints[1].name == "Chest");
  CHECK(m.joints[1].parent == 0);
  CHECK(m.joints[1].first_channel == 6);
  CHECK(m.joints[1].channels == std::vector<BvhChannel>{BvhChannel::kZrotation,
                                                        BvhChannel::kXrotation,
                                                        BvhChannel::kYrotation});
  CHECK(m.joints[2].name == "Chest_end");
  CHECK(m.joints[2].end_site);
  CHECK(m.joints[2].parent == 1);
  CHECK(m.joints[2].offset == Eigen::Vector3d(0, 1, 0));
  CHECK(m.frame_count() == 2);
  CHECK(m.channel_count() == 9);
  CHECK(m.frame_time_s == 0.01);
  CHECK(m.values(1, 0) == 1);
  CHECK(m.values(1, 8) == 9);
  CHECK(m.find("Chest") == 1);
  CHECK(m.find("Neck") == -1);
  CHECK(std::string(mocap_io::to_string(BvhChannel::kYrotation)) == "Yrotation");
}

TEST_CASE("BVH: a root without position channels sits at its OFFSET", "[bvh]") {
  const BvhMotion m = mocap_io::parse_bvh(
      "HIERARCHY\nROOT A\n{\n OFFSET 1 2 3\n CHANNELS 1 Zrotation\n JOINT B\n {\n  OFFSET 2 0 0\n"
      "  CHANNELS 0\n }\n}\nMOTION\nFrames: 2\nFrame Time: 0.5\n0\n90\n",
      "t.bvh");
  CHECK(m.channel_count() == 1);
  CHECK(m.joints[1].channels.empty());
  CHECK((position(m, "A", 0) - Eigen::Vector3d(1, 2, 3)).norm() < kExact);
  CHECK((position(m, "A", 1) - Eigen::Vector3d(1, 2, 3)).norm() < kExact);
  CHECK((position(m, "B", 0) - Eigen::Vector3d(3, 2, 3)).norm() < kExact);
  // 90 deg about z turns B's offset +x into +y.
  CHECK((position(m, "B", 1) - Eigen::Vector3d(1, 4, 3)).norm() < kExact);
}

TEST_CASE("BVH: rotations compose intrinsically in the listed order", "[bvh]") {
  SECTION("one axis: 90 deg about z moves +y to -x, about x moves +y to +z") {
    CHECK((position(mocap_io::parse_bvh(one_joint("Zrotation", "90", "0 1 0"), "t"), "R_end") -
           Eigen::Vector3d(-1, 0, 0))
              .norm() < kExact);
    CHECK((position(mocap_io::parse_bvh(one_joint("Xrotation", "90", "0 1 0"), "t"), "R_end") -
           Eigen::Vector3d(0, 0, 1))
              .norm() < kExact);
  }
  SECTION("the same angles in XYZ and ZXY order put the child in different places") {
    // ZXY, Z = 90, X = 90: R = Rz Rx; Rx takes +z to -y, then Rz takes -y to +x.
    const BvhMotion zxy =
        mocap_io::parse_bvh(one_joint("Zrotation Xrotation Yrotation", "90 90 0"), "t");
    CHECK((position(zxy, "R_end") - Eigen::Vector3d(1, 0, 0)).norm() < kExact);
    // XYZ, X = 90, Z = 90: R = Rx Rz; Rz leaves +z alone, then Rx takes +z to -y.
    const BvhMotion xyz =
        mocap_io::parse_bvh(one_joint("Xrotation Yrotation Zrotation", "90 0 90"), "t");
    CHECK((position(xyz, "R_end") - Eigen::Vector3d(0, -1, 0)).norm() < kExact);
    // XYZ, X = 90, Y = 90 on a +x child: Ry takes +x to -z, Rx takes -z to +y.
    const BvhMotion xy =
        mocap_io::parse_bvh(one_joint("Xrotation Yrotation Zrotation", "90 90 0", "1 0 0"), "t");
    CHECK((position(xy, "R_end") - Eigen::Vector3d(0, 1, 0)).norm() < kExact);
  }
  SECTION("all six orders equal the product of elementary rotations, seeded random angles") {
    std::mt19937 rng(20240531);
    std::uniform_real_distribution<double> angle_deg(-180.0, 180.0);
    const std::vector<std::string> names{"Xrotation", "Yrotation", "Zrotation"};
    std::vector<int> order{0, 1, 2};
    do {
      const double a[3] = {angle_deg(rng), angle_deg(rng), angle_deg(rng)};
      std::string channels, values;
      Eigen::Matrix3d expected = Eigen::Matrix3d::Identity();
      for (int k = 0; k < 3; ++k) {
        channels += (k ? " " : "") + names[order[k]];
        std::ostringstream v;
        v.precision(17);
        v << a[k];
        values += (k ? " " : "") + v.str();
        const double rad = a[k] * kPi / 180.0;
        expected *= order[k] == 0 ? rx(rad) : order[k] == 1 ? ry(rad) : rz(rad);
      }
      INFO(channels << " = " << values);
      const BvhMotion m = mocap_io::parse_bvh(one_joint(channels, values), "t");
      CHECK((mocap_io::local_rotation(m, 0, 0) - expected).cwiseAbs().maxCoeff() < kExact);
      CHECK((mocap_io::forward_kinematics(m, 0, kFileUnits).rotations_W[1] - expected)
                .cwiseAbs()
                .maxCoeff() < kExact);
    } while (std::next_permutation(order.begin(), order.end()));
  }
}

TEST_CASE("BVH: position channels on a non-root joint replace its OFFSET", "[bvh]") {
  const std::string text =
      "HIERARCHY\n"
      "ROOT R\n{\n OFFSET 0 0 0\n CHANNELS 1 Zrotation\n"
      " JOINT J\n {\n  OFFSET 5 6 7\n  CHANNELS 2 Xposition Zposition\n"
      "  End Site\n  {\n   OFFSET 0 0 1\n  }\n }\n"
      " JOINT K\n {\n  OFFSET 5 6 7\n  CHANNELS 2 Zrotation Xposition\n"
      "  End Site\n  {\n   OFFSET 1 0 0\n  }\n }\n"
      "}\nMOTION\nFrames: 1\nFrame Time: 0.1\n90 1 2 90 3\n";
  const BvhMotion m = mocap_io::parse_bvh(text, "t.bvh");
  // J in R's frame: x and z from the channels, y from the OFFSET: (1, 6, 2); R's 90 deg about
  // z takes it to (-6, 1, 2).
  CHECK((position(m, "J") - Eigen::Vector3d(-6, 1, 2)).norm() < kExact);
  CHECK((position(m, "J_end") - Eigen::Vector3d(-6, 1, 3)).norm() < kExact);
  // K lists its position channel after its rotation: the translation is still in the parent's
  // frame, (3, 6, 7) -> (-6, 3, 7); K's own 90 deg about z then turns its +x child to +y, and
  // R's turns that to -x.
  CHECK((position(m, "K") - Eigen::Vector3d(-6, 3, 7)).norm() < kExact);
  CHECK((position(m, "K_end") - Eigen::Vector3d(-7, 3, 7)).norm() < kExact);
}

TEST_CASE("BVH: several roots, each with its own channels", "[bvh]") {
  const std::string text =
      "HIERARCHY\n"
      "ROOT A\n{\n OFFSET 1 0 0\n CHANNELS 3 Xposition Yposition Zposition\n"
      " End Site\n {\n  OFFSET 0 1 0\n }\n}\n"
      "ROOT B\n{\n OFFSET 0 0 0\n CHANNELS 1 Xrotation\n"
      " End Site\n {\n  OFFSET 0 1 0\n }\n}\n"
      "MOTION\nFrames: 1\nFrame Time: 0.1\n10 20 30 90\n";
  const BvhMotion m = mocap_io::parse_bvh(text, "t.bvh");
  REQUIRE(m.joints.size() == 4);
  CHECK(m.joints[2].name == "B");
  CHECK(m.joints[2].parent == -1);
  CHECK(m.joints[2].first_channel == 3);
  CHECK((position(m, "A") - Eigen::Vector3d(10, 20, 30)).norm() < kExact);
  CHECK((position(m, "A_end") - Eigen::Vector3d(10, 21, 30)).norm() < kExact);
  CHECK((position(m, "B") - Eigen::Vector3d(0, 0, 0)).norm() < kExact);
  CHECK((position(m, "B_end") - Eigen::Vector3d(0, 0, 1)).norm() < kExact);
}

TEST_CASE("BVH: end sites are named after their parent, words after End Site ignored", "[bvh]") {
  const std::string text =
      "HIERARCHY\nROOT Hand\n{\n OFFSET 0 0 0\n CHANNELS 0\n"
      " End Site thumb\n {\n  OFFSET 1 0 0\n }\n"
      " End Site\n {\n  OFFSET 0 1 0\n }\n"
      "}\nMOTION\nFrames: 1\nFrame Time: 0.1\n";
  const BvhMotion m = mocap_io::parse_bvh(text, "t.bvh");
  REQUIRE(m.joints.size() == 3);
  for (int j : {1, 2}) {
    CHECK(m.joints[j].name == "Hand_end");
    CHECK(m.joints[j].end_site);
    CHECK(m.joints[j].parent == 0);
    CHECK(m.joints[j].channels.empty());
  }
  CHECK(m.joints[2].offset == Eigen::Vector3d(0, 1, 0));
  CHECK(m.channel_count() == 0);
  CHECK(m.frame_count() == 1);
}

TEST_CASE("BVH: CRLF, tabs, blank lines, a BOM, case and names with spaces are tolerated",
          "[bvh]") {
  std::string messy;
  for (char c : kBase) messy += c == '\n' ? std::string("  \t\r\n") : std::string(1, c);
  messy = "\xEF\xBB\xBF" + replace_line(messy, 17, "\r\n\t frames:   2 \r");
  messy = replace_line(messy, 10, "\tend  site\r");
  const BvhMotion a = mocap_io::parse_bvh(kBase, "a");
  const BvhMotion b = mocap_io::parse_bvh(messy, "b");
  REQUIRE(b.joints.size() == a.joints.size());
  CHECK(b.values == a.values);
  CHECK(b.joints[1].channels == a.joints[1].channels);

  const BvhMotion spaced = mocap_io::parse_bvh(
      replace_line(replace_line(kBase, 7, ""), 6, "  JOINT  Upper Chest {"), "c");
  CHECK(spaced.joints[1].name == "Upper Chest");
  // Braces need no whitespace around them.
  const BvhMotion tight = mocap_io::parse_bvh(
      replace_line(replace_line(replace_line(replace_line(kBase, 15, ""), 14, "}}"), 3, ""), 2,
                   "ROOT Hips{"),
      "d");
  CHECK(tight.joints.size() == 3);
  CHECK(spaced.joints[2].name == "Upper Chest_end");
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "BVH: units and up axis map the file to biodyn's world", "[bvh]") {
  const BvhMotion m = mocap_io::parse_bvh(
      "HIERARCHY\nROOT A\n{\n OFFSET 100 200 300\n CHANNELS 1 Yrotation\n End Site\n {\n"
      "  OFFSET 0 0 10\n }\n}\nMOTION\nFrames: 1\nFrame Time: 0.1\n90\n",
      "t.bvh");
  const BvhUnits cm_y_up{0.01, UpAxis::kY};
  // File (x, y, z) -> world (z, x, y), cm -> m.
  CHECK((position(m, "A", 0, cm_y_up) - Eigen::Vector3d(3, 1, 2)).norm() < kExact);
  // 90 deg about the file's up axis turns the +z child to +x: world +y.
  CHECK((position(m, "A_end", 0, cm_y_up) - Eigen::Vector3d(3, 1.1, 2)).norm() < kExact);
  const Eigen::Matrix3d c = mocap_io::file_to_world(UpAxis::kY);
  CHECK(c * Eigen::Vector3d::UnitY() == Eigen::Vector3d::UnitZ());
  CHECK(c * Eigen::Vector3d::UnitZ() == Eigen::Vector3d::UnitX());
  CHECK(c.determinant() == 1.0);
  CHECK(mocap_io::file_to_world(UpAxis::kZ) == Eigen::Matrix3d::Identity());
  const mocap_io::BvhPose pose = mocap_io::forward_kinematics(m, 0, cm_y_up);
  CHECK((pose.rotations_W[0] - c * ry(kPi / 2)).cwiseAbs().maxCoeff() < kExact);
  CHECK_THROWS_AS(mocap_io::forward_kinematics(m, 0, BvhUnits{0.0, UpAxis::kY}),
                  sim::InvalidArgument);
  CHECK_THROWS_AS(mocap_io::forward_kinematics(m, 1, kFileUnits), sim::InvalidArgument);
  CHECK_THROWS_AS(mocap_io::local_rotation(m, 2, 0), sim::InvalidArgument);
  CHECK_THROWS_AS(mocap_io::local_rotation(m, 0, -1), sim::InvalidArgument);
}

TEST_CASE("BVH: every malformed input is a ParseError naming its line", "[bvh]") {
  struct Case {
    int line;                 // line of kBase to replace
    std::string replacement;  // may hold several lines, or be empty
    long error_line;
    std::string expected, found;
  };
  const std::vector<Case> cases = {
      // Unknown keywords and missing braces.
      {1, "HIERARCHIE", 1, "HIERARCHY", "'HIERARCHIE'"},
      {4, "  OFSET 0 0 0", 4, "OFFSET", "'OFSET'"},
      {6, "  JOIN Chest", 6, "JOINT, End Site or '}'", "'JOIN'"},
      {10, "    End Sight", 10, "Site", "'Sight'"},
      {3, "", 4, "'{'", "'OFFSET'"},
      {14, "", 16, "JOINT, End Site or '}' in joint 'Hips'", "'MOTION'"},
      {15, "}\n}", 16, "ROOT or MOTION", "'}'"},
      {16, "MOTIONS", 16, "ROOT or MOTION", "'MOTIONS'"},
      {2, "ROOT", 2, "a joint name after ROOT", "end of line"},
      {2, "ROOT {", 2, "a joint name after ROOT", "'{'"},
      {12, "      OFFSET 0 1 0 CHANNELS 0", 12, "'}' closing the End Site", "'CHANNELS'"},
      {12, "      OFFSET 0 1", 13, "a number (OFFSET of joint 'Chest_end')", "'}'"},
      {8, "    OFFSET 0 one 0", 8, "a number", "'one'"},
      {8, "    OFFSET 0 1 0 0", 8, "CHANNELS", "'0'"},
      // Channels.
      {9, "    CHANNELS 3 Zrotation Xrot Yrotation", 9, "a channel name", "'Xrot'"},
      {9, "    CHANNELS 3 Zrotation Xrotation", 10, "a channel name", "'End'"},
      {9, "    CHANNELS 2 Zrotation Xrotation Yrotation", 9, "end of line after the 2 channels",
       "'Yrotation'"},
      {9, "    CHANNELS 7 Zrotation Xrotation Yrotation", 9, "a channel count from 0 to 6", "'7'"},
      {9, "    CHANNELS -1", 9, "a channel count from 0 to 6", "'-1'"},
      {9, "    CHANNELS three Zrotation", 9, "a channel count", "'three'"},
      {9, "    CHANNELS 3 Zrotation Zrotation Yrotation", 9, "a channel not yet listed",
       "'Zrotation'"},
      {9, "    OFFSET 0 0 0", 9, "CHANNELS", "'OFFSET'"},
      // Frame count and frame time.
      {17, "Frames: 0", 17, "a positive whole number of frames", "'0'"},
      {17, "Frames: -2", 17, "a positive whole number of frames", "'-2'"},
      {17, "Frames: 2.5", 17, "a positive whole number of frames", "'2.5'"},
      {17, "Frames: 99999999999999999999", 17, "a positive whole number", "'9999"},
      {17, "Frames:", 18, "a positive whole number of frames", "'Frame'"},
      {17, "Frame Time: 0.01", 17, "Frames:", "'Frame'"},
      {18, "Frame Time: 0", 18, "a positive frame time", "'0'"},
      {18, "Frame Time: -0.01", 18, "a positive frame time", "'-0.01'"},
      {18, "Frame Time: fast", 18, "a positive frame time", "'fast'"},
      {18, "Frame Time: inf", 18, "a positive frame time", "'inf'"},
      {18, "FrameTime: 0.01", 18, "Frame", "'FrameTime:'"},
      {18, "Frame Time: 0.01 0 0 0", 18, "end of line after the frame time", "'0'"},
      // Frames.
      {19, "0 0 0 0 0 0 0 0", 19, "9 values (frame 1 of 2", "8 values"},
      {20, "1 2 3 4 5 6 7 8 9 10", 20, "9 values (frame 2 of 2", "10 values"},
      {20, "1 2 3 4 x 6 7 8 9", 20, "frame 2 of 2, one frame per line, value 5: Hips Xrotation",
       "'x'"},
      {20, "1 2 3 4 5 6 7 8 nan", 20, "a number", "'nan'"},
      {20, "1 2 3 4 5 6 7 8 1e999", 20, "a number", "'1e999'"},
      {20, "1,2 3 4 5 6 7 8 9 10", 20, "a number", "'1,2'"},
      {20, "", 20, "2 frames", "end of file after 1 frame"},
      {20, "1 2 3 4 5 6 7 8 9\n1 2 3 4 5 6 7 8 9", 21, "end of file after the 2 frames", "'1'"},
  };
  for (const Case& c : cases) {
    INFO("line " << c.line << " -> \"" << c.replacement << "\"");
    check_parse_error(replace_line(kBase, c.line, c.replacement), c.error_line, c.expected,
                      c.found);
  }
  // A blank line among the frames is skipped, so a file missing frame 1's line is one frame
  // short at its end.
  check_parse_error(replace_line(kBase, 19, ""), 20, "2 frames", "end of file after 1 frame");
}

TEST_CASE("BVH: empty, unfinished and headless files are ParseErrors", "[bvh]") {
  check_parse_error("", 1, "HIERARCHY", "end of file");
  check_parse_error("\n\n   \r\n", 3, "HIERARCHY", "end of file");
  check_parse_error("HIERARCHY\n", 1, "ROOT", "end of file");
  check_parse_error("MOTION\nFrames: 1\n", 1, "HIERARCHY", "'MOTION'");
  std::string hierarchy_only;
  std::istringstream in(kBase);
  std::string l;
  for (int i = 1; i <= 15 && std::getline(in, l); ++i) hierarchy_only += l + "\n";
  check_parse_error(hierarchy_only, 15, "ROOT or MOTION", "end of file");
  check_parse_error(std::string("HIERARCHY\nROOT \x01\x02\n"), 2, "'{'", "end of file");
}

TEST_CASE("BVH: a truncated CMU file is always a ParseError, never a partial motion",
          "[bvh][regression]") {
  std::ifstream in(
      biodyn::testing::source_dir() + "/../shared/data/mocap/bvh/cmu_131_01_start_walk_stop.bvh",
      std::ios::binary);
  REQUIRE(in);
  std::stringstream buffer;
  buffer << in.rdbuf();
  const std::string text = buffer.str();
  REQUIRE(mocap_io::parse_bvh(text, "full").frame_count() == 994);
  // Cuts inside the last line can leave a valid file (a shortened last number is a number);
  // every shorter cut must fail.
  const std::size_t last_line = text.rfind('\n', text.size() - 2) + 1;
  const std::size_t header_end = text.find("Frame Time:") + 40;
  std::vector<std::size_t> cuts;
  for (std::size_t n = 0; n < header_end; n += 7) cuts.push_back(n);  // all through the header
  std::mt19937 rng(131);
  std::uniform_int_distribution<std::size_t> anywhere(header_end, last_line - 1);
  for (int k = 0; k < 100; ++k) cuts.push_back(anywhere(rng));
  for (std::size_t pos = text.find('\n', header_end); pos < last_line && cuts.size() < 220;
       pos = text.find('\n', pos + 50000)) {
    cuts.push_back(pos + 1);  // whole lines: a clean cut between frames
  }
  cuts.push_back(last_line - 1);
  cuts.push_back(last_line);
  for (std::size_t n : cuts) {
    INFO("cut at byte " << n << " of " << text.size());
    CHECK_THROWS_AS(mocap_io::parse_bvh(text.substr(0, n), "cut.bvh"), ParseError);
  }
  // The message of a cut between frames says how many frames were expected and found.
  const std::size_t after_10 = [&] {
    std::size_t p = text.find("Frame Time:");
    for (int k = 0; k < 11; ++k) p = text.find('\n', p) + 1;
    return p;
  }();
  try {
    mocap_io::parse_bvh(text.substr(0, after_10), "cut.bvh");
    FAIL("no ParseError");
  } catch (const ParseError& e) {
    CHECK(e.where() == ParseError::line(197));
    CHECK(e.expected() == "994 frames (from Frames:)");
    CHECK(e.found() == "end of file after 10 frames");
  }
  // A cut inside a frame's line says how many values that line has.
  const std::size_t mid_11 = text.find(' ', after_10 + 100);
  try {
    mocap_io::parse_bvh(text.substr(0, mid_11), "cut.bvh");
    FAIL("no ParseError");
  } catch (const ParseError& e) {
    CHECK(e.where() == ParseError::line(198));
    CHECK_THAT(e.expected(), Contains("96 values (frame 11 of 994"));
    CHECK_THAT(e.found(), Contains(" values"));
    CHECK(e.found() != "96 values");
  }
}

namespace {

/// A chain of `depth` joints, each nested in the one before (joint k's JOINT on line 4k + 2).
std::string nested_bvh(int depth) {
  std::string text = "HIERARCHY\nROOT j0\n{\nOFFSET 0 0 0\nCHANNELS 0\n";
  for (int k = 1; k < depth; ++k) {
    text += "JOINT j" + std::to_string(k) + "\n{\nOFFSET 0 1 0\nCHANNELS 0\n";
  }
  return text + std::string(static_cast<std::size_t>(depth), '}') +
         "\nMOTION\nFrames: 1\nFrame Time: 1\n";
}

}  // namespace

TEST_CASE("BVH: joints nest kMaxBvhDepth deep, one deeper is a ParseError on its line", "[bvh]") {
  constexpr int kDepth = mocap_io::kMaxBvhDepth;
  std::string text = nested_bvh(kDepth);
  const BvhMotion m = mocap_io::parse_bvh(text, "deep.bvh");
  REQUIRE(m.joints.size() == kDepth);
  CHECK(m.joints.back().parent == kDepth - 2);
  CHECK(position(m, "j" + std::to_string(kDepth - 1)).y() == kDepth - 1);
  CHECK(mocap_io::parse_bvh(mocap_io::format_bvh(m), "deep.bvh").joints.size() == kDepth);
  // One brace short: the last '}' is missing when MOTION comes.
  text.erase(text.find('}'), 1);
  check_parse_error(text, 4 * kDepth + 3, "JOINT, End Site or '}' in joint 'j0'", "'MOTION'");
  // One joint deeper, an End Site deeper, and the 200,000 levels that once took 7.9 GB.
  check_parse_error(nested_bvh(kDepth + 1), 4 * kDepth + 2,
                    "joints nested at most " + std::to_string(kDepth) + " deep",
                    "'JOINT' at depth " + std::to_string(kDepth + 1) + ", inside 'j255'");
  std::string end_site = nested_bvh(kDepth);
  end_site.insert(end_site.find('}'), "End Site\n{\nOFFSET 0 1 0\n}\n");
  check_parse_error(end_site, 4 * kDepth + 2, "nested at most", "'End' at depth 257");
  check_parse_error(nested_bvh(200000), 4 * kDepth + 2, "nested at most", "depth 257");
}

TEST_CASE("BVH: format_bvh refuses a hand-built hierarchy deeper than kMaxBvhDepth", "[bvh]") {
  BvhMotion m = mocap_io::parse_bvh(nested_bvh(mocap_io::kMaxBvhDepth), "deep.bvh");
  mocap_io::BvhJoint end;
  end.name = "tip";
  end.end_site = true;
  end.parent = static_cast<int>(m.joints.size()) - 1;
  m.joints.push_back(end);
  CHECK_THROWS_WITH(mocap_io::format_bvh(m), Contains("nested 257 deep"));
}

TEST_CASE("BVH: joint names that are not UTF-8 are read as Latin-1", "[bvh]") {
  const std::string hufte_latin1 = std::string("H\xFC") + "fte";  // "Hüfte" in Latin-1
  const std::string hufte_utf8 = std::string("H\xC3\xBC") + "fte";
  const BvhMotion m = mocap_io::parse_bvh(
      replace_line(replace_line(kBase, 2, "ROOT " + hufte_latin1), 6, "  JOINT Br\xC3\xBCst"),
      "latin1.bvh");
  CHECK(m.joints[0].name == hufte_utf8);
  CHECK(m.joints[1].name == "Br\xC3\xBCst");  // UTF-8 "Brüst": kept
  CHECK(m.joints[2].name == "Br\xC3\xBCst_end");
  CHECK(m.transcoded_names == 1);
  CHECK(mocap_io::parse_bvh(kBase, "base.bvh").transcoded_names == 0);
}

TEST_CASE("BVH: mutated files parse or throw ParseError, nothing else", "[bvh]") {
  std::mt19937 rng(5);
  const std::string alphabet = " \n\t{}-.0123456789eXYZrotaionpsJOINTEndSite:";
  std::uniform_int_distribution<std::size_t> pick(0, alphabet.size() - 1);
  int parsed = 0;
  for (int k = 0; k < 3000; ++k) {
    std::string text = kBase;
    for (int edits = 1 + k % 3; edits > 0; --edits) {
      if (text.empty()) break;
      const std::size_t at = std::uniform_int_distribution<std::size_t>(0, text.size() - 1)(rng);
      switch (rng() % 3) {
        case 0:
          text[at] = alphabet[pick(rng)];
          break;
        case 1:
          text.erase(at, 1 + rng() % 8);
          break;
        default:
          text.insert(at, 1, alphabet[pick(rng)]);
      }
    }
    parsed += parses_or_parse_error(text) ? 1 : 0;
  }
  INFO(parsed << " of 3000 mutated files still parsed");
  CHECK(parsed < 3000);
}

TEST_CASE("BVH: format_bvh round-trips small motions", "[bvh]") {
  const std::string text =
      "HIERARCHY\n"
      "ROOT Pelvis Root\n{\n OFFSET 1.5 -2.25 3\n CHANNELS 0\n"
      " JOINT J\n {\n  OFFSET 5 6 7\n  CHANNELS 4 Yrotation Zposition Xrotation Xposition\n"
      "  End Site\n  {\n   OFFSET 0 0 1\n  }\n }\n"
      " JOINT K\n {\n  OFFSET 0 1 0\n  CHANNELS 1 Zrotation\n }\n"
      "}\n"
      "ROOT Other\n{\n OFFSET 0 0 0\n CHANNELS 3 Zposition Xrotation Yposition\n}\n"
      "MOTION\nFrames: 2\nFrame Time: 0.0333333333\n"
      "1 2 3 4 5 6 7 8\n-1e-7 123456.789 0.1 -0.2 0.3 -0.4 0.5 -0.6\n";
  const BvhMotion m = mocap_io::parse_bvh(text, "t.bvh");
  const BvhMotion back = mocap_io::parse_bvh(mocap_io::format_bvh(m, 17), "formatted");
  REQUIRE(back.joints.size() == m.joints.size());
  for (std::size_t i = 0; i < m.joints.size(); ++i) {
    CHECK(back.joints[i].name == m.joints[i].name);
    CHECK(back.joints[i].parent == m.joints[i].parent);
    CHECK(back.joints[i].channels == m.joints[i].channels);
    CHECK(back.joints[i].offset == m.joints[i].offset);
  }
  CHECK(back.values == m.values);  // 17 digits: exact
  CHECK(back.frame_time_s == m.frame_time_s);
  // Fewer digits round as asked.
  const BvhMotion coarse = mocap_io::parse_bvh(mocap_io::format_bvh(m, 3), "coarse");
  CHECK(coarse.values(1, 1) == 123000.0);
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "BVH: format_bvh and write_bvh refuse what they cannot write", "[bvh]") {
  const BvhMotion good = mocap_io::parse_bvh(kBase, "base.bvh");
  BvhMotion m = good;
  m.frame_time_s = 0;
  CHECK_THROWS_AS(mocap_io::format_bvh(m), sim::InvalidArgument);
  m = good;
  m.values(1, 3) = std::nan("");
  CHECK_THROWS_AS(mocap_io::format_bvh(m), sim::InvalidArgument);
  m = good;
  m.joints[1].parent = 2;  // a parent after its child
  CHECK_THROWS_AS(mocap_io::format_bvh(m), sim::InvalidArgument);
  CHECK_THROWS_AS(mocap_io::forward_kinematics(m, 0, kFileUnits), sim::InvalidArgument);
  m = good;
  m.joints[1].name = "two\nlines";
  CHECK_THROWS_AS(mocap_io::format_bvh(m), sim::InvalidArgument);
  m = good;
  m.values.conservativeResize(2, 8);  // fewer columns than channels
  CHECK_THROWS_AS(mocap_io::format_bvh(m), sim::InvalidArgument);
  CHECK_THROWS_AS(mocap_io::format_bvh(good, 0), sim::InvalidArgument);
  // Not depth-first: a root's second child listed after another root.
  m = mocap_io::parse_bvh(
      "HIERARCHY\nROOT A\n{\n OFFSET 0 0 0\n CHANNELS 0\n}\nROOT B\n{\n OFFSET 0 0 0\n"
      " CHANNELS 0\n}\nMOTION\nFrames: 1\nFrame Time: 1\n",
      "t");
  m.joints.push_back(m.joints[1]);
  m.joints.back().parent = 0;
  m.joints.back().name = "C";
  CHECK_THROWS_AS(mocap_io::format_bvh(m), sim::InvalidArgument);

  const std::string dir = biodyn::testing::binary_dir();
  SECTION("a path in a missing directory: sim::Error naming it, nothing written") {
    const std::string path = dir + "/no_such_dir/out.bvh";
    try {
      mocap_io::write_bvh(path, good);
      FAIL("no error");
    } catch (const sim::Error& e) {
      CHECK_THAT(std::string(e.what()), Contains(path));
    }
    CHECK_FALSE(std::ifstream(path).good());
  }
  SECTION("an invalid motion leaves the existing file untouched") {
    const std::string path = dir + "/bvh_test_keep.bvh";
    mocap_io::write_bvh(path, good);
    BvhMotion bad = good;
    bad.frame_time_s = -1;
    CHECK_THROWS_AS(mocap_io::write_bvh(path, bad), sim::InvalidArgument);
    CHECK(mocap_io::read_bvh(path).values == good.values);
    std::remove(path.c_str());
  }
  SECTION("read_bvh of a missing file or a directory is sim::InvalidArgument naming it") {
    try {
      mocap_io::read_bvh(dir + "/no_such_file.bvh");
      FAIL("no error");
    } catch (const sim::InvalidArgument& e) {
      CHECK_THAT(std::string(e.what()), Contains("no_such_file.bvh"));
    }
    CHECK_THROWS_AS(mocap_io::read_bvh(dir), sim::InvalidArgument);
  }
}
