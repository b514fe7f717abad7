// C3D reader (C3D User Guide, c3d.org, "The C3D File Format"; section names quoted below).
//
// A file is 512-byte blocks: the header (block 1), the parameter section (from the block the
// header's first byte names), then the data section (from POINT:DATA_START): frames of 3D points
// (x, y, z, residual word) each followed by its analog samples. The writer is in c3d_write.cc.

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <optional>

#include "biodyn/mocap_io/c3d.h"

#include "biodyn/mocap_io/errors.h"
#include "biodyn/mocap_io/utf8.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/file_io.h"
#include "c3d_binary.h"
#include "c3d_force_plates.h"
#include "c3d_parameters.h"
#include "c3d_units.h"

namespace biodyn::mocap_io {

using c3d_internal::ByteReader;
using c3d_internal::count_value;
using c3d_internal::fail_parameter;
using c3d_internal::format_number;
using c3d_internal::kBlockBytes;
using c3d_internal::kMaxWord;
using c3d_internal::NumberFormat;
using c3d_internal::Parameter;
using c3d_internal::ParameterSection;

const char* to_string(C3dProcessor processor) {
  switch (processor) {
    case C3dProcessor::kIntel:
      return "Intel";
    case C3dProcessor::kDec:
      return "DEC";
    case C3dProcessor::kMips:
      return "MIPS";
  }
  return "unknown";
}

const char* to_string(C3dStorage storage) {
  return storage == C3dStorage::kInteger ? "integer" : "float";
}

namespace {

// "The Header Section": 16-bit words, numbered from 1; word n starts at byte 2 (n - 1).
constexpr std::size_t word_offset(int word) { return 2 * static_cast<std::size_t>(word - 1); }
constexpr int kWordPoints = 2;                  // 3D points per frame
constexpr int kWordAnalogValues = 3;            // analog channels x samples per frame
constexpr int kWordFirstFrame = 4;              // first frame number (from 1)
constexpr int kWordLastFrame = 5;               // last frame number
constexpr int kWordScale = 7;                   // POINT:SCALE, a float in words 7-8
constexpr int kWordDataStart = 9;               // first block of the data section
constexpr int kWordAnalogSamplesPerFrame = 10;  // analog samples per channel per frame
constexpr int kWordRate = 11;                   // POINT:RATE, a float in words 11-12

// "POINT:FRAMES": an integer POINT:FRAMES of 65535 means "65535 or more"; the count is then in
// POINT:LONG_FRAMES or the TRIAL group ("Reading the frame count").
constexpr long kSaturatedFrames = 65535;
// Two rates, or scales, this close count as the same.
constexpr double kSameRelative = 1e-6;
// ANALOG:RATE / POINT:RATE must be this close to a whole number of samples per frame.
constexpr double kWholeSamplesTolerance = 1e-3;

/// The header's copy of the layout ("The Header Section"); the parameters take precedence.
struct Header {
  std::size_t parameter_start = 0;  ///< byte offset of the parameter section
  long points = 0;
  long analog_values_per_frame = 0;
  long first_frame = 0, last_frame = 0;
  double scale = 0;
  long data_block = 0;
  long analog_samples_per_frame = 0;
  double rate_hz = 0;
  long frames() const { return last_frame >= first_frame ? last_frame - first_frame + 1 : 0; }
};

/// How the data section is laid out and scaled, as decided from the parameters.
struct Layout {
  long points = 0;
  long frames = 0;
  long first_frame = 1;
  double rate_hz = 0;
  double scale = 0;  ///< POINT:SCALE: POINT:UNITS per integer unit; < 0 for float storage
  C3dStorage storage = C3dStorage::kFloat;
  double unit_m = 1e-3;  ///< m per POINT:UNITS
  std::size_t data_offset = 0;
  long channels = 0;
  long samples_per_frame = 0;  ///< analog samples per channel per frame

  std::uint64_t word_bytes() const { return storage == C3dStorage::kFloat ? 4 : 2; }
  std::uint64_t point_bytes() const { return 4 * word_bytes() * std::uint64_t(points); }
  std::uint64_t frame_bytes() const {
    return point_bytes() +
           word_bytes() * std::uint64_t(channels) * std::uint64_t(samples_per_frame);
  }
};

std::vector<std::uint8_t> load(const std::string& path) {
  const std::string bytes = sim::read_file(path);
  return std::vector<std::uint8_t>(bytes.begin(), bytes.end());
}

/// Finds the parameter section and the processor type, which says how to read every number
/// ("The Header Section", "Parameter header").
std::pair<std::size_t, C3dProcessor> locate_parameters(const ByteReader& raw) {
  raw.span(0, kBlockBytes, "a C3D header");
  const std::uint8_t key = raw.byte(1, "the C3D key");
  if (key != c3d_internal::kC3dKey) {
    raw.fail(1, "the C3D key 0x50 (80) in the header's second byte", std::to_string(key));
  }
  const std::uint8_t block = raw.byte(0, "the parameter section block");
  if (block < 2) {
    raw.fail(0, "a parameter section block >= 2 (block 1 is the header)", std::to_string(block));
  }
  const std::size_t start = (block - 1u) * kBlockBytes;
  if (start + 4 > raw.end()) {
    raw.fail(0,
             "a parameter section inside the file (block " + std::to_string(block) +
                 " starts at byte " + std::to_string(start) + ")",
             "a file of " + std::to_string(raw.end()) + " bytes");
  }
  const std::uint8_t processor = raw.byte(start + 3, "the processor type");
  if (processor < static_cast<int>(C3dProcessor::kIntel) ||
      processor > static_cast<int>(C3dProcessor::kMips)) {
    raw.fail(start + 3, "processor type 84 (Intel), 85 (DEC) or 86 (MIPS)",
             std::to_string(processor));
  }
  return {start, static_cast<C3dProcessor>(processor)};
}

Header read_header(const ByteReader& r, std::size_t parameter_start) {
  Header h;
  h.parameter_start = parameter_start;
  auto word = [&](int n) { return static_cast<long>(r.uint16(word_offset(n), "header word")); };
  h.points = word(kWordPoints);
  h.analog_values_per_frame = word(kWordAnalogValues);
  h.first_frame = word(kWordFirstFrame);
  h.last_frame = word(kWordLastFrame);
  h.scale = r.float32(word_offset(kWordScale), "header scale");
  h.data_block = word(kWordDataStart);
  h.analog_samples_per_frame = word(kWordAnalogSamplesPerFrame);
  h.rate_hz = r.float32(word_offset(kWordRate), "header frame rate");
  return h;
}

ParameterSection read_parameter_section(const ByteReader& raw, std::size_t start) {
  const std::uint8_t blocks = raw.byte(start + 2, "the parameter block count");
  if (blocks == 0) raw.fail(start + 2, "a parameter section of at least 1 block", "0 blocks");
  const std::size_t end = start + blocks * kBlockBytes;
  const ByteReader section =
      raw.narrowed(end, end <= raw.end() ? "the end of the parameter section"
                                         : "the end of the file (inside the parameter section)");
  return c3d_internal::parse_parameters(section, start);
}

/// Decides the layout from the parameters, noting where the header disagrees and which
/// defaults were taken. Each decision is one small function below.
class LayoutDecider {
 public:
  LayoutDecider(const ParameterSection& params, const Header& header, const ByteReader& raw,
                std::vector<std::string>* notes)
      : params_(params), header_(header), raw_(raw), notes_(notes) {}

  Layout decide(std::string* point_units) {
    Layout l;
    l.points = point_count();
    l.frames = frame_count();
    l.first_frame = first_frame();
    l.rate_hz = rate();
    l.scale = scale();
    l.storage = l.scale < 0 ? C3dStorage::kFloat : C3dStorage::kInteger;
    l.unit_m = units(point_units);
    l.data_offset = data_offset();
    l.channels = analog_channels();
    l.samples_per_frame = analog_samples_per_frame(l.channels, l.rate_hz);
    return l;
  }

 private:
  const std::string& file() const { return raw_.file(); }
  const Parameter* point(const char* name) const { return params_.find("POINT", name); }

  void note_disagreement(const std::string& what, const std::string& header_value,
                         const std::string& parameter, const std::string& parameter_value) {
    notes_->push_back(what + ": the header says " + header_value + ", " + parameter + " says " +
                      parameter_value + "; used " + parameter);
  }

  /// "POINT:USED" is required ("The POINT group").
  long point_count() {
    if (!params_.has_group("POINT")) {
      raw_.fail(header_.parameter_start, "a POINT group in the parameter section", "none");
    }
    const Parameter* used = point("USED");
    if (used == nullptr) {
      raw_.fail(header_.parameter_start, "a POINT:USED parameter (the number of 3D points)",
                "none");
    }
    const long n = count_value(file(), *used, "number of 3D points", 0, kMaxWord);
    if (n != header_.points) {
      note_disagreement("point count", std::to_string(header_.points) + " (word 2)", "POINT:USED",
                        std::to_string(n));
    }
    return n;
  }

  /// TRIAL:<name>, two 16-bit words (low, high) of a 32-bit frame number (Vicon's convention,
  /// "The TRIAL group"), when present and whole.
  std::optional<long> trial_field(const char* name) const {
    const Parameter* p = params_.find("TRIAL", name);
    if (p == nullptr || !p->is_integer() || p->numbers.size() < 2) return std::nullopt;
    return static_cast<long>(p->unsigned_number(0) + 65536.0 * p->unsigned_number(1));
  }

  /// TRIAL:ACTUAL_END_FIELD - ACTUAL_START_FIELD + 1, when both are present and ordered.
  std::optional<long> trial_frame_count() const {
    const auto start = trial_field("ACTUAL_START_FIELD");
    const auto end = trial_field("ACTUAL_END_FIELD");
    if (!start || !end || *end < *start) return std::nullopt;
    return *end - *start + 1;
  }

  /// "Reading the frame count": POINT:FRAMES, unless it is an integer that could not hold the
  /// count: 65535 (saturated) with POINT:LONG_FRAMES present, or a count the TRIAL fields put
  /// above 65535 that POINT:FRAMES holds as 65535 or modulo 65536 (overflowed). The header's
  /// 16-bit frame range cannot hold such counts either, so it is never the fallback.
  long frame_count() {
    const Parameter* frames = point("FRAMES");
    if (frames == nullptr) {
      notes_->push_back("POINT:FRAMES missing: used the header's frames " +
                        std::to_string(header_.first_frame) + "-" +
                        std::to_string(header_.last_frame) + " (" +
                        std::to_string(header_.frames()) + " frames)");
      return header_.frames();
    }
    long n = count_value(file(), *frames, "number of frames");
    std::string source = "POINT:FRAMES";
    const Parameter* long_frames = point("LONG_FRAMES");
    const std::optional<long> trial = trial_frame_count();
    if (frames->is_integer() && n == kSaturatedFrames && long_frames != nullptr) {
      n = count_value(file(), *long_frames, "number of frames");
      source = "POINT:LONG_FRAMES";
    } else if (frames->is_integer() && trial && *trial > kSaturatedFrames &&
               (n == kSaturatedFrames || n == (*trial & kMaxWord))) {
      // Saturated at 65535, or wrapped around 65536 by a writer that kept the low word.
      if (*trial > std::numeric_limits<int>::max()) {
        fail_parameter(file(), *params_.find("TRIAL", "ACTUAL_END_FIELD"),
                       "a frame range of at most 2^31 - 1 frames", std::to_string(*trial));
      }
      n = *trial;
      source = "TRIAL:ACTUAL_END_FIELD - ACTUAL_START_FIELD + 1";
    }
    if (n != header_.frames()) {
      note_disagreement("frame count",
                        std::to_string(header_.frames()) + " (frames " +
                            std::to_string(header_.first_frame) + "-" +
                            std::to_string(header_.last_frame) + ")",
                        source, std::to_string(n));
    }
    return n;
  }

  /// The header's first frame, or TRIAL:ACTUAL_START_FIELD (32 bits) when present.
  long first_frame() {
    const auto trial = trial_field("ACTUAL_START_FIELD");
    if (!trial || *trial < 1) return header_.first_frame;
    if (*trial > std::numeric_limits<int>::max()) {
      fail_parameter(file(), *params_.find("TRIAL", "ACTUAL_START_FIELD"),
                     "a first frame number that fits an int", std::to_string(*trial));
    }
    if (*trial != header_.first_frame) {
      note_disagreement("first frame", std::to_string(header_.first_frame) + " (word 4)",
                        "TRIAL:ACTUAL_START_FIELD", std::to_string(*trial));
    }
    return *trial;
  }

  /// Whether a and b are the same value (within kSameRelative). An infinite or NaN value is
  /// the same as nothing: |250 - inf| <= 1e-6 inf would call a header rate of inf 250 Hz.
  static bool same(double a, double b) {
    if (!std::isfinite(a) || !std::isfinite(b)) return false;
    return std::fabs(a - b) <= kSameRelative * std::max(std::fabs(a), std::fabs(b));
  }

  /// POINT:RATE ("POINT:RATE"), else the header's.
  double rate() {
    const Parameter* p = point("RATE");
    if (p == nullptr || p->numbers.empty()) {
      if (!(header_.rate_hz > 0) || !std::isfinite(header_.rate_hz)) {
        raw_.fail(word_offset(kWordRate), "a frame rate > 0 (no POINT:RATE)",
                  format_number(header_.rate_hz));
      }
      notes_->push_back("POINT:RATE missing: used the header's " + format_number(header_.rate_hz) +
                        " Hz");
      return header_.rate_hz;
    }
    const double hz = p->numbers[0];
    if (!(hz > 0) || !std::isfinite(hz)) fail_parameter(file(), *p, "> 0 Hz", format_number(hz));
    if (!same(hz, header_.rate_hz)) {
      note_disagreement("frame rate", format_number(header_.rate_hz) + " Hz (words 11-12)",
                        "POINT:RATE", format_number(hz) + " Hz");
    }
    return hz;
  }

  /// POINT:SCALE, else the header's; negative means float storage ("POINT:SCALE").
  double scale() {
    const Parameter* p = point("SCALE");
    double s = header_.scale;
    if (p == nullptr || p->numbers.empty()) {
      notes_->push_back("POINT:SCALE missing: used the header's " + format_number(s));
    } else {
      s = p->numbers[0];
      if (!same(s, header_.scale)) {
        note_disagreement("scale", format_number(header_.scale) + " (words 7-8)", "POINT:SCALE",
                          format_number(s));
      }
    }
    if (s == 0 || !std::isfinite(s)) {
      if (p != nullptr) fail_parameter(file(), *p, "nonzero", format_number(s));
      raw_.fail(word_offset(kWordScale), "a nonzero scale (no POINT:SCALE)", format_number(s));
    }
    return s;
  }

  /// m per POINT:UNITS ("POINT:UNITS"); mm when missing.
  double units(std::string* written) {
    const Parameter* p = point("UNITS");
    if (p == nullptr || p->strings.empty() || p->strings[0].empty()) {
      notes_->push_back("POINT:UNITS missing: assumed mm");
      written->clear();
      return 1e-3;
    }
    *written = p->strings[0];
    const auto m = c3d_internal::length_unit_m(*written);
    if (!m) fail_parameter(file(), *p, "mm, cm or m", "'" + *written + "'");
    return *m;
  }

  /// POINT:DATA_START ("POINT:DATA_START": always use it), else the header's word 9.
  std::size_t data_offset() {
    const Parameter* p = point("DATA_START");
    long block = header_.data_block;
    if (p == nullptr) {
      notes_->push_back("POINT:DATA_START missing: used the header's block " +
                        std::to_string(block));
    } else {
      block = count_value(file(), *p, "data start block", 0, kMaxWord);
      if (block != header_.data_block) {
        note_disagreement("data start block", std::to_string(header_.data_block) + " (word 9)",
                          "POINT:DATA_START", std::to_string(block));
      }
    }
    const long parameter_block = static_cast<long>(header_.parameter_start / kBlockBytes) + 1;
    if (block <= parameter_block) {
      const std::string expected = "a data start block after the parameter section's (block " +
                                   std::to_string(parameter_block) + ")";
      if (p != nullptr) fail_parameter(file(), *p, expected, std::to_string(block));
      raw_.fail(word_offset(kWordDataStart), expected, std::to_string(block));
    }
    return static_cast<std::size_t>(block - 1) * kBlockBytes;
  }

  /// ANALOG:USED ("ANALOG:USED"), else the header's word 3 / word 10.
  long analog_channels() {
    const long header_channels =
        header_.analog_samples_per_frame > 0
            ? header_.analog_values_per_frame / header_.analog_samples_per_frame
            : 0;
    const Parameter* p = params_.find("ANALOG", "USED");
    if (p == nullptr) {
      if (header_channels > 0) {
        notes_->push_back("ANALOG:USED missing: used the header's " +
                          std::to_string(header_channels) + " channels");
      }
      return header_channels;
    }
    const long n = count_value(file(), *p, "number of analog channels", 0, kMaxWord);
    if (n != header_channels) {
      note_disagreement("analog channels",
                        std::to_string(header_channels) + " (word 3 " +
                            std::to_string(header_.analog_values_per_frame) + " / word 10 " +
                            std::to_string(header_.analog_samples_per_frame) + ")",
                        "ANALOG:USED", std::to_string(n));
    }
    return n;
  }

  /// ANALOG:RATE / POINT:RATE, a whole number ("ANALOG:RATE"), else the header's word 10.
  long analog_samples_per_frame(long channels, double point_rate_hz) {
    if (channels == 0) return 0;
    const Parameter* p = params_.find("ANALOG", "RATE");
    const long header_samples = header_.analog_samples_per_frame;
    if (p == nullptr || p->numbers.empty()) {
      if (header_samples < 1) {
        raw_.fail(word_offset(kWordAnalogSamplesPerFrame),
                  "analog samples per frame >= 1 (no ANALOG:RATE)", std::to_string(header_samples));
      }
      notes_->push_back("ANALOG:RATE missing: used the header's " + std::to_string(header_samples) +
                        " samples per frame");
      return header_samples;
    }
    const double ratio = p->numbers[0] / point_rate_hz;
    const double whole = std::round(ratio);
    if (!(whole >= 1 && whole <= kMaxWord) ||
        std::fabs(ratio - whole) > kWholeSamplesTolerance * whole) {
      fail_parameter(
          file(), *p,
          "a whole multiple (1 to 65535) of POINT:RATE " + format_number(point_rate_hz) + " Hz",
          format_number(p->numbers[0]) + " Hz");
    }
    const auto n = static_cast<long>(whole);
    if (n != header_samples) {
      note_disagreement("analog samples per frame", std::to_string(header_samples) + " (word 10)",
                        "ANALOG:RATE / POINT:RATE", std::to_string(n));
    }
    return n;
  }

  const ParameterSection& params_;
  const Header& header_;
  const ByteReader& raw_;
  std::vector<std::string>* notes_;
};

/// Throws ParseError when the data section is shorter than the layout needs ("The 3D Point Data
/// Section"): nothing is read from a truncated file.
void check_data_size(const ByteReader& raw, const Layout& l) {
  const std::uint64_t frame = l.frame_bytes();  // <= 2^35: frames x frame may overflow
  const std::uint64_t available = l.data_offset <= raw.end() ? raw.end() - l.data_offset : 0;
  const auto frames = static_cast<std::uint64_t>(l.frames);
  if (frame == 0 || frames <= available / frame) return;
  const std::string needed = frames > std::numeric_limits<std::uint64_t>::max() / frame
                                 ? "more than 2^64"
                                 : std::to_string(frames * frame);
  raw.fail(l.data_offset,
           std::to_string(l.frames) + " frames of " + std::to_string(frame) + " bytes (" +
               std::to_string(l.points) + " points, " + std::to_string(l.channels) +
               " analog channels x " + std::to_string(l.samples_per_frame) + " samples, " +
               to_string(l.storage) + "): " + needed + " bytes of data from here",
           std::to_string(available) + " bytes before the end of the file (truncated)");
}

/// The parameter section against the data section ("The Parameter Section": its header's third
/// byte counts its blocks, and the data start after them). Parameter records that run into the
/// data are refused (the data would be read from parameter bytes); a block count claiming more
/// blocks than lie before the data, over records that end before it, is noted.
void check_parameter_blocks(const ByteReader& raw, std::size_t start, std::size_t records_end,
                            const Layout& l, std::vector<std::string>* notes) {
  const long data_block = static_cast<long>(l.data_offset / kBlockBytes) + 1;
  if (records_end > l.data_offset) {
    raw.fail(l.data_offset,
             "the data section (block " + std::to_string(data_block) +
                 ") to start after the parameter records",
             "parameter records up to byte " + std::to_string(records_end));
  }
  const std::size_t claimed = raw.byte(start + 2, "the parameter block count");
  const std::size_t available = (l.data_offset - start) / kBlockBytes;
  if (claimed > available) {
    notes->push_back("parameter section: byte " + std::to_string(start + 2) + " claims " +
                     std::to_string(claimed) + " blocks, but the data start at block " +
                     std::to_string(data_block) + " leaves " + std::to_string(available) +
                     "; its records end at byte " + std::to_string(records_end) +
                     ", before the data: read as they are");
  }
}

/// The strings of GROUP:NAME, GROUP:NAME2, GROUP:NAME3, ... in order ("Additional
/// Parameters": LABELS2 etc. continue LABELS past 255 entries), as UTF-8 (to_utf8: a C3D
/// string may hold any byte; Latin-1 is common). Counts the strings transcoded in *transcoded.
std::vector<std::string> continued_strings(const ParameterSection& params, const char* group,
                                           const std::string& name, int* transcoded) {
  std::vector<std::string> out;
  for (int k = 1;; ++k) {
    const Parameter* p = params.find(group, k == 1 ? name : name + std::to_string(k));
    if (p == nullptr) break;  // parameters are finite: the loop ends
    for (const std::string& raw : p->strings) {
      out.push_back(to_utf8(raw));
      *transcoded += out.back() != raw ? 1 : 0;
    }
  }
  return out;
}

/// As continued_strings, for numbers; `as_unsigned` reads int16 words as 0..65535.
std::vector<double> continued_numbers(const ParameterSection& params, const char* group,
                                      const std::string& name, bool as_unsigned = false) {
  std::vector<double> out;
  for (int k = 1;; ++k) {
    const Parameter* p = params.find(group, k == 1 ? name : name + std::to_string(k));
    if (p == nullptr) break;
    for (std::size_t i = 0; i < p->numbers.size(); ++i) {
      out.push_back(as_unsigned ? p->unsigned_number(i) : p->numbers[i]);
    }
  }
  return out;
}

/// `labels` completed to `count` entries named "<prefix><n>" (n from 1), noting the gap.
std::vector<std::string> complete_labels(std::vector<std::string> labels, long count,
                                         const std::string& parameter, const std::string& prefix,
                                         std::vector<std::string>* notes) {
  const auto n = static_cast<std::size_t>(count);
  if (labels.size() < n) {
    notes->push_back(parameter + " holds " + std::to_string(labels.size()) + " labels for " +
                     std::to_string(n) + " entries: the rest are named " + prefix + "<n>");
    for (std::size_t i = labels.size(); i < n; ++i)
      labels.push_back(prefix + std::to_string(i + 1));
  }
  labels.resize(n);
  return labels;
}

/// Marker trajectories ("3D Data - Integer Format", "3D Data - Floating-point Format", "3D
/// Point Residuals"): a negative residual word marks an invalid sample, a gap (NaN), whatever
/// its coordinates say.
MarkerData read_markers(const ByteReader& raw, const Layout& l, std::vector<std::string> labels) {
  MarkerData m;
  m.rate_hz = l.rate_hz;
  m.first_frame = static_cast<int>(l.first_frame);
  m.labels = std::move(labels);
  m.positions_m.resize(l.frames, 3 * l.points);
  if (l.points == 0) return m;
  const NumberFormat& fmt = raw.format();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const bool is_float = l.storage == C3dStorage::kFloat;
  // Float coordinates are in POINT:UNITS; integers in POINT:SCALE units.
  const double to_m = is_float ? l.unit_m : l.scale * l.unit_m;
  const std::size_t word = l.word_bytes();
  for (long f = 0; f < l.frames; ++f) {
    const std::size_t at = l.data_offset + std::size_t(f) * l.frame_bytes();
    const std::uint8_t* frame = raw.span(at, l.point_bytes(), "frame " + std::to_string(f + 1));
    for (long p = 0; p < l.points; ++p) {
      const std::uint8_t* w = frame + 4 * word * std::size_t(p);
      double xyz[3];
      bool invalid = false;
      for (int k = 0; k < 3; ++k) {
        xyz[k] = is_float ? fmt.float32(w + word * k) : fmt.int16(w + word * k);
      }
      if (is_float) {
        // Word 4 is a float holding the residual word; its sign is the int16's sign. -0.0 and
        // a negative NaN count as negative.
        invalid = std::signbit(fmt.float32(w + 3 * word));
      } else {
        invalid = fmt.int16(w + 3 * word) < 0;
      }
      for (int k = 0; k < 3; ++k) invalid = invalid || !std::isfinite(xyz[k]);
      for (int k = 0; k < 3; ++k) m.positions_m(f, 3 * p + k) = invalid ? nan : xyz[k] * to_m;
    }
  }
  return m;
}

/// Analog channels ("Analog Data - Integer Format", "Analog Data - Floating-point format"):
/// value = (stored - ANALOG:OFFSET) * ANALOG:SCALE * ANALOG:GEN_SCALE, with stored values and
/// offsets unsigned when ANALOG:FORMAT is "UNSIGNED" ("ANALOG:FORMAT").
AnalogData read_analog(const ByteReader& raw, const ParameterSection& params, const Layout& l,
                       std::vector<std::string>* notes, int* transcoded) {
  AnalogData a;
  if (l.channels == 0) return a;
  const auto n = static_cast<std::size_t>(l.channels);
  a.rate_hz = l.rate_hz * static_cast<double>(l.samples_per_frame);
  a.labels = complete_labels(continued_strings(params, "ANALOG", "LABELS", transcoded), l.channels,
                             "ANALOG:LABELS", "analog", notes);
  a.units = continued_strings(params, "ANALOG", "UNITS", transcoded);
  a.units.resize(n);
  const Parameter* format = params.find("ANALOG", "FORMAT");
  const bool is_unsigned = format != nullptr && !format->strings.empty() &&
                           c3d_internal::upper(format->strings[0]) == "UNSIGNED";
  std::vector<double> scale = continued_numbers(params, "ANALOG", "SCALE");
  std::vector<double> offset = continued_numbers(params, "ANALOG", "OFFSET", is_unsigned);
  if (scale.size() < n) notes->push_back("ANALOG:SCALE missing for some channels: used 1");
  if (offset.size() < n) notes->push_back("ANALOG:OFFSET missing for some channels: used 0");
  scale.resize(n, 1.0);
  offset.resize(n, 0.0);
  const Parameter* gen = params.find("ANALOG", "GEN_SCALE");
  const double gen_scale = gen != nullptr && !gen->numbers.empty() ? gen->numbers[0] : 1.0;

  const NumberFormat& fmt = raw.format();
  const bool is_float = l.storage == C3dStorage::kFloat;
  const std::size_t word = l.word_bytes();
  const std::size_t samples = std::size_t(l.samples_per_frame);
  a.values.resize(static_cast<Eigen::Index>(std::size_t(l.frames) * samples), l.channels);
  for (long f = 0; f < l.frames; ++f) {
    const std::size_t at = l.data_offset + std::size_t(f) * l.frame_bytes() + l.point_bytes();
    const std::uint8_t* block =
        raw.span(at, word * n * samples, "analog samples of frame " + std::to_string(f + 1));
    for (std::size_t s = 0; s < samples; ++s) {
      const auto row = static_cast<Eigen::Index>(std::size_t(f) * samples + s);
      for (std::size_t c = 0; c < n; ++c) {
        const std::uint8_t* w = block + word * (s * n + c);
        const double stored =
            is_float ? fmt.float32(w) : (is_unsigned ? fmt.uint16(w) : fmt.int16(w));
        a.values(row, static_cast<Eigen::Index>(c)) = (stored - offset[c]) * scale[c] * gen_scale;
      }
    }
  }
  return a;
}

}  // namespace

C3dFile read_c3d(const std::string& path) {
  const std::vector<std::uint8_t> bytes = load(path);
  // The processor byte is needed before any multi-byte number can be read.
  const ByteReader prelude(bytes, path, NumberFormat(C3dProcessor::kIntel));
  const auto [parameter_start, processor] = locate_parameters(prelude);
  const ByteReader raw(bytes, path, NumberFormat(processor));
  const Header header = read_header(raw, parameter_start);
  const ParameterSection params = read_parameter_section(raw, parameter_start);

  C3dFile out;
  out.processor = processor;
  const Layout layout =
      LayoutDecider(params, header, raw, &out.inconsistencies).decide(&out.point_units);
  out.storage = layout.storage;
  check_parameter_blocks(raw, parameter_start, params.records_end(), layout, &out.inconsistencies);
  check_data_size(raw, layout);
  out.markers = read_markers(
      raw, layout,
      complete_labels(continued_strings(params, "POINT", "LABELS", &out.transcoded_names),
                      layout.points, "POINT:LABELS", "point", &out.inconsistencies));
  out.analog = read_analog(raw, params, layout, &out.inconsistencies, &out.transcoded_names);
  c3d_internal::ForcePlates plates =
      c3d_internal::read_force_plates(params, out.analog, layout.unit_m, path);
  out.force_plates = std::move(plates.plates);
  out.force_plate_cal_matrices = std::move(plates.cal_matrices);
  return out;
}

}  // namespace biodyn::mocap_io
