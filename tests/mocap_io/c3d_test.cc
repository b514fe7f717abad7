// C3D reader and writer: round trips through every processor and storage, files laid out byte
// by byte here (independently of the writer), force plate arithmetic against a wrench built by
// hand, and malformed files (truncated, corrupted, inconsistent, missing).

#include <Eigen/Geometry>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "biodyn/mocap_io/c3d.h"
#include "biodyn/mocap_io/errors.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/file_io.h"
#include "test_support.h"

using namespace biodyn::mocap_io;
using Eigen::Vector3d;

namespace {

const std::string kWalking =
    biodyn::testing::source_dir() + "/../shared/data/mocap/c3d/opensim_walking5.c3d";
const double kNaN = std::numeric_limits<double>::quiet_NaN();

/// A scratch directory for this test binary's files.
std::string scratch(const std::string& name) {
  const std::filesystem::path dir =
      std::filesystem::path(biodyn::testing::binary_dir()) / "mocap_io_test_files";
  std::filesystem::create_directories(dir);
  return (dir / name).string();
}

std::vector<std::uint8_t> read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  REQUIRE(in);
  return std::vector<std::uint8_t>((std::istreambuf_iterator<char>(in)),
                                   std::istreambuf_iterator<char>());
}

std::string write_bytes(const std::string& name, const std::vector<std::uint8_t>& bytes) {
  const std::string path = scratch(name);
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
  REQUIRE(out);
  return path;
}

// ---------------------------------------------------------------------------------------------
// A synthetic capture: 3 markers with gaps, 2 EMG channels and a type-2 plate whose six channels
// encode a ground reaction chosen here.

constexpr double kRate_Hz = 100.0;
constexpr int kFrames = 12;
constexpr int kSamplesPerFrame = 4;
constexpr int kFirstFrame = 7;
constexpr double kOriginZ_mm = 40.0;  // stored positive, as Vicon does (the reader flips it)
// Plate 1 of walking5, scaled: its axes are x_p = -y_lab, y_p = -x_lab, z_p = -z_lab (down).
const Eigen::Matrix<double, 3, 4> kCorners_m =
    (Eigen::Matrix<double, 3, 4>() << 0.2, 0.2, 0.8, 0.8, 0.1, 0.5, 0.5, 0.1, 0, 0, 0, 0)
        .finished();
const Vector3d kCentre_m(0.5, 0.3, 0.0);

Eigen::Matrix3d plate_to_lab() {
  Eigen::Matrix3d r;
  r << 0, -1, 0, -1, 0, 0, 0, 0, -1;  // columns: plate x, y, z in the lab
  return r;
}

/// The ground reaction the plate's channels encode at sample s (lab frame): unloaded for the
/// first 5 samples, then a push that grows, with its COP walking along x and a free moment.
struct Reaction {
  Vector3d force_N = Vector3d::Zero();
  Vector3d cop_m = Vector3d::Constant(kNaN);
  double free_moment_Nm = 0;  // about the lab z
};

Reaction reaction(int s) {
  Reaction r;
  if (s < 5) return r;
  r.force_N = Vector3d(30.0 + s, -50.0, 600.0 + 5.0 * s);
  r.cop_m = Vector3d(0.45 + 0.005 * s, 0.25, 0.0);
  r.free_moment_Nm = 2.0 - 0.05 * s;
  return r;
}

/// Fx Fy Fz (N) and Mx My Mz about the sensor origin (N mm) in the plate frame.
Eigen::Matrix<double, 6, 1> plate_channels(const Reaction& r) {
  const Eigen::Matrix3d rt = plate_to_lab().transpose();
  const Vector3d f = rt * r.force_N;
  Vector3d m_centre = rt * Vector3d(0, 0, r.free_moment_Nm);
  if (r.force_N.norm() > 0) m_centre += (rt * (r.cop_m - kCentre_m)).cross(f);
  // The sensor origin lies 40 mm under the surface: from it, the surface centre is at
  // r = (0, 0, -0.040) in the plate frame (z down), and M_origin = M_centre - F x r.
  const Vector3d to_surface(0, 0, -kOriginZ_mm / 1000.0);
  const Vector3d m_origin = m_centre - f.cross(to_surface);
  Eigen::Matrix<double, 6, 1> ch;
  ch << f, m_origin * 1000.0;
  return ch;
}

C3dFile synthetic_capture() {
  C3dFile c;
  MarkerData& m = c.markers;
  m.rate_hz = kRate_Hz;
  m.first_frame = kFirstFrame;
  m.labels = {"LASI", "RASI", "LHEE"};
  m.positions_m.resize(kFrames, 9);
  for (int f = 0; f < kFrames; ++f) {
    for (int k = 0; k < 3; ++k) {
      m.positions_m(f, 3 * k + 0) = 0.1 * k + 0.0123 * f - 1.5;
      m.positions_m(f, 3 * k + 1) = -0.2 + 0.0031 * f * f;
      m.positions_m(f, 3 * k + 2) = 1.0 - 0.05 * k + 0.001 * std::sin(f);
    }
  }
  for (int f = 4; f <= 7; ++f) m.positions_m.block<1, 3>(f, 3).setConstant(kNaN);  // RASI
  m.positions_m.block<1, 3>(0, 6).setConstant(kNaN);  // LHEE, first and last frames
  m.positions_m.block<1, 3>(kFrames - 1, 6).setConstant(kNaN);

  AnalogData& a = c.analog;
  a.rate_hz = kRate_Hz * kSamplesPerFrame;
  a.labels = {"EMG1", "EMG2", "Fx1", "Fy1", "Fz1", "Mx1", "My1", "Mz1"};
  a.units = {"V", "mV", "N", "N", "N", "Nmm", "Nmm", "Nmm"};
  a.values.resize(kFrames * kSamplesPerFrame, 8);
  for (int s = 0; s < a.values.rows(); ++s) {
    a.values(s, 0) = 0.8 * std::sin(0.3 * s);
    a.values(s, 1) = -2.5 + 0.01 * s;
    a.values.block<1, 6>(s, 2) = plate_channels(reaction(s)).transpose();
  }
  ForcePlate p;
  p.type = 2;
  p.corners_m = kCorners_m;
  p.origin_m = Vector3d(0, 0, kOriginZ_mm / 1000.0);
  p.channels = {2, 3, 4, 5, 6, 7};
  c.force_plates = {p};
  c.force_plate_cal_matrices = {Eigen::MatrixXd()};
  return c;
}

/// Half a stored unit: the rounding of integer storage.
double half_unit(double largest, double full_scale) { return 0.5 * largest / full_scale; }

void check_round_trip(const C3dFile& in, const C3dFile& out, const C3dWriteOptions& o) {
  const bool integer = o.storage == C3dStorage::kInteger;
  CHECK(out.processor == o.processor);
  CHECK(out.storage == o.storage);
  CHECK(out.point_units == "mm");
  CHECK(out.inconsistencies.empty());
  const MarkerData& a = in.markers;
  const MarkerData& b = out.markers;
  CHECK(b.labels == a.labels);
  CHECK(b.rate_hz == a.rate_hz);
  CHECK(b.first_frame == a.first_frame);
  REQUIRE(b.frame_count() == a.frame_count());
  // Integer: half a unit of POINT:SCALE; float: float rounding of a coordinate in mm (2^-24 of
  // 1500 mm is 9e-5 mm).
  const double tolerance_m = integer ? 0.5 * o.integer_scale_mm / 1000.0 + 1e-12 : 1e-7;
  for (int f = 0; f < a.frame_count(); ++f) {
    for (int k = 0; k < a.marker_count(); ++k) {
      INFO("frame " << f << " marker " << k);
      REQUIRE(b.visible(f, k) == a.visible(f, k));
      if (!a.visible(f, k)) {
        CHECK(b.position(f, k).array().isNaN().all());  // a gap stays a gap, never zeros
        continue;
      }
      CHECK((b.position(f, k) - a.position(f, k)).cwiseAbs().maxCoeff() <= tolerance_m);
    }
  }
  CHECK(out.analog.labels == in.analog.labels);
  CHECK(out.analog.units == in.analog.units);
  CHECK(out.analog.rate_hz == in.analog.rate_hz);
  REQUIRE(out.analog.sample_count() == in.analog.sample_count());
  for (int c = 0; c < in.analog.channel_count(); ++c) {
    const double largest = in.analog.values.col(c).cwiseAbs().maxCoeff();
    // ANALOG:SCALE = largest / 32000 in integer storage (rounded to float: + 1e-6).
    const double tolerance = integer ? half_unit(largest, 32000.0) * (1 + 1e-6) : 1e-7 * largest;
    INFO("channel " << c);
    CHECK((out.analog.values.col(c) - in.analog.values.col(c)).cwiseAbs().maxCoeff() <= tolerance);
  }
  REQUIRE(out.force_plates.size() == 1);
  const ForcePlate& p = out.force_plates[0];
  CHECK(p.type == 2);
  CHECK(p.channels == in.force_plates[0].channels);
  CHECK((p.corners_m - kCorners_m).cwiseAbs().maxCoeff() < 1e-7);
  CHECK((p.origin_m - in.force_plates[0].origin_m).cwiseAbs().maxCoeff() < 1e-9);
}

/// The plate's output against the reaction its channels encode.
void check_plate(const ForcePlate& p, C3dStorage storage) {
  // Integer storage quantises Fz to ~0.01 N and moments to ~5 N mm (largest / 64000).
  const bool integer = storage == C3dStorage::kInteger;
  const double force_tol = integer ? 0.05 : 1e-3;
  const double moment_tol = integer ? 0.02 : 1e-4;
  const double cop_tol = integer ? 1e-4 : 1e-6;
  REQUIRE(p.sample_count() == kFrames * kSamplesPerFrame);
  for (int s = 0; s < p.sample_count(); ++s) {
    INFO("sample " << s);
    const Reaction r = reaction(s);
    const Vector3d force = p.force_N.row(s).transpose();
    CHECK((force - r.force_N).norm() < force_tol);
    if (s < 5) {
      CHECK(std::isnan(p.cop_m(s, 0)));  // unloaded
      CHECK(std::isnan(p.free_moment_Nm(s, 2)));
      continue;
    }
    CHECK(force.z() > 0);  // the ground reaction pushes the subject up
    CHECK((p.cop_m.row(s).transpose() - r.cop_m).norm() < cop_tol);
    CHECK((p.free_moment_Nm.row(s).transpose() - Vector3d(0, 0, r.free_moment_Nm)).norm() <
          moment_tol);
    const Vector3d about_centre =
        (r.cop_m - kCentre_m).cross(r.force_N) + Vector3d(0, 0, r.free_moment_Nm);
    CHECK((p.moment_origin_Nm.row(s).transpose() - about_centre).norm() < moment_tol);
  }
}

// ---------------------------------------------------------------------------------------------
// Files laid out by hand: a minimal byte writer that knows nothing of the library.

enum class Order { kIntel, kDec, kMips };

struct Bytes {
  Order order;
  std::vector<std::uint8_t> b;

  void u8(int v) { b.push_back(static_cast<std::uint8_t>(v)); }
  void word(int v) {  // 16 bits
    const auto u = static_cast<std::uint16_t>(v);
    if (order == Order::kMips) {
      u8(u >> 8);
      u8(u & 0xFF);
    } else {
      u8(u & 0xFF);
      u8(u >> 8);
    }
  }
  void real(double v) {
    // DEC per the C3D user guide: the IEEE bits of 4 v with the two 16-bit words swapped.
    const float f = static_cast<float>(order == Order::kDec ? 4 * v : v);
    std::uint32_t bits;
    std::memcpy(&bits, &f, 4);
    if (order == Order::kMips) {
      for (int shift : {24, 16, 8, 0}) u8(int((bits >> shift) & 0xFF));
    } else if (order == Order::kDec) {
      for (int shift : {16, 24, 0, 8}) u8(int((bits >> shift) & 0xFF));
    } else {
      for (int shift : {0, 8, 16, 24}) u8(int((bits >> shift) & 0xFF));
    }
  }
  void text(const std::string& s) { b.insert(b.end(), s.begin(), s.end()); }
  void pad_to(std::size_t size) { b.resize(size, 0); }
};

/// Parameter records: `next` is the offset word's position, patched when the next record starts.
struct Records {
  Bytes* out;
  std::size_t offset_word = 0;

  void start(int id, const std::string& name) {
    if (offset_word != 0) {
      const auto next = static_cast<int>(out->b.size() - offset_word);
      Bytes patch{out->order, {}};
      patch.word(next);
      out->b[offset_word] = patch.b[0];
      out->b[offset_word + 1] = patch.b[1];
    }
    out->u8(int(name.size()));
    out->u8(id);
    out->text(name);
    offset_word = out->b.size();
    out->word(0);
  }
  void group(int id, const std::string& name) {
    start(-id & 0xFF, name);
    out->u8(0);  // no description
  }
  void header(int group, const std::string& name, int type, const std::vector<int>& dims) {
    start(group, name);
    out->u8(type & 0xFF);
    out->u8(int(dims.size()));
    for (int d : dims) out->u8(d);
  }
  void words(int group, const std::string& name, const std::vector<int>& v, bool scalar = true) {
    header(group, name, 2, scalar ? std::vector<int>{} : std::vector<int>{int(v.size())});
    for (int x : v) out->word(x);
    out->u8(0);
  }
  void reals(int group, const std::string& name, const std::vector<double>& v, bool scalar = true) {
    header(group, name, 4, scalar ? std::vector<int>{} : std::vector<int>{int(v.size())});
    for (double x : v) out->real(x);
    out->u8(0);
  }
  void chars(int group, const std::string& name, const std::string& s, int count = 0) {
    header(group, name, -1,
           count == 0 ? std::vector<int>{int(s.size())}
                      : std::vector<int>{int(s.size()) / count, count});
    out->text(s);
    out->u8(0);
  }
};

/// Header block: words as the C3D user guide's header section lists them.
void header_block(Bytes* f, int points, int analog_per_frame, int first, int last, double scale,
                  int data_block, int samples_per_frame, double rate) {
  f->u8(2);     // parameters at block 2
  f->u8(0x50);  // C3D key
  f->word(points);
  f->word(analog_per_frame);
  f->word(first);
  f->word(last);
  f->word(0);
  f->real(scale);
  f->word(data_block);
  f->word(samples_per_frame);
  f->real(rate);
  f->pad_to(512);
}

/// Parameter section header at byte 512: one block, processor byte 83 + type.
void parameter_header(Bytes* f, int processor) {
  f->u8(1);
  f->u8(0x50);
  f->u8(1);
  f->u8(processor);
}

std::size_t find(const std::vector<std::uint8_t>& bytes, const std::vector<std::uint8_t>& what) {
  const auto it = std::search(bytes.begin(), bytes.end(), what.begin(), what.end());
  REQUIRE(it != bytes.end());
  return static_cast<std::size_t>(it - bytes.begin());
}

std::vector<std::uint8_t> record_prefix(int length, int id, const std::string& name) {
  std::vector<std::uint8_t> v{static_cast<std::uint8_t>(length), static_cast<std::uint8_t>(id)};
  v.insert(v.end(), name.begin(), name.end());
  return v;
}

/// Reads `bytes` written to a scratch file; returns the ParseError's where() or "" on success.
std::string parse_error_where(const std::string& name, const std::vector<std::uint8_t>& bytes) {
  const std::string path = write_bytes(name, bytes);
  try {
    read_c3d(path);
  } catch (const ParseError& e) {
    CHECK(e.file() == path);
    CHECK(e.where().rfind("byte ", 0) == 0);
    return e.where();
  }
  return "";
}

}  // namespace

TEST_CASE("C3D processor and storage names", "[mocap_io][c3d]") {
  CHECK(std::string(to_string(C3dProcessor::kIntel)) == "Intel");
  CHECK(std::string(to_string(C3dProcessor::kDec)) == "DEC");
  CHECK(std::string(to_string(C3dProcessor::kMips)) == "MIPS");
  CHECK(std::string(to_string(C3dStorage::kInteger)) == "integer");
  CHECK(std::string(to_string(C3dStorage::kFloat)) == "float");
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "write_c3d round-trips through read_c3d in every processor and storage",
                 "[mocap_io][c3d]") {
  const C3dFile capture = synthetic_capture();
  for (const C3dProcessor processor :
       {C3dProcessor::kIntel, C3dProcessor::kDec, C3dProcessor::kMips}) {
    for (const C3dStorage storage : {C3dStorage::kInteger, C3dStorage::kFloat}) {
      DYNAMIC_SECTION(to_string(processor) << " " << to_string(storage)) {
        C3dWriteOptions o;
        o.processor = processor;
        o.storage = storage;
        const std::string path = scratch(std::string("round_trip_") + to_string(processor) + "_" +
                                         to_string(storage) + ".c3d");
        write_c3d(path, capture, o);
        CHECK(!std::filesystem::exists(path + biodyn::sim::kPartialFileSuffix));
        const C3dFile back = read_c3d(path);
        check_round_trip(capture, back, o);
        check_plate(back.force_plates[0], storage);
      }
    }
  }
}

TEST_CASE("The plate arithmetic recovers a hand-built ground reaction", "[mocap_io][c3d]") {
  // Float storage keeps the channels to float precision: the force, COP, free moment and moment
  // about the centre come back as built, the ground reaction upward (force_N: on the subject).
  const std::string path = scratch("plate.c3d");
  write_c3d(path, synthetic_capture());
  const C3dFile back = read_c3d(path);
  REQUIRE(back.force_plates.size() == 1);
  check_plate(back.force_plates[0], C3dStorage::kFloat);
  CHECK(back.force_plates[0].center_m().isApprox(kCentre_m));
}

TEST_CASE("More than 255 markers use POINT:LABELS2", "[mocap_io][c3d]") {
  C3dFile c;
  c.markers.rate_hz = 60;
  const int n = 300;
  for (int k = 0; k < n; ++k) c.markers.labels.push_back("M" + std::to_string(k));
  c.markers.positions_m = Eigen::MatrixXd::Constant(2, 3 * n, 0.25);
  const std::string path = scratch("labels2.c3d");
  write_c3d(path, c);
  const std::vector<std::uint8_t> bytes = read_bytes(path);
  find(bytes, record_prefix(7, 1, "LABELS2"));  // POINT is group 1
  const C3dFile back = read_c3d(path);
  CHECK(back.markers.labels == c.markers.labels);
  CHECK(back.markers.positions_m.isApprox(c.markers.positions_m));
}

TEST_CASE("A DEC float file laid out by hand", "[mocap_io][c3d]") {
  // One marker in cm, frames 3-4, 50 Hz; frame 4 is invalid (residual -1, coordinates 0).
  Bytes f{Order::kDec, {}};
  header_block(&f, 1, 0, 3, 4, -0.1, 3, 0, 50.0);
  parameter_header(&f, 85);
  Records r{&f};
  r.group(1, "POINT");
  r.words(1, "USED", {1});
  r.words(1, "FRAMES", {2});
  r.words(1, "DATA_START", {3});
  r.reals(1, "SCALE", {-0.1});
  r.reals(1, "RATE", {50.0});
  r.chars(1, "UNITS", "cm");
  r.chars(1, "LABELS", "HEEL", 1);
  r.group(2, "ANALOG");
  r.words(2, "USED", {0});
  f.pad_to(1024);
  for (double v : {12.5, -3.25, 100.0, 0.0, 0.0, 0.0, 0.0, -1.0}) f.real(v);
  f.pad_to(1536);
  const C3dFile c = read_c3d(write_bytes("hand_dec.c3d", f.b));
  CHECK(c.processor == C3dProcessor::kDec);
  CHECK(c.storage == C3dStorage::kFloat);
  CHECK(c.point_units == "cm");
  CHECK(c.inconsistencies.empty());
  CHECK(c.markers.labels == std::vector<std::string>{"HEEL"});
  CHECK(c.markers.rate_hz == 50.0);
  CHECK(c.markers.first_frame == 3);
  REQUIRE(c.markers.frame_count() == 2);
  CHECK(c.markers.position(0, 0).isApprox(Vector3d(0.125, -0.0325, 1.0)));
  CHECK(c.markers.position(1, 0).array().isNaN().all());
  CHECK(c.analog.channel_count() == 0);
  CHECK(c.force_plates.empty());
}

TEST_CASE("A MIPS integer file laid out by hand, with unsigned analog", "[mocap_io][c3d]") {
  // Big-endian words. One marker at POINT:SCALE 0.5 mm and one analog channel at 2 samples per
  // frame, ANALOG:FORMAT UNSIGNED with an offset of 32768 stored as the word 0x8000.
  Bytes f{Order::kMips, {}};
  header_block(&f, 1, 2, 1, 2, 0.5, 3, 2, 100.0);
  parameter_header(&f, 86);
  Records r{&f};
  r.group(1, "POINT");
  r.words(1, "USED", {1});
  r.words(1, "FRAMES", {2});
  r.words(1, "DATA_START", {3});
  r.reals(1, "SCALE", {0.5});
  r.reals(1, "RATE", {100.0});
  r.chars(1, "UNITS", "mm");
  r.chars(1, "LABELS", "TOE ", 1);
  r.group(2, "ANALOG");
  r.words(2, "USED", {1});
  r.reals(2, "RATE", {200.0});
  r.chars(2, "LABELS", "EMG", 1);
  r.chars(2, "UNITS", "V", 1);
  r.reals(2, "SCALE", {0.001}, false);
  r.words(2, "OFFSET", {0x8000}, false);
  r.reals(2, "GEN_SCALE", {2.0});
  r.chars(2, "FORMAT", "UNSIGNED");
  f.pad_to(1024);
  // Frame 1: (1000, -2000, 4) units, residual word 0x0102 (camera 1, residual 2): valid.
  for (int v : {1000, -2000, 4, 0x0102, 0x8010, 0x7FF0}) f.word(v);
  // Frame 2: invalid (residual word -1) whatever its coordinates say.
  for (int v : {7, 7, 7, -1, 0xFFFF, 0}) f.word(v);
  f.pad_to(1536);
  const C3dFile c = read_c3d(write_bytes("hand_mips.c3d", f.b));
  CHECK(c.processor == C3dProcessor::kMips);
  CHECK(c.storage == C3dStorage::kInteger);
  CHECK(c.inconsistencies.empty());
  CHECK(c.markers.labels == std::vector<std::string>{"TOE"});
  REQUIRE(c.markers.frame_count() == 2);
  CHECK(c.markers.position(0, 0).isApprox(Vector3d(0.5, -1.0, 0.002)));
  CHECK(c.markers.position(1, 0).array().isNaN().all());
  REQUIRE(c.analog.sample_count() == 4);
  CHECK(c.analog.rate_hz == 200.0);
  CHECK(c.analog.labels == std::vector<std::string>{"EMG"});
  CHECK(c.analog.units == std::vector<std::string>{"V"});
  // (stored - 32768) * 0.001 * 2, the scale a float (0.001f).
  const double unit = static_cast<double>(0.001f) * 2.0;
  CHECK(c.analog.values(0, 0) == Approx(16 * unit));
  CHECK(c.analog.values(1, 0) == Approx(-16 * unit));
  CHECK(c.analog.values(2, 0) == Approx(32767 * unit));
  CHECK(c.analog.values(3, 0) == Approx(-32768 * unit));
}

TEST_CASE("Header and parameter disagreements are reported, the parameters used",
          "[mocap_io][c3d]") {
  const C3dFile original = read_c3d(kWalking);
  std::vector<std::uint8_t> bytes = read_bytes(kWalking);
  // Intel header words: 2 points, 5 last frame, 9 data start block, 11-12 rate.
  bytes[2] = 39;
  bytes[8] = 0xE8;  // last frame 1000 (0x03E8)
  bytes[9] = 0x03;
  bytes[16] = 15;  // data start block 15 (POINT:DATA_START says 14)
  const float rate = 200.0f;
  std::memcpy(&bytes[20], &rate, 4);
  const C3dFile c = read_c3d(write_bytes("inconsistent.c3d", bytes));
  auto reported = [&](const std::vector<std::string>& words) {
    for (const std::string& s : c.inconsistencies) {
      bool all = true;
      for (const std::string& w : words) all = all && s.find(w) != std::string::npos;
      if (all) return true;
    }
    return false;
  };
  CHECK(c.inconsistencies.size() == 4);
  CHECK(reported({"frame count", "1000", "1103", "used POINT:FRAMES"}));
  CHECK(reported({"frame rate", "200", "250", "used POINT:RATE"}));
  CHECK(reported({"point count", "39", "40", "used POINT:USED"}));
  CHECK(reported({"data start", "15", "14", "used POINT:DATA_START"}));
  CHECK(c.markers.frame_count() == 1103);
  CHECK(c.markers.rate_hz == 250.0);
  const auto read = c.markers.positions_m.array(), expected = original.markers.positions_m.array();
  CHECK((read == expected || (read.isNaN() && expected.isNaN())).all());
  CHECK(c.analog.values == original.analog.values);
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "Malformed C3D files throw ParseError naming the byte", "[mocap_io][c3d]") {
  const std::vector<std::uint8_t> walking = read_bytes(kWalking);
  const std::size_t data_start = 13 * 512;  // POINT:DATA_START 14

  SECTION("a file that cannot be opened") {
    CHECK_THROWS_AS(read_c3d(scratch("no_such_file.c3d")), biodyn::sim::InvalidArgument);
  }
  SECTION("truncated anywhere: header, parameters, data") {
    for (const std::size_t size :
         {std::size_t(0), std::size_t(1), std::size_t(100), std::size_t(511), std::size_t(512),
          std::size_t(515), std::size_t(516), std::size_t(700), std::size_t(2000), data_start - 1,
          data_start, data_start + 1, walking.size() / 2, walking.size() - 1}) {
      INFO("cut at " << size);
      std::vector<std::uint8_t> cut(walking.begin(), walking.begin() + long(size));
      CHECK(parse_error_where("truncated.c3d", cut) != "");
    }
  }
  SECTION("a truncated data section names its start, the expected and the found size") {
    std::vector<std::uint8_t> cut(walking.begin(), walking.end() - 1000);
    const std::string path = write_bytes("truncated_data.c3d", cut);
    try {
      read_c3d(path);
      FAIL("no error");
    } catch (const ParseError& e) {
      CHECK(e.where() == "byte " + std::to_string(data_start));
      CHECK_THAT(e.expected(), Catch::Contains("1103 frames of 1024 bytes") &&
                                   Catch::Contains(std::to_string(1103 * 1024) + " bytes"));
      CHECK_THAT(e.found(), Catch::Contains(std::to_string(cut.size() - data_start) + " bytes") &&
                                Catch::Contains("truncated"));
    }
  }
  SECTION("a bad processor byte") {
    std::vector<std::uint8_t> bad = walking;
    bad[515] = 99;
    const std::string path = write_bytes("processor.c3d", bad);
    CHECK_THROWS_WITH(read_c3d(path), Catch::Contains("byte 515") &&
                                          Catch::Contains("processor type 84") &&
                                          Catch::Contains("found 99"));
  }
  SECTION("not a C3D file") {
    std::vector<std::uint8_t> bad = walking;
    bad[1] = 0;
    CHECK(parse_error_where("key.c3d", bad) == "byte 1");
  }
  SECTION("a parameter section pointer outside the file") {
    std::vector<std::uint8_t> bad(walking.begin(), walking.begin() + 100000);
    bad[0] = 255;  // block 255 starts at byte 130048
    CHECK(parse_error_where("pointer.c3d", bad) == "byte 0");
  }
  SECTION("parameter records running past the section") {
    std::vector<std::uint8_t> bad = walking;
    bad[514] = 1;  // the section claims 1 block; its records need 12
    const std::string path = write_bytes("section.c3d", bad);
    CHECK_THROWS_WITH(read_c3d(path), Catch::Contains("parameter section"));
  }
  SECTION("a negative number of dimensions, an unknown parameter type") {
    const std::size_t name = find(walking, record_prefix(18, 1, "ACTUAL_START_FIELD")) + 2;
    std::vector<std::uint8_t> bad = walking;
    bad[name + 18 + 3] = 0x80;  // after name and offset word: type, then dimension count
    CHECK(parse_error_where("dims.c3d", bad) == "byte " + std::to_string(name + 21));
    bad = walking;
    bad[name + 18 + 2] = 3;
    CHECK(parse_error_where("type.c3d", bad) == "byte " + std::to_string(name + 20));
  }
  SECTION("no POINT group, no POINT:USED") {
    std::vector<std::uint8_t> bad = walking;
    bad[find(walking, record_prefix(5, 0xFD, "POINT")) + 3] = 'X';  // group 3 -> "PXINT"
    CHECK_THROWS_WITH(read_c3d(write_bytes("no_point.c3d", bad)),
                      Catch::Contains("expected a POINT group"));
    bad = walking;
    bad[find(walking, record_prefix(4, 3, "USED")) + 5] = 'X';  // POINT:USED -> "USEX"
    CHECK_THROWS_WITH(read_c3d(write_bytes("no_used.c3d", bad)),
                      Catch::Contains("expected a POINT:USED"));
  }
}

TEST_CASE("Corrupted headers and parameters never crash the reader", "[mocap_io][c3d]") {
  // Seeded: random bytes of the header and parameter section are overwritten; every read
  // either succeeds or throws ParseError, and ends.
  constexpr int kTrials = 150;
  const std::vector<std::uint8_t> walking = read_bytes(kWalking);
  const std::size_t data_start = 13 * 512;
  std::mt19937 rng(20240611);
  std::uniform_int_distribution<std::size_t> where(0, data_start - 1);
  std::uniform_int_distribution<int> value(0, 255), count(1, 6);
  int parse_errors = 0;
  for (int t = 0; t < kTrials; ++t) {
    std::vector<std::uint8_t> bad = walking;
    for (int k = count(rng); k > 0; --k) bad[where(rng)] = static_cast<std::uint8_t>(value(rng));
    const std::string path = write_bytes("fuzz.c3d", bad);
    try {
      read_c3d(path);
    } catch (const ParseError&) {
      ++parse_errors;
    }
  }
  CHECK(parse_errors > 0);
}

TEST_CASE_METHOD(biodyn::testing::SimulationTest,
                 "write_c3d refuses what C3D cannot hold and leaves the old file",
                 "[mocap_io][c3d]") {
  const std::string path = scratch("refused.c3d");
  const C3dFile good = synthetic_capture();
  write_c3d(path, good);
  const std::vector<std::uint8_t> before = read_bytes(path);

  C3dFile long_label = good;
  long_label.markers.labels[0] = std::string(33, 'x');
  CHECK_THROWS_AS(write_c3d(path, long_label), biodyn::sim::InvalidArgument);

  C3dFile far = good;
  far.markers.positions_m(0, 0) = 4.0;  // 4 m: beyond +-3.2767 m at 0.1 mm per unit
  C3dWriteOptions integer;
  integer.storage = C3dStorage::kInteger;
  CHECK_THROWS_WITH(write_c3d(path, far, integer), Catch::Contains("overflows"));
  CHECK_NOTHROW(write_c3d(scratch("far_float.c3d"), far));  // float storage holds it

  C3dFile type4 = good;
  type4.force_plates[0].type = 4;
  CHECK_THROWS_WITH(write_c3d(path, type4), Catch::Contains("calibration matrix"));

  CHECK(read_bytes(path) == before);
  CHECK_THROWS_AS(write_c3d(scratch("no_such_dir/x.c3d"), good), biodyn::sim::Error);
}

TEST_CASE("A type-4 plate applies its calibration matrix", "[mocap_io][c3d]") {
  // The channels hold the plate's wrench divided by 2 and permuted; CAL_MATRIX undoes it.
  C3dFile c = synthetic_capture();
  Eigen::MatrixXd cal = Eigen::MatrixXd::Zero(6, 6);
  for (int i = 0; i < 6; ++i) cal(i, (i + 1) % 6) = 2.0;  // output i = 2 * channel i+1
  for (int s = 0; s < c.analog.sample_count(); ++s) {
    const Eigen::VectorXd wrench = c.analog.values.block<1, 6>(s, 2).transpose();
    Eigen::VectorXd stored(6);
    for (int i = 0; i < 6; ++i) stored((i + 1) % 6) = wrench(i) / 2.0;
    c.analog.values.block<1, 6>(s, 2) = stored.transpose();
  }
  c.force_plates[0].type = 4;
  c.force_plate_cal_matrices = {cal};
  const std::string path = scratch("type4.c3d");
  write_c3d(path, c);
  const C3dFile back = read_c3d(path);
  REQUIRE(back.force_plate_cal_matrices.size() == 1);
  CHECK(back.force_plate_cal_matrices[0].isApprox(cal));
  CHECK(back.force_plates[0].type == 4);
  check_plate(back.force_plates[0], C3dStorage::kFloat);
}

namespace {

/// A capture of one plate (corners kCorners_m) whose channels hold `channels` every sample.
C3dFile single_plate(int type, const std::vector<std::string>& units,
                     const Eigen::VectorXd& channels, const Vector3d& origin_m) {
  C3dFile c;
  c.markers.rate_hz = kRate_Hz;
  c.markers.labels = {"M"};
  c.markers.positions_m = Eigen::MatrixXd::Zero(3, 3);
  c.analog.rate_hz = kRate_Hz;
  c.analog.units = units;
  for (std::size_t i = 0; i < units.size(); ++i)
    c.analog.labels.push_back("ch" + std::to_string(i));
  c.analog.values = channels.transpose().replicate(3, 1);
  ForcePlate p;
  p.type = type;
  p.corners_m = kCorners_m;
  p.origin_m = origin_m;
  for (int i = 0; i < channels.size(); ++i) p.channels.push_back(i);
  c.force_plates = {p};
  return c;
}

}  // namespace

TEST_CASE("Type-1 and type-3 plates give the wrench their channels encode", "[mocap_io][c3d]") {
  constexpr double kTolerance = 1e-6;  // float channels, values of order 1e3
  const Eigen::Matrix3d r = plate_to_lab();
  SECTION("type 1: force, COP (mm) and Tz (N mm) in the plate frame") {
    const Vector3d force_p(20, -35, -700);  // z down: pushing the subject up
    const Vector3d cop_p(0.12, -0.05, 0);   // m from the surface centre
    const double tz = 1.5;                  // N m about the plate's z
    Eigen::VectorXd ch(6);
    ch << force_p, cop_p.head<2>() * 1000, tz * 1000;
    const C3dFile c = single_plate(1, {"N", "N", "N", "mm", "mm", "Nmm"}, ch, Vector3d::Zero());
    const std::string path = scratch("type1.c3d");
    write_c3d(path, c);
    const ForcePlate p = read_c3d(path).force_plates.at(0);
    const Vector3d cop = kCentre_m + r * cop_p, force = r * force_p, free = r * Vector3d(0, 0, tz);
    CHECK((p.force_N.row(0).transpose() - force).norm() < kTolerance * 1e3);
    CHECK((p.cop_m.row(0).transpose() - cop).norm() < kTolerance);
    CHECK((p.free_moment_Nm.row(0).transpose() - free).norm() < kTolerance * 1e3);
    const Vector3d about_centre = (cop - kCentre_m).cross(force) + free;
    CHECK((p.moment_origin_Nm.row(0).transpose() - about_centre).norm() < kTolerance * 1e3);
  }
  SECTION("type 3: eight sensor forces, ORIGIN = (a, b, az0) with az0 stored positive") {
    // A force F applied at the surface point (x, y) of a plate whose sensors sit at (+-a, +-b)
    // and az0 = 50 mm below the surface (Kistler's numbering: 1 +a+b, 2 -a+b, 3 -a-b, 4 +a-b).
    const double a = 0.12, b = 0.20, az0 = -0.05;
    const Vector3d force_p(40, 0, -650);
    const double x = 0.03, y = -0.07;
    // About the sensor origin: M = (x, y, az0) x F; the four Fz carry Mx and My, Fx12 / Fx34
    // carry Mz.
    const Vector3d moment = Vector3d(x, y, az0).cross(force_p);
    const double xe = -moment.y() / force_p.z(), ye = moment.x() / force_p.z();
    const double fz = force_p.z();
    Eigen::VectorXd ch(8);
    ch << (force_p.x() - moment.z() / b) / 2, (force_p.x() + moment.z() / b) / 2, 0, 0,
        fz * (1 + xe / a) * (1 + ye / b) / 4, fz * (1 - xe / a) * (1 + ye / b) / 4,
        fz * (1 - xe / a) * (1 - ye / b) / 4, fz * (1 + xe / a) * (1 - ye / b) / 4;
    const C3dFile c = single_plate(3, std::vector<std::string>(8, "N"), ch,
                                   Vector3d(a, b, -az0));  // stored positive, as Vicon does
    const std::string path = scratch("type3.c3d");
    write_c3d(path, c);
    const ForcePlate p = read_c3d(path).force_plates.at(0);
    const Vector3d cop = kCentre_m + r * Vector3d(x, y, 0), force = r * force_p;
    CHECK((p.force_N.row(0).transpose() - force).norm() < kTolerance * 1e3);
    CHECK((p.cop_m.row(0).transpose() - cop).norm() < kTolerance);
    CHECK(p.free_moment_Nm.row(0).norm() < kTolerance * 1e3);  // a bare force: no free moment
  }
}

TEST_CASE("More than 65535 frames: float POINT:FRAMES, or the TRIAL range", "[mocap_io][c3d]") {
  constexpr int kLong = 70000;
  C3dFile c;
  c.markers.rate_hz = 1000;
  c.markers.first_frame = 2;
  c.markers.labels = {"M"};
  c.markers.positions_m = Eigen::MatrixXd::Zero(kLong, 3);
  for (int f = 0; f < kLong; ++f) c.markers.positions_m(f, 0) = 1e-4 * (f % 1000);
  C3dWriteOptions integer;
  integer.storage = C3dStorage::kInteger;
  const std::string path = scratch("long.c3d");
  write_c3d(path, c, integer);
  const C3dFile back = read_c3d(path);
  CHECK(back.markers.frame_count() == kLong);
  CHECK(back.markers.first_frame == 2);
  CHECK(back.markers.position(kLong - 1, 0).x() == Approx(0.0999).margin(1e-5));
  // The header's 16-bit range (2-65535) cannot say 70000: reported, the parameter used.
  REQUIRE(back.inconsistencies.size() == 1);
  CHECK_THAT(back.inconsistencies[0], Catch::Contains("65534") && Catch::Contains("70000"));

  // The same file with POINT:FRAMES an integer that saturated (65535) or wrapped (70000 - 65536):
  // the TRIAL range gives the count.
  const std::vector<std::uint8_t> bytes = read_bytes(path);
  const std::size_t name = find(bytes, record_prefix(6, 1, "FRAMES")) + 2;
  for (const int stored : {65535, kLong - 65536}) {
    std::vector<std::uint8_t> patched = bytes;
    patched[name + 8] = 2;  // after "FRAMES" and the offset word: type int16, no dimensions
    patched[name + 10] = static_cast<std::uint8_t>(stored & 0xFF);
    patched[name + 11] = static_cast<std::uint8_t>(stored >> 8);
    patched[name + 12] = 0;  // no description
    INFO("POINT:FRAMES " << stored);
    const C3dFile trial = read_c3d(write_bytes("long_trial.c3d", patched));
    CHECK(trial.markers.frame_count() == kLong);
    CHECK_THAT(trial.inconsistencies.at(0), Catch::Contains("TRIAL:ACTUAL_END_FIELD"));
  }
}

TEST_CASE("Calibration matrices of different sizes share CAL_MATRIX", "[mocap_io][c3d]") {
  // A 6x6 (type 4) and an 8x8 (type 3) in one (8, 8, 2) array: each comes back whole.
  C3dFile c;
  c.markers.rate_hz = kRate_Hz;
  c.markers.labels = {"M"};
  c.markers.positions_m = Eigen::MatrixXd::Zero(2, 3);
  c.analog.rate_hz = kRate_Hz;
  for (int i = 0; i < 14; ++i) {
    c.analog.labels.push_back("ch" + std::to_string(i));
    c.analog.units.push_back(i < 3 ? "N" : i < 6 ? "Nmm" : "N");
  }
  c.analog.values = Eigen::MatrixXd::Zero(2, 14);
  ForcePlate four, three;
  four.type = 4;
  four.corners_m = kCorners_m;
  four.channels = {0, 1, 2, 3, 4, 5};
  three.type = 3;
  three.corners_m = kCorners_m;
  three.origin_m = Vector3d(0.12, 0.2, 0.05);
  three.channels = {6, 7, 8, 9, 10, 11, 12, 13};
  c.force_plates = {four, three};
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-2, 2);
  Eigen::MatrixXd six(6, 6), eight(8, 8);
  for (double& v : six.reshaped()) v = u(rng);
  for (double& v : eight.reshaped()) v = u(rng);
  c.force_plate_cal_matrices = {six, eight};
  const std::string path = scratch("two_cal.c3d");
  write_c3d(path, c);
  const C3dFile back = read_c3d(path);
  REQUIRE(back.force_plate_cal_matrices.size() == 2);
  CHECK(back.force_plate_cal_matrices[0].isApprox(six, 1e-7));
  CHECK(back.force_plate_cal_matrices[1].isApprox(eight, 1e-7));
}

TEST_CASE("A header rate of inf is reported like 0, -250 and NaN, and POINT:RATE used",
          "[mocap_io][c3d]") {
  const std::vector<std::uint8_t> walking = read_bytes(kWalking);
  for (const float rate : {std::numeric_limits<float>::infinity(), 0.0f, -250.0f,
                           std::numeric_limits<float>::quiet_NaN()}) {
    INFO("header rate " << rate);
    std::vector<std::uint8_t> bytes = walking;
    std::memcpy(&bytes[20], &rate, 4);  // Intel header words 11-12
    const C3dFile c = read_c3d(write_bytes("header_rate.c3d", bytes));
    REQUIRE(c.inconsistencies.size() == 1);
    CHECK_THAT(c.inconsistencies[0], Catch::Contains("frame rate: the header says ") &&
                                         Catch::Contains("POINT:RATE says 250 Hz") &&
                                         Catch::Contains("used POINT:RATE"));
    CHECK(c.markers.rate_hz == 250.0);
  }
  std::vector<std::uint8_t> bytes = walking;
  const float inf = std::numeric_limits<float>::infinity();
  std::memcpy(&bytes[20], &inf, 4);
  CHECK_THAT(read_c3d(write_bytes("header_rate.c3d", bytes)).inconsistencies[0],
             Catch::Contains("says inf Hz"));
}

TEST_CASE("A parameter section claiming more blocks than lie before the data", "[mocap_io][c3d]") {
  // walking5: parameters from block 2 (byte 512), records ending at byte 6268, data from block
  // 14 (byte 6656): 12 blocks for the parameters, as byte 514 says.
  const std::vector<std::uint8_t> walking = read_bytes(kWalking);
  REQUIRE(walking[514] == 12);
  std::vector<std::uint8_t> bytes = walking;
  bytes[514] = 20;  // claims 20: 8 of them would be data
  const C3dFile c = read_c3d(write_bytes("parameter_blocks.c3d", bytes));
  REQUIRE(c.inconsistencies.size() == 1);
  CHECK_THAT(c.inconsistencies[0], Catch::Contains("byte 514 claims 20 blocks") &&
                                       Catch::Contains("data start at block 14 leaves 12") &&
                                       Catch::Contains("records end at byte 6268"));
  const C3dFile original = read_c3d(kWalking);
  const auto read = c.markers.positions_m.array(), expected = original.markers.positions_m.array();
  CHECK((read == expected || (read.isNaN() && expected.isNaN())).all());

  // The data moved to block 13 (POINT:DATA_START and header word 9), where the records still
  // are: the data would be read from parameter bytes. Refused.
  bytes = walking;
  const std::size_t value = find(walking, record_prefix(10, 3, "DATA_START")) + 2 + 10 + 2 + 2;
  REQUIRE(walking[value - 2] == 2);  // an int16
  REQUIRE(walking[value - 1] == 0);  // scalar
  REQUIRE(walking[value] == 14);
  bytes[value] = 13;
  bytes[16] = 13;  // header word 9
  const std::string path = write_bytes("data_in_parameters.c3d", bytes);
  CHECK_THROWS_WITH(read_c3d(path), Catch::Contains(path + ": byte 6144") &&
                                        Catch::Contains("data section (block 13)") &&
                                        Catch::Contains("parameter records up to byte 6268"));
}

TEST_CASE("C3D labels and units that are not UTF-8 are read as Latin-1", "[mocap_io][c3d]") {
  C3dFile c = synthetic_capture();
  c.markers.labels[0] = "M\xE9";      // Latin-1 "Mé", legal in a C3D
  c.markers.labels[1] = "H\xC3\xBC";  // UTF-8 "Hü": kept
  c.analog.units[0] = "\xB5V";        // Latin-1 "µV"
  const std::string path = scratch("latin1.c3d");
  write_c3d(path, c);
  const C3dFile read = read_c3d(path);
  CHECK(read.markers.labels[0] == "M\xC3\xA9");
  CHECK(read.markers.labels[1] == "H\xC3\xBC");
  CHECK(read.analog.units[0] == "\xC2\xB5V");
  CHECK(read.transcoded_names == 2);
  CHECK(read_c3d(kWalking).transcoded_names == 0);
}
