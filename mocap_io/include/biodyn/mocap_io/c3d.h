#pragma once
/// C3D reader and writer (c3d.org, "The C3D File Format User Guide"). The reader handles Intel,
/// DEC and MIPS processor types, integer and float storage, POINT:SCALE, residuals (a negative
/// residual marks an invalid sample: a gap, NaN, never zeros), labels, rate, the frame count
/// from the parameters (POINT:FRAMES, not the header), the first-frame offset, analog channels
/// (offset, scales, units) and force plates (FORCE_PLATFORM types 1-4).
///
/// Pitfalls (references.md): processor byte 84/85/86 = Intel/DEC/MIPS; negative POINT:SCALE =
/// float storage; residual -1 = invalid sample (coordinates often 0,0,0).

#include <Eigen/Core>
#include <string>
#include <vector>

#include "biodyn/mocap_io/marker_data.h"

namespace biodyn::mocap_io {

/// How the numbers of a C3D file are stored (parameter section byte 4).
enum class C3dProcessor { kIntel = 84, kDec = 85, kMips = 86 };
/// Storage of the 3D and analog data (sign of POINT:SCALE).
enum class C3dStorage { kInteger, kFloat };

/// "Intel", "DEC" or "MIPS".
const char* to_string(C3dProcessor processor);
/// "integer" or "float".
const char* to_string(C3dStorage storage);

/// A C3D file's contents in SI units, lab frame of the file.
struct C3dFile {
  MarkerData markers;
  AnalogData analog;
  std::vector<ForcePlate> force_plates;
  C3dProcessor processor = C3dProcessor::kIntel;
  C3dStorage storage = C3dStorage::kFloat;
  std::string point_units;  ///< POINT:UNITS as written (e.g. "mm"); positions are in metres
  /// Places where the header and the parameters disagree (e.g. the header's frame count or
  /// rate), each naming both values and saying which one was used (the parameters), and
  /// defaults taken for missing parameters (e.g. no POINT:UNITS: mm assumed). Empty for a
  /// consistent file. Reported by `biodyn mocap info`.
  std::vector<std::string> inconsistencies;
  /// Labels and units (POINT:LABELS, ANALOG:LABELS, ANALOG:UNITS) that were not UTF-8, read as
  /// Latin-1 (to_utf8 in utf8.h); every string in this struct is UTF-8.
  int transcoded_names = 0;
  /// FORCE_PLATFORM:CAL_MATRIX per plate of force_plates (same order): 6x6 for type 4, 8x8 for a
  /// type-3 plate whose file has one, else empty. Rows are the calibrated outputs (Fx Fy Fz Mx My
  /// Mz for type 4), columns the plate's channels. Applied by read_c3d; write_c3d writes it back
  /// (a type-4 plate cannot be written without it).
  std::vector<Eigen::MatrixXd> force_plate_cal_matrices;
};

/// Reads a C3D file. The parameters decide the layout; where the header disagrees it is noted in
/// C3dFile::inconsistencies. Frame count: POINT:FRAMES, except for an integer that could not hold
/// it: 65535 ("at least 65535") with POINT:LONG_FRAMES present, or 65535 or the count modulo
/// 65536 (overflowed) when TRIAL:ACTUAL_END_FIELD - ACTUAL_START_FIELD + 1 exceeds 65535; the
/// header's 16-bit range is never the fallback (C3D User Guide, "Reading the frame count").
/// First frame: TRIAL:ACTUAL_START_FIELD (32 bits) when present, else header word 4. Positions:
/// POINT:UNITS (mm, cm or m) to metres. Analog: (stored - OFFSET) * SCALE * GEN_SCALE in the
/// channel's own units, offsets unsigned when ANALOG:FORMAT is "UNSIGNED". Force plates: see
/// ForcePlate and mocap_io/src/c3d_force_plates.h for the conventions (ground reaction on the
/// subject; moments in N m whatever ANALOG:UNITS says, "Nmm" included).
///
/// Throws sim::InvalidArgument if the file cannot be opened, and ParseError naming the file,
/// the byte offset, what was expected and what was found for anything malformed: a file shorter
/// than the header, no C3D key, a parameter section pointer outside the file, a bad processor
/// byte, a parameter record running past its section or of an unknown type or dimension count,
/// no POINT group or POINT:USED, a negative or fractional count, a rate <= 0, unknown
/// POINT:UNITS, parameter records running into the data section, a data section shorter than
/// the parameters say (truncated), an unsupported or incomplete force plate. Never returns a
/// partial motion. Labels are UTF-8 (C3dFile::transcoded_names).
C3dFile read_c3d(const std::string& path);

/// Options of write_c3d.
struct C3dWriteOptions {
  C3dProcessor processor = C3dProcessor::kIntel;
  C3dStorage storage = C3dStorage::kFloat;
  /// mm per stored integer unit for kInteger storage (POINT:SCALE); positions are written in
  /// millimetres, so 0.1 keeps 0.1 mm resolution and +-3.2 m range.
  double integer_scale_mm = 0.1;
};

/// Writes markers, analog channels and force plates (their corners, origin and channels; the
/// analog values carry the signals) as a C3D file with POINT:UNITS "mm". Gaps (a sample with
/// any non-finite coordinate) are written as invalid samples (residual -1, coordinates 0); valid
/// samples with residual 0 (the guide's "processed, not measured": MarkerData keeps no residuals).
/// Analog channels are written with OFFSET 0 and, for integer storage, SCALE = largest |value| /
/// 32000 per channel; the analog rate must be a whole multiple of the marker rate. The frame range
/// also goes to TRIAL:ACTUAL_START_FIELD / ACTUAL_END_FIELD. Throws sim::InvalidArgument for data
/// that cannot be stored (a label longer than 32 characters would be cut: refused; integer storage
/// overflow; non-finite analog values; a plate of type other than 1-4, with the wrong number of
/// channels, or of type 4 without its calibration matrix), sim::Error if the file cannot be
/// written. Whole or not at all: written to "<path>.tmp", then renamed over `path`.
void write_c3d(const std::string& path, const C3dFile& file, const C3dWriteOptions& options = {});

}  // namespace biodyn::mocap_io
