#pragma once
/// TRC (track row column, OpenSim / Motion Analysis) marker files: a 5-line header (path line,
/// the DataRate ... OrigNumFrames keys and their values, the marker labels, X1 Y1 Z1 ...
/// column names), then one row per frame: Frame#, Time, x y z per marker. A gap is "NaN", an
/// empty field or exactly 0 0 0 (all three occur in the wild; OpenSim writes 0 0 0).

#include <string>
#include <vector>

#include "biodyn/mocap_io/marker_data.h"

namespace biodyn::mocap_io {

/// A TRC file's contents; positions converted from its Units to metres.
struct TrcFile {
  /// times_s holds the Time column; first_frame the first Frame#; rate_hz the header's DataRate.
  MarkerData markers;
  std::string units;  ///< the file's Units ("mm", "cm" or "m")
  /// Places where the header and the rows disagree (NumFrames vs rows, DataRate vs the Time
  /// column's spacing), each naming both values and saying which one was used. Empty for a
  /// consistent file.
  std::vector<std::string> inconsistencies;
  /// Samples stored as exactly 0 0 0, read as gaps (NaN in markers, counted by gap_count).
  int zero_samples = 0;
  /// Marker labels that were not UTF-8, read as Latin-1 (to_utf8 in utf8.h).
  int transcoded_names = 0;
  long rate_line = 0;           ///< line of the header values (DataRate), for messages
  std::vector<long> row_lines;  ///< line of each row (frame f on row_lines[f]), for messages
};

/// The one rate at which a TRC file's rows can be written to a format that stores a rate and
/// no times (C3D), and why it is not DataRate when it is not.
struct TrcUniformRate {
  double rate_hz = 0.0;  ///< Hz
  /// Empty when DataRate is the rate; else names both rates and says the Time column's was
  /// used.
  std::string note;
};

/// The rate of `file`'s rows for a writer that stores one rate (C3D): DataRate when the Time
/// column steps at it (within 0.1%) or there is one row, else the Time column's own rate (see
/// the note). Throws ParseError naming `source`, the line of the first row whose time is off an
/// even spacing (by more than a quarter of a step), both rates and the time found: such rows
/// cannot be written at one rate without resampling.
TrcUniformRate uniform_rate(const TrcFile& file, const std::string& source);

/// Parses TRC text; `source` names the file in errors. Throws ParseError naming the line, what
/// was expected and what was found (missing header key, unknown Units, label count against
/// NumMarkers, a row with the wrong number of fields or a non-number, no rows). Never returns
/// a partial motion.
TrcFile parse_trc(const std::string& text, const std::string& source);
/// Reads a TRC file (parse_trc of its contents; sim::InvalidArgument if it cannot be read).
TrcFile read_trc(const std::string& path);

/// TRC text of `markers` in `units` ("mm" or "m"), values to `precision` significant digits,
/// gaps as NaN. Frame numbers start at markers.first_frame; times are markers.time_s(f).
/// `file_name` goes into the PathFileType line. Throws sim::InvalidArgument for other units.
std::string format_trc(const MarkerData& markers, const std::string& units = "mm",
                       const std::string& file_name = "", int precision = 10);
/// Writes format_trc(...) to `path` whole or not at all; throws sim::Error if it cannot.
void write_trc(const std::string& path, const MarkerData& markers, const std::string& units = "mm",
               int precision = 10);

}  // namespace biodyn::mocap_io
