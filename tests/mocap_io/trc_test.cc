// TRC reader and writer: the OpenSim reference file, a round trip, gaps, and every malformed
// header or row refused with the line, what was expected and what was found.
#include "biodyn/mocap_io/trc.h"

#include <cmath>
#include <fstream>

#include "biodyn/mocap_io/errors.h"
#include "test_support.h"

using namespace biodyn;
using mocap_io::ParseError;

namespace {

std::string walking5_trc() {
  return testing::source_dir() + "/../shared/data/mocap/c3d/opensim_walking5_markers.trc";
}

constexpr char kSmallTrc[] =
    "PathFileType\t4\t(X/Y/Z)\tsmall.trc\n"
    "DataRate\tCameraRate\tNumFrames\tNumMarkers\tUnits\tOrigDataRate\tOrigDataStartFrame\t"
    "OrigNumFrames\n"
    "100\t100\t3\t2\tmm\t100\t5\t3\n"
    "Frame#\tTime\tA\t\t\tB\t\t\n"
    "\t\tX1\tY1\tZ1\tX2\tY2\tZ2\n"
    "\n"
    "5\t0.00\t1\t2\t3\t4\t5\t6\n"
    "6\t0.01\t1.5\t2\t3\t\t\t\n"
    "7\t0.02\t2\t2\t3\tNaN\tNaN\tNaN\n";

/// kSmallTrc with line `number` (1-based) replaced by `text`.
std::string with_line(int number, const std::string& text) {
  std::string s = kSmallTrc;
  size_t start = 0;
  for (int i = 1; i < number; ++i) start = s.find('\n', start) + 1;
  const size_t end = s.find('\n', start);
  return s.substr(0, start) + text + s.substr(end);
}

void require_parse_error(const std::string& text, const std::string& where,
                         const std::string& found_part) {
  try {
    mocap_io::parse_trc(text, "bad.trc");
    FAIL("expected a ParseError at " << where);
  } catch (const ParseError& e) {
    CHECK(e.file() == "bad.trc");
    CHECK(e.where() == where);
    CHECK(std::string(e.what()).find("expected") != std::string::npos);
    CHECK(e.found().find(found_part) != std::string::npos);
  }
}

}  // namespace

TEST_CASE("TRC: a small file with both gap spellings", "[mocap_io][trc]") {
  const mocap_io::TrcFile f = mocap_io::parse_trc(kSmallTrc, "small.trc");
  const mocap_io::MarkerData& m = f.markers;
  REQUIRE(m.marker_count() == 2);
  REQUIRE(m.frame_count() == 3);
  CHECK(m.labels == std::vector<std::string>{"A", "B"});
  CHECK(m.rate_hz == 100.0);
  CHECK(m.first_frame == 5);
  CHECK(f.units == "mm");
  CHECK(f.inconsistencies.empty());
  CHECK(m.position(1, 0).x() == Approx(1.5e-3));  // mm -> m
  CHECK(m.visible(0, 1));
  CHECK_FALSE(m.visible(1, 1));  // empty fields
  CHECK_FALSE(m.visible(2, 1));  // NaN
  CHECK(m.gap_count(1) == 2);
  CHECK(m.time_s(2) == Approx(0.02));
}

TEST_CASE("TRC: write then read gives the same markers", "[mocap_io][trc]") {
  const mocap_io::TrcFile f = mocap_io::parse_trc(kSmallTrc, "small.trc");
  for (const char* units : {"mm", "m"}) {
    const mocap_io::TrcFile g =
        mocap_io::parse_trc(mocap_io::format_trc(f.markers, units, "x.trc"), "x.trc");
    CHECK(g.markers.labels == f.markers.labels);
    CHECK(g.markers.first_frame == f.markers.first_frame);
    CHECK(g.markers.times_s == f.markers.times_s);
    for (int fr = 0; fr < 3; ++fr) {
      for (int k = 0; k < 6; ++k) {
        const double a = f.markers.positions_m(fr, k), b = g.markers.positions_m(fr, k);
        CHECK(std::isnan(a) == std::isnan(b));
        if (!std::isnan(a)) CHECK(b == Approx(a).epsilon(1e-12));
      }
    }
  }
}

TEST_CASE("TRC: the OpenSim reference file reads whole", "[mocap_io][trc][regression]") {
  const mocap_io::TrcFile f = mocap_io::read_trc(walking5_trc());
  const mocap_io::MarkerData& m = f.markers;
  CHECK(m.marker_count() == 40);
  CHECK(m.frame_count() == 112);
  CHECK(m.labels.front() == "LTH3");
  CHECK(m.labels.back() == "RKJC");
  CHECK(f.units == "mm");
  // Its rows are every 10th frame of a 250 Hz capture: the header says 250 Hz, the Time column
  // steps 0.04 s. Reported, and the times kept.
  REQUIRE(f.inconsistencies.size() == 1);
  CHECK(f.inconsistencies[0].find("DataRate") != std::string::npos);
  CHECK(m.time_s(111) == Approx(4.408));
  CHECK_FALSE(m.visible(0, 0));  // the first rows are NaN
  CHECK(m.position(6, 0).x() == Approx(4.2838));
}

TEST_CASE("TRC: malformed files name the line, the rule and the value", "[mocap_io][trc]") {
  require_parse_error("", "line 1", "end of file");
  require_parse_error("hello\n", "line 1", "hello");
  require_parse_error(with_line(3, "100\t100\t3\t2\tinch\t100\t5\t3"), "line 3", "inch");
  require_parse_error(with_line(3, "fast\t100\t3\t2\tmm\t100\t5\t3"), "line 3", "fast");
  require_parse_error(with_line(3, "-5\t100\t3\t2\tmm\t100\t5\t3"), "line 3", "-5");
  require_parse_error(with_line(2, "DataRate\tCameraRate\tNumFrames\tUnits"), "line 2", "DataRate");
  require_parse_error(with_line(4, "Frame#\tTime\tA\t\t\tB\t\t\tC"), "line 4", "3");
  require_parse_error(with_line(8, "6\t0.01\t1.5\t2\t3\t4"), "line 8", "6 fields");
  require_parse_error(with_line(8, "6\t0.01\t1.5\tabc\t3\t4\t5\t6"), "line 8", "abc");
  require_parse_error(with_line(8, "6\t0.00\t1.5\t2\t3\t4\t5\t6"), "line 8", "0");
  // No rows at all.
  std::string header_only = kSmallTrc;
  header_only = header_only.substr(0, header_only.find("5\t0.00"));
  require_parse_error(header_only, "line 7", "end of file");
  // Fewer rows than NumFrames: truncated, refused. More rows: reported, all read.
  require_parse_error(with_line(3, "100\t100\t7\t2\tmm\t100\t5\t7"), "line 10", "3 rows");
  const mocap_io::TrcFile f =
      mocap_io::parse_trc(with_line(3, "100\t100\t2\t2\tmm\t100\t5\t2"), "small.trc");
  REQUIRE(f.inconsistencies.size() == 1);
  CHECK(f.inconsistencies[0].find("NumFrames is 2") != std::string::npos);
  CHECK(f.markers.frame_count() == 3);
}

TEST_CASE("TRC: a truncated reference file is refused, never read as whole",
          "[mocap_io][trc][regression]") {
  std::ifstream in(walking5_trc(), std::ios::binary);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  REQUIRE(text.size() > 10000);
  // Cut in the header, or inside a row (the last row then has too few fields), or at a row's
  // end (fewer rows than NumFrames).
  for (size_t cut : {size_t{200}, size_t{900}, text.size() / 2 + 7, text.size() - 40}) {
    INFO("cut at byte " << cut);
    std::string part = text.substr(0, cut);
    while (!part.empty() && (part.back() == '\n' || part.back() == '\t')) part.pop_back();
    CHECK_THROWS_AS(mocap_io::parse_trc(part, "cut.trc"), ParseError);
  }
}

TEST_CASE("TRC: a file cut at a row's end has fewer rows than NumFrames: refused",
          "[mocap_io][trc]") {
  std::string s = kSmallTrc;
  s = s.substr(0, s.find("7\t0.02"));
  require_parse_error(s, "line 9", "2 rows");
}

TEST_CASE("TRC: a sample stored as 0 0 0 is a gap, and counted", "[mocap_io][trc]") {
  // OpenSim writes a missing marker as 0 0 0; read as a position it is a marker at the lab origin.
  const mocap_io::TrcFile f =
      mocap_io::parse_trc(with_line(8, "6\t0.01\t0\t0\t0\t0\t0\t0.000"), "zeros.trc");
  CHECK_FALSE(f.markers.visible(1, 0));
  CHECK_FALSE(f.markers.visible(1, 1));
  CHECK(std::isnan(f.markers.position(1, 0).x()));
  CHECK(f.markers.gap_count(0) == 1);
  CHECK(f.markers.gap_count(1) == 2);  // with the NaN sample of kSmallTrc
  CHECK(f.zero_samples == 2);
  // One zero coordinate, or two, is a position.
  const mocap_io::TrcFile g =
      mocap_io::parse_trc(with_line(8, "6\t0.01\t0\t0\t3\t0\t5\t0"), "small.trc");
  CHECK(g.markers.visible(1, 0));
  CHECK(g.markers.visible(1, 1));
  CHECK(g.zero_samples == 0);
}

TEST_CASE("TRC: the same label twice is refused naming line 4 and the label", "[mocap_io][trc]") {
  require_parse_error(with_line(4, "Frame#\tTime\tA\t\t\tA\t\t"), "line 4", "'A' twice");
}

TEST_CASE("TRC: a time column going backwards is refused naming the line", "[mocap_io][trc]") {
  require_parse_error(with_line(9, "7\t0.005\t2\t2\t3\tNaN\tNaN\tNaN"), "line 9", "0.005");
}

TEST_CASE("TRC: labels that are not UTF-8 are read as Latin-1", "[mocap_io][trc]") {
  const mocap_io::TrcFile f =
      mocap_io::parse_trc(with_line(4, "Frame#\tTime\tM\xE9\t\t\tH\xC3\xBC\t\t"), "latin1.trc");
  CHECK(f.markers.labels == std::vector<std::string>{"M\xC3\xA9", "H\xC3\xBC"});  // "Mé", "Hü"
  CHECK(f.transcoded_names == 1);
}

TEST_CASE("TRC: the rate a C3D gets is the Time column's when DataRate disagrees",
          "[mocap_io][trc]") {
  const mocap_io::TrcFile consistent = mocap_io::parse_trc(kSmallTrc, "small.trc");
  CHECK(mocap_io::uniform_rate(consistent, "small.trc").rate_hz == 100.0);
  CHECK(mocap_io::uniform_rate(consistent, "small.trc").note.empty());
  // DataRate 250 Hz over rows 0.01 s apart: the rows' 100 Hz, said.
  const mocap_io::TrcFile fast =
      mocap_io::parse_trc(with_line(3, "250\t250\t3\t2\tmm\t250\t5\t3"), "fast.trc");
  const mocap_io::TrcUniformRate r = mocap_io::uniform_rate(fast, "fast.trc");
  CHECK(r.rate_hz == 100.0);
  CHECK_THAT(r.note, Catch::Contains("fast.trc") && Catch::Contains("250 Hz") &&
                         Catch::Contains("line 3") && Catch::Contains("used 100 Hz"));
  // Rows not evenly spaced cannot be written at one rate: refused on the row that breaks it.
  try {
    mocap_io::uniform_rate(
        mocap_io::parse_trc(with_line(9, "7\t0.05\t2\t2\t3\tNaN\tNaN\tNaN"), "uneven.trc"),
        "uneven.trc");
    FAIL("no ParseError");
  } catch (const ParseError& e) {
    CHECK(e.file() == "uneven.trc");
    CHECK(e.where() == "line 9");
    CHECK_THAT(e.expected(), Catch::Contains("evenly spaced") && Catch::Contains("DataRate 100"));
    CHECK_THAT(e.found(), Catch::Contains("0.05"));
  }
  // OpenSim's walking5 TRC: 0.04 s steps, then 4.4 s to 4.408 s on its last row (line 118).
  const mocap_io::TrcFile walking = mocap_io::read_trc(walking5_trc());
  CHECK_THROWS_WITH(mocap_io::uniform_rate(walking, "walking5.trc"),
                    Catch::Contains("walking5.trc: line 118") && Catch::Contains("4.408"));
}
