#pragma once
/// C3D reader and writer (c3d.org, "The C3D File Format User Guide"). The reader handles Intel,
/// DEC and MIPS processor types, integer and float storage, POINT:SCALE, residuals (a negative
/// residual marks an invalid sample: a gap, NaN, never zeros), labels, rate, the frame count
/// from the parameters (POINT:FRAMES, not the header), the first-frame offset, analog channels
/// (offset, scales, units) and force plates (FORCE_PLATFORM types 1-4).
///
/// Pitfalls (references.md): processor byte 84/85/86 = Intel/DEC/MIPS; negative POINT:SCALE =
/// float storage; residual -1 = invalid sample (coordinates often 0,0,0).

#include <string>
#include <vector>

#include "biodyn/mocap_io/marker_data.h"

namespace biodyn::mocap_io {

/// How the numbers of a C3D file are stored (parameter section byte 4).
enum class C3dProcessor { kIntel = 84, kDec = 85, kMips = 86 };
/// Storage of the 3D and analog data (sign of POINT:SCALE).
enum class C3dStorage { kInteger, kFloat };

const char* to_string(C3dProcessor processor);
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
  /// rate), each naming both values and saying which one was used (the parameters). Empty for a
  /// consistent file. Reported by `biodyn mocap info`.
  std::vector<std::string> inconsistencies;
};

/// Reads a C3D file. Throws ParseError naming the file, the byte offset, what was expected and
/// what was found: bad processor byte, truncated data, parameter that points outside the file,
/// missing POINT group, ... Never returns a partial motion.
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
/// analog values carry the signals) as a C3D file with POINT:UNITS "mm". Gaps are written as
/// invalid samples (residual -1, coordinates 0). Throws sim::InvalidArgument for data that
/// cannot be stored (a label longer than 32 characters would be cut: refused; integer storage
/// overflow), sim::Error if the file cannot be written. Whole or not at all.
void write_c3d(const std::string& path, const C3dFile& file, const C3dWriteOptions& options = {});

}  // namespace biodyn::mocap_io
