// Regression: OpenSim's walking5.c3d (Vicon Nexus, Intel, float storage, 40 markers, 2 AMTI-style
// type-2 plates) against what OpenSim's own reader wrote from it: the markers as TRC and the
// plates as STO (shared/data/README.md).

#include <Eigen/Geometry>
#include <cmath>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "biodyn/mocap_io/c3d.h"
#include "test_support.h"

using namespace biodyn::mocap_io;

namespace {

const std::string kDataDir = biodyn::testing::source_dir() + "/../shared/data/mocap/c3d/";

// The TRC prints about 5 significant digits ("1318.1", "392.66"): half a unit of the last digit
// is at most 5e-5 of the value; 0.005 mm covers values printed with two decimals.
constexpr double kTrcRelative = 5e-5;
constexpr double kTrcAbsolute_mm = 0.005;
// The STO holds OpenSim's (ezc3d's) double arithmetic on the same float channels, printed with
// 8 decimals (+-5e-9). We agree to that printing (measured: 5e-9 N, 4e-9 mm, 5e-7 N mm where
// moments reach 1e5 N mm, i.e. 1e-11 relative: the order of the two sums).
constexpr double kStoRelative = 1e-9;
constexpr double kStoForceAbsolute_N = 2e-8;
constexpr double kStoPositionAbsolute_mm = 2e-8;
constexpr double kStoMomentAbsolute_Nmm = 2e-8;

constexpr int kMarkers = 40;
constexpr int kFrames = 1103;
constexpr double kRate_Hz = 250.0;
constexpr double kAnalogRate_Hz = 2000.0;

std::vector<std::string> split(const std::string& line, char sep) {
  std::vector<std::string> out;
  std::string item;
  std::istringstream in(line);
  while (std::getline(in, item, sep)) out.push_back(item);
  return out;
}

/// OpenSim's TRC: labels and rows (time, then x y z mm per marker; "NaN" for gaps).
struct Trc {
  std::vector<std::string> labels;
  std::vector<double> times;
  std::vector<std::vector<double>> rows;
};

Trc read_trc(const std::string& path) {
  std::ifstream in(path);
  REQUIRE(in);
  Trc trc;
  std::string line;
  for (int i = 0; i < 5 && std::getline(in, line); ++i) {
    if (line.rfind("Frame#", 0) != 0) continue;
    const auto cells = split(line, '\t');
    for (std::size_t c = 2; c < cells.size(); ++c) {
      if (!cells[c].empty() && cells[c] != "\r") trc.labels.push_back(cells[c]);
    }
  }
  while (std::getline(in, line)) {
    const auto cells = split(line, '\t');
    if (cells.size() < 2 || cells[0].empty()) continue;
    trc.times.push_back(std::stod(cells[1]));
    std::vector<double> values;
    for (std::size_t c = 2; c < cells.size(); ++c) {
      if (!cells[c].empty()) values.push_back(std::strtod(cells[c].c_str(), nullptr));  // "NaN"
    }
    trc.rows.push_back(values);
  }
  return trc;
}

/// OpenSim's STO: after "endheader", a row of column names, then numbers.
struct Sto {
  std::vector<std::string> columns;
  std::vector<std::vector<double>> rows;
  int column(const std::string& name) const {
    for (std::size_t i = 0; i < columns.size(); ++i) {
      if (columns[i] == name) return static_cast<int>(i);
    }
    FAIL("no column " << name);
    return -1;
  }
};

Sto read_sto(const std::string& path) {
  std::ifstream in(path);
  REQUIRE(in);
  Sto sto;
  std::string line;
  while (std::getline(in, line) && line.rfind("endheader", 0) != 0) {
  }
  std::getline(in, line);
  std::istringstream names(line);
  for (std::string n; names >> n;) sto.columns.push_back(n);
  while (std::getline(in, line)) {
    std::istringstream values(line);
    std::vector<double> row;
    for (double v; values >> v;) row.push_back(v);
    if (!row.empty()) sto.rows.push_back(row);
  }
  return sto;
}

bool close(double value, double reference, double relative, double absolute) {
  return std::fabs(value - reference) <= relative * std::fabs(reference) + absolute;
}

}  // namespace

TEST_CASE("walking5.c3d: layout, labels and analog channels", "[mocap_io][c3d][regression]") {
  const C3dFile c3d = read_c3d(kDataDir + "opensim_walking5.c3d");
  CHECK(c3d.processor == C3dProcessor::kIntel);
  CHECK(c3d.storage == C3dStorage::kFloat);
  CHECK(c3d.point_units == "mm");
  CHECK(c3d.inconsistencies.empty());
  const MarkerData& m = c3d.markers;
  CHECK(m.rate_hz == kRate_Hz);
  CHECK(m.marker_count() == kMarkers);
  CHECK(m.frame_count() == kFrames);
  CHECK(m.first_frame == 1);  // header word 4 (and TRIAL:ACTUAL_START_FIELD)
  const Trc trc = read_trc(kDataDir + "opensim_walking5_markers.trc");
  CHECK(m.labels == trc.labels);

  const AnalogData& a = c3d.analog;
  CHECK(a.channel_count() == 12);
  CHECK(a.rate_hz == kAnalogRate_Hz);
  CHECK(a.sample_count() == kFrames * 8);
  CHECK(a.labels.front() == "Fx1");
  CHECK(a.labels.back() == "Mz2");
  CHECK(a.units[0] == "N");
  CHECK(a.units[3] == "Nmm");
}

TEST_CASE("walking5.c3d: every marker sample equals OpenSim's TRC", "[mocap_io][c3d][regression]") {
  const MarkerData m = read_c3d(kDataDir + "opensim_walking5.c3d").markers;
  const Trc trc = read_trc(kDataDir + "opensim_walking5_markers.trc");
  REQUIRE(trc.rows.size() == 112);  // every 10th frame (0.04 s) and the last
  int compared = 0, gaps = 0;
  double worst_mm = 0;
  for (std::size_t r = 0; r < trc.rows.size(); ++r) {
    const int f = static_cast<int>(std::lround(trc.times[r] * m.rate_hz));
    REQUIRE(f < m.frame_count());
    REQUIRE(trc.rows[r].size() == std::size_t(3 * kMarkers));
    for (int k = 0; k < kMarkers; ++k) {
      for (int c = 0; c < 3; ++c) {
        const double reference_mm = trc.rows[r][std::size_t(3 * k + c)];
        const double mm = m.positions_m(f, 3 * k + c) * 1000.0;
        INFO("frame " << f << " marker " << m.labels[std::size_t(k)] << " axis " << c);
        if (std::isnan(reference_mm)) {
          CHECK(std::isnan(mm));  // a gap: NaN, never (0, 0, 0)
          ++gaps;
          continue;
        }
        REQUIRE(!std::isnan(mm));
        CHECK(close(mm, reference_mm, kTrcRelative, kTrcAbsolute_mm));
        worst_mm = std::max(worst_mm, std::fabs(mm - reference_mm));
        ++compared;
      }
    }
  }
  CHECK(trc.times.back() * m.rate_hz == Approx(kFrames - 1));  // the last frame is compared
  CHECK(gaps > 0);
  CHECK(compared > 5000);
  // 0.05 mm when written (printing "1318.1" for 1318.15): the TRC's rounding, nothing more.
  CHECK(worst_mm <= 0.05 + kTrcAbsolute_mm);
}

TEST_CASE("walking5.c3d: force plates equal OpenSim's STO", "[mocap_io][c3d][regression]") {
  const C3dFile c3d = read_c3d(kDataDir + "opensim_walking5.c3d");
  REQUIRE(c3d.force_plates.size() == 2);
  const Sto sto = read_sto(kDataDir + "opensim_walking5_grfs.sto");
  REQUIRE(sto.rows.size() == 90);  // every 100th analog sample and the last
  const int time = sto.column("time");
  for (std::size_t p = 0; p < 2; ++p) {
    const ForcePlate& plate = c3d.force_plates[p];
    const std::string n = std::to_string(p + 1);
    CHECK(plate.type == 2);
    CHECK(plate.sample_count() == c3d.analog.sample_count());
    CHECK(plate.channels == std::vector<int>{int(6 * p), int(6 * p + 1), int(6 * p + 2),
                                             int(6 * p + 3), int(6 * p + 4), int(6 * p + 5)});
    int loaded = 0;
    for (const auto& row : sto.rows) {
      const int s = static_cast<int>(std::lround(row[std::size_t(time)] * c3d.analog.rate_hz));
      INFO("plate " << n << " sample " << s);
      REQUIRE(s < plate.sample_count());
      for (int k = 0; k < 3; ++k) {
        const std::string axis = "_" + std::to_string(k + 1);
        // OpenSim's f: the ground reaction in the lab (N); p: the plate's surface centre (mm);
        // m: the moment about it (N mm).
        const double f = row[std::size_t(sto.column("f" + n + axis))];
        const double centre_mm = row[std::size_t(sto.column("p" + n + axis))];
        const double moment_Nmm = row[std::size_t(sto.column("m" + n + axis))];
        CHECK(close(plate.force_N(s, k), f, kStoRelative, kStoForceAbsolute_N));
        CHECK(
            close(plate.center_m()(k) * 1000.0, centre_mm, kStoRelative, kStoPositionAbsolute_mm));
        CHECK(close(plate.moment_origin_Nm(s, k) * 1000.0, moment_Nmm, kStoRelative,
                    kStoMomentAbsolute_Nmm));
      }
      if (!std::isnan(plate.cop_m(s, 0))) ++loaded;
    }
    CHECK(loaded > 0);  // the subject stepped on both plates
  }
}

TEST_CASE("walking5.c3d: COP and free moment reproduce the moment about the centre",
          "[mocap_io][c3d][regression]") {
  // M_centre = (cop - centre) x F + free moment, for every loaded sample; the free moment is
  // normal to the plate. Under a real load the COP lies on the plate; under a light one the
  // plates' uncorrected offsets (~1.5 N m at no load, FORCE_PLATFORM:ZERO unused) move it by
  // up to ~15 cm, so the position check starts at 200 N (30% of the subject's weight).
  constexpr double kMomentTolerance_Nm = 1e-9;
  constexpr double kOnPlate_m = 0.01;
  constexpr double kRealLoad_N = 200.0;
  const C3dFile c3d = read_c3d(kDataDir + "opensim_walking5.c3d");
  for (const ForcePlate& plate : c3d.force_plates) {
    const Eigen::Vector3d lo = plate.corners_m.rowwise().minCoeff();
    const Eigen::Vector3d hi = plate.corners_m.rowwise().maxCoeff();
    int loaded = 0;
    for (int s = 0; s < plate.sample_count(); ++s) {
      if (std::isnan(plate.cop_m(s, 0))) continue;
      ++loaded;
      const Eigen::Vector3d cop = plate.cop_m.row(s).transpose();
      const Eigen::Vector3d force = plate.force_N.row(s).transpose();
      const Eigen::Vector3d free = plate.free_moment_Nm.row(s).transpose();
      const Eigen::Vector3d moment = (cop - plate.center_m()).cross(force) + free;
      INFO("sample " << s);
      CHECK((moment - plate.moment_origin_Nm.row(s).transpose()).norm() < kMomentTolerance_Nm);
      CHECK(free.head<2>().norm() < 1e-12);  // the plates are level: the normal is the lab z
      CHECK(force.z() > 0);                  // the ground pushes the subject up
      if (force.z() > kRealLoad_N) {
        CHECK((cop.array() >= lo.array() - kOnPlate_m).all());
        CHECK((cop.array() <= hi.array() + kOnPlate_m).all());
      }
    }
    CHECK(loaded > 500);
  }
}
