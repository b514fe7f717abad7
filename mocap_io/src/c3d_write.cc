// C3D writer: header, parameter section and data in the chosen processor's format (C3D User
// Guide; the reader in c3d.cc documents the layout). Everything is checked and encoded in
// memory first, then written to a temporary file that replaces `path` only when complete.

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include "biodyn/mocap_io/c3d.h"

#include "biodyn/sim/errors.h"
#include "biodyn/sim/file_io.h"
#include "c3d_binary.h"
#include "c3d_parameters.h"

namespace biodyn::mocap_io {

using c3d_internal::ByteWriter;
using c3d_internal::kBlockBytes;
using c3d_internal::kMaxWord;
using c3d_internal::NumberFormat;
using c3d_internal::ParameterWriter;

namespace {

// c3d.h: longer labels would be cut by readers that keep 32 characters.
constexpr std::size_t kMaxLabel = 32;
// "Parameter Arrays": a dimension is one byte, so LABELS holds 255 entries; LABELS2, LABELS3,
// ... continue it ("Additional Parameters").
constexpr std::size_t kMaxPerParameter = 255;
// "Notes for programmers - Integer 3D Data": integer scale = largest value / 32000.
constexpr double kIntegerFullScale = 32000.0;
constexpr double kMaxInt16 = 32767.0;
constexpr double kMmPerM = 1000.0;
// Vicon's convention (and ezc3d's writer): an invalid point's residual word is -1.
constexpr double kInvalidResidual = -1.0;
// Frames at or above this count are written as a float POINT:FRAMES ("Writing the C3D frame
// count").
constexpr long kFloatFramesFrom = 65535;
// Plates with this many channels (types 1, 2, 4 and type 3).
constexpr int kSixChannels = 6;
constexpr int kKistlerChannels = 8;

/// mm per integer unit as the file will hold it (a float): dividing by this one, not by the
/// requested double, keeps the reader's reconstruction within half a unit.
double stored_scale_mm(const C3dWriteOptions& o) {
  return static_cast<double>(static_cast<float>(o.integer_scale_mm));
}

[[noreturn]] void refuse(const std::string& what) {
  throw sim::InvalidArgument("C3D writer: " + what);
}

std::string plate_name(std::size_t i) { return "force plate " + std::to_string(i + 1); }

/// Analog samples per marker frame.
long samples_per_frame(const C3dFile& f) {
  if (f.analog.channel_count() == 0) return 1;
  const double ratio = f.analog.rate_hz / f.markers.rate_hz;
  const double whole = std::round(ratio);
  if (!(whole >= 1 && whole <= kMaxWord) || std::fabs(ratio - whole) > 1e-9 * whole) {
    refuse("the analog rate " + std::to_string(f.analog.rate_hz) +
           " Hz is not a whole multiple of the marker rate " + std::to_string(f.markers.rate_hz) +
           " Hz");
  }
  return static_cast<long>(whole);
}

void check_labels(const std::vector<std::string>& labels, const std::string& what) {
  for (const std::string& l : labels) {
    if (l.size() > kMaxLabel) {
      refuse(what + " label '" + l + "' is longer than 32 characters (it would be cut)");
    }
  }
}

void check_markers(const MarkerData& m, const C3dWriteOptions& options) {
  if (!(m.rate_hz > 0) || !std::isfinite(m.rate_hz)) {
    refuse("marker rate must be > 0 Hz, got " + std::to_string(m.rate_hz));
  }
  if (m.positions_m.cols() != 3 * m.marker_count()) {
    refuse("positions_m has " + std::to_string(m.positions_m.cols()) + " columns for " +
           std::to_string(m.marker_count()) + " labels (expected 3 per marker)");
  }
  if (m.marker_count() > kMaxWord) refuse("more than 65535 markers");
  if (m.first_frame < 1) refuse("first_frame must be >= 1, got " + std::to_string(m.first_frame));
  check_labels(m.labels, "marker");
  if (!(options.integer_scale_mm > 0) || !std::isfinite(options.integer_scale_mm)) {
    refuse("integer_scale_mm must be > 0, got " + std::to_string(options.integer_scale_mm));
  }
  if (options.storage != C3dStorage::kInteger) return;
  for (int f = 0; f < m.frame_count(); ++f) {
    for (int k = 0; k < m.marker_count(); ++k) {
      if (!m.position(f, k).allFinite()) continue;  // written as a gap
      const double largest = m.position(f, k).cwiseAbs().maxCoeff() * kMmPerM;
      if (!(largest / stored_scale_mm(options) <= kMaxInt16)) {
        refuse("marker " + m.labels[std::size_t(k)] + " frame index " + std::to_string(f) + ": " +
               std::to_string(largest) + " mm overflows integer storage at " +
               std::to_string(options.integer_scale_mm) + " mm per unit (max " +
               std::to_string(kMaxInt16 * options.integer_scale_mm) + " mm)");
      }
    }
  }
}

void check_analog(const C3dFile& f, long samples) {
  const AnalogData& a = f.analog;
  if (a.values.cols() != a.channel_count() ||
      (!a.units.empty() && a.units.size() != a.labels.size())) {
    refuse("analog values, labels and units disagree on the channel count");
  }
  if (a.channel_count() == 0) return;
  if (a.sample_count() != f.markers.frame_count() * samples) {
    refuse("analog has " + std::to_string(a.sample_count()) + " samples, expected " +
           std::to_string(f.markers.frame_count() * samples) + " (frames x samples per frame)");
  }
  if (a.channel_count() * samples > kMaxWord) refuse("more than 65535 analog values per frame");
  if (!a.values.allFinite()) refuse("analog values must be finite (C3D analog has no gaps)");
  check_labels(a.labels, "analog");
  check_labels(a.units, "analog unit");
}

void check_plates(const C3dFile& f) {
  for (std::size_t i = 0; i < f.force_plates.size(); ++i) {
    const ForcePlate& p = f.force_plates[i];
    if (p.type < 1 || p.type > 4) {
      refuse(plate_name(i) + ": type " + std::to_string(p.type) + " (only 1-4 are written)");
    }
    const std::size_t needed = p.type == 3 ? kKistlerChannels : kSixChannels;
    if (p.channels.size() != needed) {
      refuse(plate_name(i) + ": type " + std::to_string(p.type) + " needs " +
             std::to_string(needed) + " channels, has " + std::to_string(p.channels.size()));
    }
    for (int c : p.channels) {
      if (c < 0 || c >= f.analog.channel_count()) {
        refuse(plate_name(i) + ": channel " + std::to_string(c) + " is not an analog channel");
      }
    }
    const bool has_cal =
        i < f.force_plate_cal_matrices.size() && f.force_plate_cal_matrices[i].size() != 0;
    if (has_cal && (f.force_plate_cal_matrices[i].rows() != long(needed) ||
                    f.force_plate_cal_matrices[i].cols() != long(needed))) {
      refuse(plate_name(i) + ": calibration matrix must be " + std::to_string(needed) + "x" +
             std::to_string(needed));
    }
    if (p.type == 4 && !has_cal) refuse(plate_name(i) + ": type 4 needs a calibration matrix");
  }
}

/// Splits `values` into LABELS, LABELS2, ... of at most 255 entries each.
template <typename T, typename Write>
void write_continued(const std::string& name, const std::vector<T>& values, Write write) {
  std::size_t part = 1;
  for (std::size_t at = 0; at == 0 || at < values.size(); at += kMaxPerParameter, ++part) {
    const auto end = std::min(values.size(), at + kMaxPerParameter);
    write(part == 1 ? name : name + std::to_string(part),
          std::vector<T>(values.begin() + long(at), values.begin() + long(end)));
  }
}

void write_texts(ParameterWriter* w, const std::string& name,
                 const std::vector<std::string>& values) {
  std::size_t width = 1;
  for (const std::string& v : values) width = std::max(width, v.size());
  write_continued(name, values, [&](const std::string& n, const std::vector<std::string>& part) {
    w->texts(n, part, static_cast<int>(width));
  });
}

/// Per channel ANALOG:SCALE for integer storage (largest |value| / 32000, 1 for a silent
/// channel); 1 for float storage.
std::vector<double> analog_scales(const AnalogData& a, C3dStorage storage) {
  std::vector<double> scales(std::size_t(a.channel_count()), 1.0);
  if (storage == C3dStorage::kFloat) return scales;
  for (int c = 0; c < a.channel_count(); ++c) {
    const double largest = a.sample_count() > 0 ? a.values.col(c).cwiseAbs().maxCoeff() : 0.0;
    // Rounded to the float the file holds (see stored_scale_mm).
    if (largest > 0) scales[std::size_t(c)] = static_cast<float>(largest / kIntegerFullScale);
  }
  return scales;
}

/// Low and high 16-bit words of a 32-bit frame number (the TRIAL group's convention).
std::vector<long> two_words(long value) { return {value & 0xFFFF, (value >> 16) & 0xFFFF}; }

void point_group(ParameterWriter* w, const C3dFile& f, const C3dWriteOptions& o, long data_block) {
  const MarkerData& m = f.markers;
  w->group("POINT");
  w->integers("USED", {m.marker_count()});
  if (m.frame_count() < kFloatFramesFrom) {
    w->integers("FRAMES", {m.frame_count()});
  } else {
    w->floats("FRAMES", {double(m.frame_count())});
  }
  w->integers("DATA_START", {data_block});
  w->floats("SCALE", {o.storage == C3dStorage::kFloat ? -o.integer_scale_mm : o.integer_scale_mm});
  w->floats("RATE", {m.rate_hz});
  w->text("UNITS", "mm");
  write_texts(w, "LABELS", m.labels);
}

void analog_group(ParameterWriter* w, const C3dFile& f, const std::vector<double>& scales,
                  long samples) {
  const AnalogData& a = f.analog;
  w->group("ANALOG");
  w->integers("USED", {a.channel_count()});
  w->floats("RATE", {f.markers.rate_hz * double(samples)});
  w->floats("GEN_SCALE", {1.0});
  w->text("FORMAT", "SIGNED");
  if (a.channel_count() == 0) return;
  write_texts(w, "LABELS", a.labels);
  std::vector<std::string> units = a.units;
  units.resize(a.labels.size());
  write_texts(w, "UNITS", units);
  write_continued("SCALE", scales, [&](const std::string& n, const std::vector<double>& part) {
    w->floats(n, part, {int(part.size())});
  });
  const std::vector<long> offsets(scales.size(), 0);
  write_continued("OFFSET", offsets, [&](const std::string& n, const std::vector<long>& part) {
    w->integers(n, part, {int(part.size())});
  });
}

void force_platform_group(ParameterWriter* w, const C3dFile& f) {
  const auto& plates = f.force_plates;
  const int n = static_cast<int>(plates.size());
  w->group("FORCE_PLATFORM");
  w->integers("USED", {n});
  if (n == 0) return;
  std::vector<long> types, channels;
  std::vector<double> corners, origins;
  int stride = kSixChannels, cal_size = 0;
  for (std::size_t i = 0; i < plates.size(); ++i) {
    stride = std::max(stride, int(plates[i].channels.size()));
    if (i < f.force_plate_cal_matrices.size()) {
      cal_size = std::max(cal_size, int(f.force_plate_cal_matrices[i].rows()));
    }
  }
  for (const ForcePlate& p : plates) {
    types.push_back(p.type);
    for (int c = 0; c < 4; ++c) {
      for (int k = 0; k < 3; ++k) corners.push_back(p.corners_m(k, c) * kMmPerM);
    }
    for (int k = 0; k < 3; ++k) origins.push_back(p.origin_m(k) * kMmPerM);
    for (int k = 0; k < stride; ++k) {
      channels.push_back(k < int(p.channels.size()) ? p.channels[std::size_t(k)] + 1 : 0);
    }
  }
  w->integers("TYPE", types, {n});
  w->floats("CORNERS", corners, {3, 4, n});
  w->floats("ORIGIN", origins, {3, n});
  w->integers("CHANNEL", channels, {stride, n});
  if (cal_size == 0) return;
  // FORTRAN order, row index fastest. Each plate's matrix fills the top-left corner (a 6x6 next
  // to an 8x8); the rest, and plates without a matrix, get the identity.
  std::vector<double> cal;
  for (std::size_t i = 0; i < plates.size(); ++i) {
    const Eigen::MatrixXd m =
        i < f.force_plate_cal_matrices.size() ? f.force_plate_cal_matrices[i] : Eigen::MatrixXd();
    for (int col = 0; col < cal_size; ++col) {
      for (int row = 0; row < cal_size; ++row) {
        const bool inside = row < m.rows() && col < m.cols();
        cal.push_back(inside ? m(row, col) : (row == col ? 1.0 : 0.0));
      }
    }
  }
  w->floats("CAL_MATRIX", cal, {cal_size, cal_size, n});
}

void trial_group(ParameterWriter* w, const MarkerData& m) {
  w->group("TRIAL");
  w->integers("ACTUAL_START_FIELD", two_words(m.first_frame), {2});
  w->integers("ACTUAL_END_FIELD", two_words(long(m.first_frame) + m.frame_count() - 1), {2});
}

/// The header block ("The Header Section").
void write_header(ByteWriter* w, const C3dFile& f, const C3dWriteOptions& o, long samples,
                  long data_block) {
  const MarkerData& m = f.markers;
  const long last = long(m.first_frame) + m.frame_count() - 1;
  w->byte(2);  // the parameter section starts at block 2
  w->byte(c3d_internal::kC3dKey);
  w->uint16(static_cast<std::uint16_t>(m.marker_count()));
  w->uint16(static_cast<std::uint16_t>(f.analog.channel_count() * samples));
  w->uint16(static_cast<std::uint16_t>(std::min<long>(m.first_frame, kMaxWord)));
  w->uint16(static_cast<std::uint16_t>(std::clamp<long>(last, 0, kMaxWord)));
  w->uint16(0);  // maximum interpolation gap
  w->float32(o.storage == C3dStorage::kFloat ? -o.integer_scale_mm : o.integer_scale_mm);
  w->uint16(static_cast<std::uint16_t>(data_block));
  w->uint16(static_cast<std::uint16_t>(samples));
  w->float32(m.rate_hz);
  w->pad_to_block();
}

/// Frames of points then analog samples ("The 3D Point Data Section").
void write_data(ByteWriter* w, const C3dFile& f, const C3dWriteOptions& o,
                const std::vector<double>& scales, long samples) {
  const MarkerData& m = f.markers;
  const bool is_float = o.storage == C3dStorage::kFloat;
  auto value = [&](double v) {
    if (is_float) {
      w->float32(v);
    } else {
      w->int16(static_cast<std::int16_t>(std::lround(v)));
    }
  };
  for (int fr = 0; fr < m.frame_count(); ++fr) {
    for (int k = 0; k < m.marker_count(); ++k) {
      const bool visible = m.position(fr, k).allFinite();  // any NaN: a gap
      for (int c = 0; c < 3; ++c) {
        const double mm = visible ? m.positions_m(fr, 3 * k + c) * kMmPerM : 0.0;
        value(is_float ? mm : mm / stored_scale_mm(o));
      }
      value(visible ? 0.0 : kInvalidResidual);
    }
    for (long s = 0; s < samples && f.analog.channel_count() > 0; ++s) {
      const long row = fr * samples + s;
      for (int c = 0; c < f.analog.channel_count(); ++c) {
        value(f.analog.values(row, c) / scales[std::size_t(c)]);
      }
    }
  }
}

std::vector<std::uint8_t> encode(const C3dFile& f, const C3dWriteOptions& o) {
  check_markers(f.markers, o);
  const long samples = samples_per_frame(f);
  check_analog(f, samples);
  check_plates(f);
  const std::vector<double> scales = analog_scales(f.analog, o.storage);
  const NumberFormat format(o.processor);
  // The data block depends on the parameter section's size, which does not depend on it.
  auto parameters = [&](long data_block) {
    ParameterWriter p;
    point_group(&p, f, o, data_block);
    analog_group(&p, f, scales, samples);
    force_platform_group(&p, f);
    trial_group(&p, f.markers);
    return p.serialize(format);
  };
  const long data_block = 2 + long(parameters(0).size() / kBlockBytes);
  ByteWriter w(format);
  write_header(&w, f, o, samples, data_block);
  const std::vector<std::uint8_t> section = parameters(data_block);
  w.bytes().insert(w.bytes().end(), section.begin(), section.end());
  write_data(&w, f, o, scales, samples);
  w.pad_to_block();
  return std::move(w.bytes());
}

}  // namespace

void write_c3d(const std::string& path, const C3dFile& file, const C3dWriteOptions& options) {
  std::vector<std::uint8_t> bytes;
  try {
    bytes = encode(file, options);
  } catch (const sim::InvalidArgument& e) {
    throw sim::InvalidArgument(path + ": " + e.what());  // name the file too
  }
  sim::write_file_atomically(path, std::string(bytes.begin(), bytes.end()));
}

}  // namespace biodyn::mocap_io
