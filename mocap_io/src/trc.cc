#include "biodyn/mocap_io/trc.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <map>
#include <sstream>

#include "biodyn/mocap_io/errors.h"
#include "biodyn/mocap_io/utf8.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/file_io.h"

namespace biodyn::mocap_io {
namespace {

/// Relative difference between DataRate and the Time column's rate above which the header and
/// the rows are reported as disagreeing (TRC files print times to ~6 digits).
constexpr double kRateMismatchTolerance = 1e-3;
/// uniform_rate: a row's time may be this fraction of a step off an even spacing (times printed
/// to 6 significant digits are off by at most 6% of a 120 Hz step at 100 s); more would put a
/// sample in another frame's slot.
constexpr double kEvenSpacingTolerance = 0.25;
/// uniform_rate: a Time column rate this close (relative) to a whole number of Hz is that number
/// (capture rates are whole: 50, 100, 120, 250 Hz; printed times give the mean step to ~1e-6).
constexpr double kWholeRateTolerance = 1e-4;

/// One line of the file with its 1-based number.
struct Line {
  long number = 0;
  std::string text;
};

std::vector<Line> split_lines(const std::string& text) {
  std::vector<Line> lines;
  std::istringstream in(text);
  std::string s;
  long n = 0;
  while (std::getline(in, s)) {
    ++n;
    if (!s.empty() && s.back() == '\r') s.pop_back();
    lines.push_back({n, s});
  }
  return lines;
}

bool blank(const std::string& s) {
  return std::all_of(s.begin(), s.end(), [](char c) { return c == ' ' || c == '\t'; });
}

std::string trim(const std::string& s) {
  const size_t b = s.find_first_not_of(" \t");
  if (b == std::string::npos) return "";
  const size_t e = s.find_last_not_of(" \t");
  return s.substr(b, e - b + 1);
}

/// Fields of a line: tab-separated when it has tabs (empty fields kept: a gap in a data row),
/// else whitespace-separated (some writers use spaces).
std::vector<std::string> split_fields(const std::string& s) {
  std::vector<std::string> fields;
  if (s.find('\t') != std::string::npos) {
    size_t start = 0;
    while (true) {
      const size_t tab = s.find('\t', start);
      fields.push_back(
          trim(s.substr(start, tab == std::string::npos ? std::string::npos : tab - start)));
      if (tab == std::string::npos) break;
      start = tab + 1;
    }
  } else {
    std::istringstream in(s);
    std::string f;
    while (in >> f) fields.push_back(f);
  }
  return fields;
}

/// Parses a whole field as a number ("NaN" included); false if it is not one.
bool parse_number(const std::string& s, double* value) {
  if (s.empty()) return false;
  errno = 0;
  char* end = nullptr;
  *value = std::strtod(s.c_str(), &end);
  return *end == '\0' && errno != ERANGE;
}

double metres_per_unit(const std::string& units, const std::string& source, long line) {
  if (units == "mm") return 1e-3;
  if (units == "cm") return 1e-2;
  if (units == "m") return 1.0;
  throw ParseError(source, ParseError::line(line), "Units mm, cm or m", "'" + units + "'");
}

std::string number_text(double v) {
  std::ostringstream s;
  s.precision(8);
  s << v;
  return s.str();
}

/// Line i of the file; throws ParseError (expected `expected`, found the end of the file) when
/// the file is shorter.
const Line& line_at(const std::vector<Line>& lines, size_t i, const std::string& expected,
                    const std::string& source) {
  if (i >= lines.size()) {
    throw ParseError(source, ParseError::line(static_cast<long>(lines.size()) + 1), expected,
                     "end of file");
  }
  return lines[i];
}

/// What lines 1-3 state: the header keys' values that parse_trc uses.
struct TrcHeader {
  long value_line = 0;   ///< number of the values line (line 3), for errors naming a value
  double rate_hz = 0.0;  ///< DataRate, Hz
  double num_frames = 0.0;
  double num_markers = 0.0;  ///< a whole number >= 1
  std::string units;         ///< Units: mm, cm or m
  double metres_per_unit = 1.0;
};

/// Lines 1-3: "PathFileType 4 (X/Y/Z) name", the header keys and their values. Throws
/// ParseError for a file that is not TRC, a key missing or a value out of its range.
TrcHeader parse_header(const std::vector<Line>& lines, const std::string& source) {
  const Line& path_line = line_at(lines, 0, "the PathFileType line", source);
  if (path_line.text.rfind("PathFileType", 0) != 0) {
    throw ParseError(source, ParseError::line(1), "'PathFileType' (a TRC file)",
                     "'" + path_line.text.substr(0, 40) + "'");
  }
  const Line& key_line = line_at(lines, 1, "the header keys (DataRate, NumFrames, ...)", source);
  const Line& value_line = line_at(lines, 2, "the header values", source);
  const std::vector<std::string> keys = split_fields(key_line.text);
  const std::vector<std::string> values = split_fields(value_line.text);
  if (values.size() < keys.size()) {
    throw ParseError(source, ParseError::line(value_line.number),
                     std::to_string(keys.size()) + " header values (one per key on line " +
                         std::to_string(key_line.number) + ")",
                     std::to_string(values.size()));
  }
  std::map<std::string, std::string> header;
  for (size_t i = 0; i < keys.size(); ++i) header[keys[i]] = values[i];
  auto header_number = [&](const std::string& key) {
    const auto it = header.find(key);
    if (it == header.end()) {
      throw ParseError(source, ParseError::line(key_line.number), "the header key " + key,
                       "'" + key_line.text.substr(0, 80) + "'");
    }
    double v = 0.0;
    if (!parse_number(it->second, &v) || !std::isfinite(v)) {
      throw ParseError(source, ParseError::line(value_line.number), key + " as a number",
                       "'" + it->second + "'");
    }
    return v;
  };
  TrcHeader h;
  h.value_line = value_line.number;
  h.rate_hz = header_number("DataRate");
  if (!(h.rate_hz > 0.0)) {
    throw ParseError(source, ParseError::line(value_line.number), "DataRate > 0",
                     number_text(h.rate_hz));
  }
  h.num_frames = header_number("NumFrames");
  h.num_markers = header_number("NumMarkers");
  if (h.num_markers < 1 || h.num_markers != std::floor(h.num_markers)) {
    throw ParseError(source, ParseError::line(value_line.number), "NumMarkers a whole number >= 1",
                     number_text(h.num_markers));
  }
  const auto units_it = header.find("Units");
  if (units_it == header.end()) {
    throw ParseError(source, ParseError::line(key_line.number), "the header key Units",
                     "'" + key_line.text.substr(0, 80) + "'");
  }
  h.units = units_it->second;
  h.metres_per_unit = metres_per_unit(h.units, source, value_line.number);
  return h;
}

/// Line 4, "Frame# Time label..." (each label followed by two empty columns): the marker
/// labels. Throws ParseError unless it has the Frame# and Time columns and `count` labels.
std::vector<std::string> parse_labels(const std::vector<Line>& lines, int count,
                                      const std::string& source, int* transcoded) {
  const Line& label_line = line_at(lines, 3, "the marker labels line (Frame# Time ...)", source);
  const std::vector<std::string> label_fields = split_fields(label_line.text);
  if (label_fields.size() < 2 || label_fields[0] != "Frame#" || label_fields[1] != "Time") {
    throw ParseError(source, ParseError::line(label_line.number), "'Frame#' and 'Time' columns",
                     "'" + label_line.text.substr(0, 40) + "'");
  }
  std::vector<std::string> labels;
  for (size_t i = 2; i < label_fields.size(); ++i) {
    if (label_fields[i].empty()) continue;
    labels.push_back(to_utf8(label_fields[i]));
    *transcoded += labels.back() != label_fields[i] ? 1 : 0;
  }
  if (static_cast<int>(labels.size()) != count) {
    throw ParseError(source, ParseError::line(label_line.number),
                     std::to_string(count) + " marker labels (NumMarkers)",
                     std::to_string(labels.size()));
  }
  // A label names one marker: two columns of one name would be read as one marker's.
  std::map<std::string, size_t> first_marker;
  for (size_t i = 0; i < labels.size(); ++i) {
    const auto [it, is_new] = first_marker.emplace(labels[i], i);
    if (is_new) continue;
    throw ParseError(source, ParseError::line(label_line.number), "distinct marker labels",
                     "'" + labels[i] + "' twice (markers " + std::to_string(it->second + 1) +
                         " and " + std::to_string(i + 1) + ")");
  }
  return labels;
}

/// The data rows, from line 6 on (blank lines skipped), with positions in metres.
struct TrcRows {
  std::vector<std::vector<double>> positions_m;  ///< per row: x, y, z per marker; NaN for a gap
  std::vector<double> times_s;                   ///< the Time column, increasing
  std::vector<long> lines;                       ///< each row's line number
  int first_frame = 1;                           ///< the first row's Frame#
  int zero_samples = 0;                          ///< samples stored as exactly 0 0 0, read as gaps
};

/// One data row's marker coordinates (fields after Frame# and Time) times `scale`, in m; a
/// marker with any coordinate missing is a gap in all three, and so is one stored as exactly
/// 0 0 0 (counted in *zero_samples). Throws ParseError naming the marker and axis of a field
/// that is not a finite number, NaN or empty.
std::vector<double> parse_row(const std::vector<std::string>& fields,
                              const std::vector<std::string>& labels, double scale,
                              const Line& line, const std::string& source, int* zero_samples) {
  std::vector<double> row(3 * labels.size());
  for (size_t k = 0; k < row.size(); ++k) {
    const std::string& f = fields[2 + k];
    double v = std::numeric_limits<double>::quiet_NaN();
    // inf (or a number that overflows once scaled) is no position and no gap marker.
    if ((!f.empty() && !parse_number(f, &v)) || std::isinf(v) || std::isinf(v * scale)) {
      throw ParseError(
          source, ParseError::line(line.number),
          "a finite number, NaN or an empty field for " + labels[k / 3] + " " + "XYZ"[k % 3],
          "'" + f + "'");
    }
    row[k] = v * scale;
  }
  // A gap is a gap in all three coordinates. OpenSim writes a missing sample as 0 0 0: a marker
  // exactly at the lab origin to every printed digit is that, not a measurement.
  for (size_t k = 0; k < row.size(); k += 3) {
    const bool zeros = row[k] == 0.0 && row[k + 1] == 0.0 && row[k + 2] == 0.0;
    *zero_samples += zeros ? 1 : 0;
    if (zeros || std::isnan(row[k]) || std::isnan(row[k + 1]) || std::isnan(row[k + 2])) {
      row[k] = row[k + 1] = row[k + 2] = std::numeric_limits<double>::quiet_NaN();
    }
  }
  return row;
}

/// The rows after line 5. Throws ParseError for a row with the wrong number of fields, no
/// frame number or time, a time not after the previous row's, a bad coordinate, or no rows.
TrcRows parse_rows(const std::vector<Line>& lines, const std::vector<std::string>& labels,
                   double scale, const std::string& source) {
  const size_t columns = 2 + 3 * labels.size();
  TrcRows rows;
  for (size_t i = 5; i < lines.size(); ++i) {
    if (blank(lines[i].text)) continue;
    std::vector<std::string> fields = split_fields(lines[i].text);
    // Trailing empty fields (a trailing tab) are not data.
    while (fields.size() > columns && fields.back().empty()) fields.pop_back();
    if (fields.size() != columns) {
      throw ParseError(source, ParseError::line(lines[i].number),
                       std::to_string(columns) + " fields (Frame#, Time and 3 per marker)",
                       std::to_string(fields.size()) + " fields");
    }
    double frame = 0.0, time = 0.0;
    if (!parse_number(fields[0], &frame) || !parse_number(fields[1], &time) ||
        !std::isfinite(time)) {
      throw ParseError(source, ParseError::line(lines[i].number), "a frame number and a time",
                       "'" + fields[0] + "', '" + fields[1] + "'");
    }
    if (!rows.times_s.empty() && !(time > rows.times_s.back())) {
      throw ParseError(source, ParseError::line(lines[i].number),
                       "a time later than the previous row's " + number_text(rows.times_s.back()),
                       number_text(time));
    }
    if (rows.positions_m.empty()) rows.first_frame = static_cast<int>(frame);
    rows.positions_m.push_back(
        parse_row(fields, labels, scale, lines[i], source, &rows.zero_samples));
    rows.times_s.push_back(time);
    rows.lines.push_back(lines[i].number);
  }
  if (rows.positions_m.empty()) {
    throw ParseError(source, ParseError::line(static_cast<long>(lines.size()) + 1),
                     "at least one data row", "end of file");
  }
  return rows;
}

/// Where the header and the rows disagree (the rows win); throws ParseError for fewer rows
/// than NumFrames (a truncated file). More rows are reported and read.
std::vector<std::string> check_rows_against_header(const TrcHeader& h, const TrcRows& rows,
                                                   const std::vector<Line>& lines,
                                                   const std::string& source) {
  std::vector<std::string> inconsistencies;
  const size_t count = rows.positions_m.size();
  if (h.num_frames > static_cast<double>(count)) {
    throw ParseError(source, ParseError::line(static_cast<long>(lines.size()) + 1),
                     number_text(h.num_frames) + " rows (NumFrames on line " +
                         std::to_string(h.value_line) + ")",
                     std::to_string(count) + " rows (a truncated file?)");
  }
  if (h.num_frames < static_cast<double>(count)) {
    inconsistencies.push_back("NumFrames is " + number_text(h.num_frames) + " but there are " +
                              std::to_string(count) + " rows; all rows are read");
  }
  const std::vector<double>& times = rows.times_s;
  if (times.size() >= 2) {
    std::vector<double> steps;
    for (size_t i = 1; i < times.size(); ++i) steps.push_back(times[i] - times[i - 1]);
    std::nth_element(steps.begin(), steps.begin() + steps.size() / 2, steps.end());
    const double median_step = steps[steps.size() / 2];
    if (std::abs(median_step * h.rate_hz - 1.0) > kRateMismatchTolerance) {
      inconsistencies.push_back("DataRate is " + number_text(h.rate_hz) +
                                " Hz but the Time column steps " + number_text(median_step) +
                                " s (" + number_text(1.0 / median_step) +
                                " Hz); each frame keeps its time from the Time column");
    }
  }
  return inconsistencies;
}

}  // namespace

TrcFile parse_trc(const std::string& text, const std::string& source) {
  const std::vector<Line> lines = split_lines(text);
  const TrcHeader header = parse_header(lines, source);
  TrcFile file;
  file.units = header.units;
  MarkerData& m = file.markers;
  const int n = static_cast<int>(header.num_markers);
  m.labels = parse_labels(lines, n, source, &file.transcoded_names);
  // Line 5: X1 Y1 Z1 ...; then optional blank lines before the rows.
  line_at(lines, 4, "the coordinate names line (X1 Y1 Z1 ...)", source);
  const TrcRows rows = parse_rows(lines, m.labels, header.metres_per_unit, source);
  m.rate_hz = header.rate_hz;
  m.first_frame = rows.first_frame;
  m.times_s = rows.times_s;
  file.row_lines = rows.lines;
  file.rate_line = header.value_line;
  file.zero_samples = rows.zero_samples;
  m.positions_m.resize(static_cast<Eigen::Index>(rows.positions_m.size()), 3 * n);
  for (size_t f = 0; f < rows.positions_m.size(); ++f) {
    for (int k = 0; k < 3 * n; ++k) {
      m.positions_m(static_cast<Eigen::Index>(f), k) = rows.positions_m[f][k];
    }
  }
  file.inconsistencies = check_rows_against_header(header, rows, lines, source);
  return file;
}

TrcFile read_trc(const std::string& path) { return parse_trc(sim::read_file(path), path); }

// The Time column wins over DataRate: it stamps every sample, while DataRate is a header field
// that writers leave at the capture's rate when they keep every n-th frame (OpenSim's walking5
// TRC: DataRate 250 Hz, rows 0.04 s apart). A biomechanist converting a 5 s walk expects a 5 s
// C3D; writing DataRate would shrink it to 0.5 s and scale every velocity by 10 and every
// acceleration by 100. Rows that are not evenly spaced are refused: C3D stores one rate, and
// resampling is not a conversion's job.
TrcUniformRate uniform_rate(const TrcFile& file, const std::string& source) {
  const MarkerData& m = file.markers;
  const std::vector<double>& t = m.times_s;
  if (t.size() < 2) return {m.rate_hz, ""};
  const size_t n = t.size();
  const double mean_step = (t.back() - t.front()) / static_cast<double>(n - 1);
  std::vector<double> steps;
  for (size_t i = 1; i < n; ++i) steps.push_back(t[i] - t[i - 1]);
  // The lower median: of two steps, the shorter (a row late names itself, not its predecessor).
  const size_t middle = (steps.size() - 1) / 2;
  std::nth_element(steps.begin(), steps.begin() + static_cast<std::ptrdiff_t>(middle), steps.end());
  const double median_step = steps[middle];
  const auto refuse = [&](size_t row, const std::string& rule, double off_s) {
    const long line = row < file.row_lines.size() ? file.row_lines[row] : 0;
    throw ParseError(source, ParseError::line(line),
                     "rows evenly spaced in time, to be written at one rate (" + rule +
                         "; DataRate " + number_text(m.rate_hz) + " Hz on line " +
                         std::to_string(file.rate_line) + ", the Time column " +
                         number_text(1.0 / median_step) + " Hz by its median step " +
                         number_text(median_step) + " s)",
                     "time " + number_text(t[row]) + " s, " + number_text(off_s) + " s off");
  };
  // Each step against the median names the row where the spacing breaks; each time against
  // the line through the first and last catches a slow drift.
  for (size_t i = 1; i < n; ++i) {
    const double off_s = (t[i] - t[i - 1]) - median_step;
    if (std::abs(off_s) > kEvenSpacingTolerance * median_step) {
      refuse(i, "a step of " + number_text(median_step) + " s after the previous row's time",
             off_s);
    }
  }
  for (size_t i = 1; i < n; ++i) {
    const double grid_s = t.front() + static_cast<double>(i) * mean_step;
    if (std::abs(t[i] - grid_s) > kEvenSpacingTolerance * mean_step) {
      refuse(i, "the time " + number_text(grid_s) + " s of an even spacing", t[i] - grid_s);
    }
  }
  if (std::abs(mean_step * m.rate_hz - 1.0) <= kRateMismatchTolerance) return {m.rate_hz, ""};
  double rate_hz = 1.0 / mean_step;
  if (std::abs(rate_hz - std::round(rate_hz)) <= kWholeRateTolerance * rate_hz) {
    rate_hz = std::round(rate_hz);
  }
  return {rate_hz, source + ": DataRate is " + number_text(m.rate_hz) + " Hz (line " +
                       std::to_string(file.rate_line) + ") but the rows are " +
                       number_text(mean_step) + " s apart (" + number_text(rate_hz) +
                       " Hz): used " + number_text(rate_hz) +
                       " Hz, the Time column's rate, so the capture keeps its duration"};
}

std::string format_trc(const MarkerData& markers, const std::string& units,
                       const std::string& file_name, int precision) {
  double per_metre = 0.0;
  if (units == "mm") {
    per_metre = 1e3;
  } else if (units == "m") {
    per_metre = 1.0;
  } else {
    throw sim::InvalidArgument("TRC units: expected mm or m, got '" + units + "'");
  }
  const int n = markers.marker_count();
  if (markers.positions_m.cols() != 3 * n) {
    throw sim::InvalidArgument("TRC: positions have " + std::to_string(markers.positions_m.cols()) +
                               " columns, expected 3 per label (" + std::to_string(3 * n) + ")");
  }
  std::ostringstream out;
  out.precision(precision);
  out << "PathFileType\t4\t(X/Y/Z)\t" << file_name << "\n";
  out << "DataRate\tCameraRate\tNumFrames\tNumMarkers\tUnits\tOrigDataRate\tOrigDataStartFrame\t"
         "OrigNumFrames\n";
  out << markers.rate_hz << "\t" << markers.rate_hz << "\t" << markers.frame_count() << "\t" << n
      << "\t" << units << "\t" << markers.rate_hz << "\t" << markers.first_frame << "\t"
      << markers.frame_count() << "\n";
  out << "Frame#\tTime";
  for (const std::string& label : markers.labels) out << "\t" << label << "\t\t";
  out << "\n\t";
  for (int i = 1; i <= n; ++i) out << "\tX" << i << "\tY" << i << "\tZ" << i;
  out << "\n\n";
  for (int f = 0; f < markers.frame_count(); ++f) {
    out << markers.first_frame + f << "\t" << markers.time_s(f);
    for (int k = 0; k < 3 * n; ++k) {
      const double v = markers.positions_m(f, k);
      out << "\t";
      if (std::isnan(v)) {
        out << "NaN";
      } else {
        out << v * per_metre;
      }
    }
    out << "\n";
  }
  return out.str();
}

void write_trc(const std::string& path, const MarkerData& markers, const std::string& units,
               int precision) {
  const size_t slash = path.find_last_of('/');
  const std::string name = slash == std::string::npos ? path : path.substr(slash + 1);
  sim::write_file_atomically(path, format_trc(markers, units, name, precision));
}

}  // namespace biodyn::mocap_io
