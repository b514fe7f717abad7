#include "c3d_force_plates.h"

#include <Eigen/Geometry>
#include <cmath>
#include <limits>

#include "c3d_units.h"

namespace biodyn::mocap_io::c3d_internal {
namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;

// C3D User Guide, "TYPE-1" .. "TYPE-4": types 1, 2 and 4 use six channels, type 3 (Kistler) eight.
constexpr int kSixChannels = 6;
constexpr int kKistlerChannels = 8;
constexpr int kCorners = 4;
// Corners whose edges are closer than this to parallel (sine of the angle) span no plane.
constexpr double kMinCornerSine = 1e-6;

int channels_of_type(int type) { return type == 3 ? kKistlerChannels : kSixChannels; }

/// What each of a plate's (calibrated) channels measures.
enum class Quantity { kForce, kMoment, kLength };

Quantity slot_quantity(int type, int slot) {
  if (type == 3) return Quantity::kForce;               // Fx12 Fx34 Fy14 Fy23 Fz1 Fz2 Fz3 Fz4
  if (slot < 3) return Quantity::kForce;                // Fx Fy Fz
  if (type == 1 && slot < 5) return Quantity::kLength;  // COPx COPy (then Tz)
  return Quantity::kMoment;                             // Mx My Mz, Tz
}

/// SI factor for one slot: from the unit of the channel read there when it is a unit of the
/// slot's quantity, else the C3D defaults (N; lengths in POINT:UNITS, moments in N x POINT:UNITS).
double slot_si_factor(Quantity q, const std::string& unit, double point_unit_m) {
  switch (q) {
    case Quantity::kForce:
      return force_unit_N(unit).value_or(1.0);
    case Quantity::kLength:
      return length_unit_m(unit).value_or(point_unit_m);
    case Quantity::kMoment:
      return moment_unit_Nm(unit).value_or(point_unit_m);
  }
  return 1.0;
}

/// The FORCE_PLATFORM parameters and the file, for reading and for error messages.
class PlateParameters {
 public:
  PlateParameters(const ParameterSection& section, const std::string& file)
      : section_(section), file_(file) {}

  const std::string& file() const { return file_; }
  const Parameter* find(const char* name) const { return section_.find("FORCE_PLATFORM", name); }
  /// FORCE_PLATFORM:<name>, which must exist because `used` plates are declared.
  const Parameter& require(const char* name, const Parameter& used) const {
    const Parameter* p = find(name);
    if (p == nullptr) {
      fail_parameter(file_, used, "plates described by FORCE_PLATFORM:" + std::string(name),
                     "no such parameter");
    }
    return *p;
  }
  /// Number i of `p`, which must hold at least `needed` numbers.
  double number(const Parameter& p, std::size_t i, std::size_t needed,
                const std::string& what) const {
    if (p.numbers.size() < needed) {
      fail_parameter(file_, p, "at least " + std::to_string(needed) + " values (" + what + ")",
                     std::to_string(p.numbers.size()));
    }
    return p.numbers[i];
  }

 private:
  const ParameterSection& section_;
  const std::string& file_;
};

/// Columns: the plate's x, y, z axes in the lab (see c3d_force_plates.h).
Matrix3d plate_axes(const ForcePlate& plate, const PlateParameters& params,
                    const Parameter& corners, int index) {
  Vector3d x = plate.corners_m.col(0) - plate.corners_m.col(1);
  const Vector3d y_edge = plate.corners_m.col(0) - plate.corners_m.col(3);
  Vector3d z = x.cross(y_edge);
  if (!(z.norm() > kMinCornerSine * x.norm() * y_edge.norm())) {
    fail_parameter(params.file(), corners,
                   "corners of plate " + std::to_string(index + 1) + " spanning a plane",
                   "corners 1-2 and 1-4 parallel or of zero length");
  }
  x.normalize();
  z.normalize();
  Matrix3d axes;
  axes << x, z.cross(x), z;
  return axes;
}

/// m, plate frame: the vector from the sensor origin to the surface centre (z <= 0).
Vector3d sensor_to_surface(const ForcePlate& plate) {
  Vector3d r = plate.origin_m;
  if (plate.type == 3) return Vector3d(0, 0, -std::fabs(r.z()));  // x, y are a and b
  if (plate.type == 1) return Vector3d::Zero();  // COP and Tz are given at the surface
  return r.z() > 0 ? Vector3d(-r) : r;
}

/// Reads TYPE, CORNERS, ORIGIN and CHANNEL of plate `index`.
ForcePlate plate_description(const PlateParameters& params, const Parameter& used, int index,
                             int analog_channels, double point_unit_m) {
  const auto p = static_cast<std::size_t>(index);
  const std::string plate_name = "plate " + std::to_string(index + 1);
  ForcePlate plate;
  const Parameter& type = params.require("TYPE", used);
  plate.type = static_cast<int>(params.number(type, p, p + 1, "one per plate"));
  if (plate.type < 1 || plate.type > 4) {
    fail_parameter(params.file(), type,
                   "1, 2, 3 or 4 for " + plate_name +
                       " (types 5+ are not "
                       "supported)",
                   format_number(type.numbers[p]));
  }
  const Parameter& corners = params.require("CORNERS", used);
  const std::size_t corner_values = 3 * kCorners;
  for (int c = 0; c < kCorners; ++c) {
    for (int k = 0; k < 3; ++k) {
      const std::size_t i = corner_values * p + 3 * static_cast<std::size_t>(c) + k;
      plate.corners_m(k, c) =
          params.number(corners, i, corner_values * (p + 1), "(3, 4, plates)") * point_unit_m;
    }
  }
  const Parameter& origin = params.require("ORIGIN", used);
  for (int k = 0; k < 3; ++k) {
    plate.origin_m(k) = params.number(origin, 3 * p + k, 3 * (p + 1), "(3, plates)") * point_unit_m;
  }
  const Parameter& channel = params.require("CHANNEL", used);
  const int needed = channels_of_type(plate.type);
  const std::size_t stride =
      channel.dimensions.empty() ? channel.numbers.size() : std::size_t(channel.dimensions[0]);
  if (stride < static_cast<std::size_t>(needed)) {
    fail_parameter(params.file(), channel,
                   "at least " + std::to_string(needed) + " channels per plate for " + plate_name,
                   std::to_string(stride));
  }
  for (int k = 0; k < needed; ++k) {
    const std::size_t i = stride * p + static_cast<std::size_t>(k);
    const double one_based = params.number(channel, i, stride * (p + 1), "(channels, plates)");
    if (!(one_based >= 1 && one_based <= analog_channels) || one_based != std::floor(one_based)) {
      fail_parameter(
          params.file(), channel,
          "analog channel numbers 1.." + std::to_string(analog_channels) + " for " + plate_name,
          format_number(one_based));
    }
    plate.channels.push_back(static_cast<int>(one_based) - 1);
  }
  return plate;
}

/// CAL_MATRIX of plate `index` (n x n; rows are outputs), or empty when it has none. A type-4
/// plate must have one.
Eigen::MatrixXd calibration(const PlateParameters& params, const Parameter& used,
                            const ForcePlate& plate, int index) {
  if (plate.type != 3 && plate.type != 4) return {};
  const int n = channels_of_type(plate.type);
  const Parameter* cal = params.find("CAL_MATRIX");
  const auto p = static_cast<std::size_t>(index);
  const bool usable = cal != nullptr && cal->dimensions.size() >= 2 && cal->dimensions[0] >= n &&
                      cal->dimensions[1] >= n &&
                      cal->numbers.size() >= std::size_t(cal->dimensions[0]) *
                                                 std::size_t(cal->dimensions[1]) * (p + 1);
  if (!usable) {
    if (plate.type == 3) return {};  // optional for type 3
    fail_parameter(params.file(), cal != nullptr ? *cal : used,
                   "a 6x6 calibration matrix (CAL_MATRIX (6, 6, plates)) for type-4 plate " +
                       std::to_string(index + 1),
                   cal != nullptr ? "too few dimensions or values" : "no CAL_MATRIX");
  }
  const auto rows = static_cast<std::size_t>(cal->dimensions[0]);
  const std::size_t first = rows * static_cast<std::size_t>(cal->dimensions[1]) * p;
  Eigen::MatrixXd m(n, n);
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) {  // FORTRAN order: the row index varies fastest
      m(i, j) = cal->numbers[first + static_cast<std::size_t>(i) + rows * std::size_t(j)];
    }
  }
  return m;
}

/// The plate-frame wrench of one sample: force and moment about the surface centre, SI.
struct Wrench {
  Vector3d force_N;
  Vector3d moment_Nm;
};

/// `ch`: the plate's channel values after calibration, in SI (C3D User Guide, "TYPE-1" to
/// "TYPE-4"; the type-3 (Kistler) formulas as Visual3D's "FP Type 3" page gives them).
Wrench surface_wrench(const ForcePlate& plate, const Eigen::VectorXd& ch, const Vector3d& r) {
  Wrench w;
  switch (plate.type) {
    case 1: {  // Fx Fy Fz, COP x y on the surface, Tz: the moment is that of F at the COP + Tz
      w.force_N = ch.head<3>();
      w.moment_Nm = Vector3d(ch(3), ch(4), 0).cross(w.force_N) + Vector3d(0, 0, ch(5));
      break;
    }
    case 3: {  // Fx12 Fx34 Fy14 Fy23 Fz1..Fz4; ORIGIN = (a, b, az0)
      const double a = plate.origin_m.x(), b = plate.origin_m.y();
      w.force_N = Vector3d(ch(0) + ch(1), ch(2) + ch(3), ch(4) + ch(5) + ch(6) + ch(7));
      const Vector3d sensor_moment(b * (ch(4) + ch(5) - ch(6) - ch(7)),
                                   a * (-ch(4) + ch(5) + ch(6) - ch(7)),
                                   b * (-ch(0) + ch(1)) + a * (ch(2) - ch(3)));
      w.moment_Nm = sensor_moment + w.force_N.cross(r);
      break;
    }
    default: {  // 2, 4: Fx Fy Fz Mx My Mz about the sensor origin
      w.force_N = ch.head<3>();
      // M_centre = M_origin + (origin - centre) x F = M_origin + F x r.
      w.moment_Nm = ch.segment<3>(3) + w.force_N.cross(r);
      break;
    }
  }
  return w;
}

/// Fills force_N, moment_origin_Nm, cop_m and free_moment_Nm for every analog sample.
void compute_ground_reaction(ForcePlate* plate, const Eigen::MatrixXd& cal,
                             const AnalogData& analog, const Matrix3d& axes, double point_unit_m) {
  const int n = channels_of_type(plate->type);
  Eigen::VectorXd si(n);
  for (int k = 0; k < n; ++k) {
    const auto channel = static_cast<std::size_t>(plate->channels[static_cast<std::size_t>(k)]);
    const std::string unit = channel < analog.units.size() ? analog.units[channel] : "";
    si(k) = slot_si_factor(slot_quantity(plate->type, k), unit, point_unit_m);
  }
  const Vector3d r = sensor_to_surface(*plate);
  const Vector3d centre = plate->center_m();
  const int samples = analog.sample_count();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  plate->force_N.resize(samples, 3);
  plate->moment_origin_Nm.resize(samples, 3);
  plate->cop_m.resize(samples, 3);
  plate->free_moment_Nm.resize(samples, 3);
  Eigen::VectorXd ch(n);
  for (int s = 0; s < samples; ++s) {
    for (int k = 0; k < n; ++k) ch(k) = analog.values(s, plate->channels[std::size_t(k)]);
    if (cal.size() != 0) ch = cal * ch;
    ch = ch.cwiseProduct(si);
    const Wrench w = surface_wrench(*plate, ch, r);
    plate->force_N.row(s) = (axes * w.force_N).transpose();
    plate->moment_origin_Nm.row(s) = (axes * w.moment_Nm).transpose();
    const double fz = w.force_N.z();
    // The plate's z axis points into it: a ground reaction pushing the subject has fz < 0. An
    // offset that "pulls" is no load, however large.
    if (!(-fz >= kUnloadedForce_N)) {
      plate->cop_m.row(s).setConstant(nan);
      plate->free_moment_Nm.row(s).setConstant(nan);
      continue;
    }
    // The COP is where the force's moment about the surface centre has no horizontal part:
    // M = cop x F + (0, 0, Tz) with cop = (x, y, 0).
    const Vector3d cop(-w.moment_Nm.y() / fz, w.moment_Nm.x() / fz, 0.0);
    const double tz = w.moment_Nm.z() - cop.cross(w.force_N).z();
    plate->cop_m.row(s) = (centre + axes * cop).transpose();
    plate->free_moment_Nm.row(s) = (axes * Vector3d(0, 0, tz)).transpose();
  }
}

}  // namespace

ForcePlates read_force_plates(const ParameterSection& parameters, const AnalogData& analog,
                              double point_unit_m, const std::string& file) {
  ForcePlates out;
  const PlateParameters params(parameters, file);
  const Parameter* used = params.find("USED");
  if (used == nullptr) return out;
  const long count = count_value(file, *used, "number of force plates", 0, 255);
  for (int i = 0; i < count; ++i) {
    ForcePlate plate = plate_description(params, *used, i, analog.channel_count(), point_unit_m);
    const Matrix3d axes = plate_axes(plate, params, *params.find("CORNERS"), i);
    Eigen::MatrixXd cal = calibration(params, *used, plate, i);
    compute_ground_reaction(&plate, cal, analog, axes, point_unit_m);
    out.plates.push_back(std::move(plate));
    out.cal_matrices.push_back(std::move(cal));
  }
  return out;
}

}  // namespace biodyn::mocap_io::c3d_internal
