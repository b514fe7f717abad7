#pragma once
/// Private to mocap_io: force plates from the FORCE_PLATFORM group and the analog channels (C3D
/// User Guide, "The FORCE_PLATFORM group", "TYPE-1" ... "TYPE-4").
///
/// Conventions (those of ezc3d, which OpenSim's C3DFileAdapter uses, and of Visual3D's force
/// platform documentation; walking5's plates match OpenSim's output to its 8 printed decimals):
/// - Plate frame from CORNERS: x along corner 1 - corner 2, y along corner 1 - corner 4, z = x
///   cross y (corners are numbered by the plate's quadrants +x+y, -x+y, -x-y, +x-y; "CORNERS").
///   For a plate set up as the guide says, z points down, into the plate.
/// - ORIGIN, plate frame, POINT:UNITS: the vector from the plate's sensor origin to the centre of
///   its surface, z <= 0 ("ORIGIN": "the sign entered in ORIGIN(3) will be negative"). Files
///   that store it with z > 0 (Vicon Nexus, walking5) have it reversed: types 2 and 4 negate the
///   vector (as ezc3d and Visual3D do), type 3 its z only (its x and y are the sensors' half
///   spacings a and b, not a position; ezc3d negates them too).
/// - Type 1 channels are Fx Fy Fz, the COP's x and y relative to the surface centre, and Tz;
///   the moment about the centre is cop x F + Tz (ezc3d reports the opposite sign).
/// - The channels' force rotated to the lab is the ground reaction: the force the plate exerts
///   on the subject (upward while standing). Moments follow the same wrench.
/// - FORCE_PLATFORM:ZERO is not applied (neither ezc3d nor OpenSim do): values are as stored.
/// - CAL_MATRIX (FORTRAN order, the row index fastest) maps a type-4 plate's six channels, and
///   a type-3 plate's eight when the file has an 8x8 one, to calibrated outputs.

#include <Eigen/Core>
#include <string>
#include <vector>

#include "biodyn/mocap_io/marker_data.h"
#include "c3d_parameters.h"

namespace biodyn::mocap_io::c3d_internal {

/// Normal ground reaction (pushing the subject off the plate) below which a plate counts as
/// unloaded and its centre of pressure and free moment are NaN. biodyn's choice, at the top of
/// the 10-20 N foot-contact thresholds common in gait analysis: the offsets of an unloaded
/// plate reach 10-20 N in walking5 (and pull, the wrong way, up to 25 N).
constexpr double kUnloadedForce_N = 20.0;

/// Every plate of FORCE_PLATFORM:USED with its per-sample ground reaction.
struct ForcePlates {
  std::vector<ForcePlate> plates;
  /// Per plate: CAL_MATRIX as applied (6x6 type 4; 8x8 type 3 when the file has one), else empty.
  std::vector<Eigen::MatrixXd> cal_matrices;
};

/// Reads the FORCE_PLATFORM group (absent or USED = 0: no plates) and computes each plate's
/// force, moment about the surface centre, centre of pressure and free moment in the lab frame,
/// SI, for every sample of `analog`. `point_unit_m`: metres per POINT:UNITS, the unit of CORNERS
/// and ORIGIN, and of moments whose channel states no known unit (N per POINT unit; a force
/// channel without a known unit is taken as N). Throws ParseError naming the parameter for a
/// TYPE other than 1-4, arrays too short for USED plates, a CHANNEL outside the analog channels,
/// corners that span no plane, a type-4 plate without a 6x6 CAL_MATRIX.
ForcePlates read_force_plates(const ParameterSection& parameters, const AnalogData& analog,
                              double point_unit_m, const std::string& file);

}  // namespace biodyn::mocap_io::c3d_internal
