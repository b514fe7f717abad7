// biodyn mocap convert: C3D/TRC markers to TRC or C3D, or a BVH rewritten with its lengths
// scaled (issue 5).
#include <algorithm>
#include <cmath>
#include <iostream>
#include <memory>

#include "biodyn/mocap_io/bvh.h"
#include "biodyn/mocap_io/c3d.h"
#include "biodyn/mocap_io/trc.h"
#include "biodyn/sim/errors.h"
#include "biodyn/sim/log.h"
#include "cmd_mocap.h"

namespace biodyn::apps {
namespace {

struct ConvertOptions {
  std::string in, out, units = "mm", processor = "intel", storage = "float";
  double scale = 1.0;
  int precision = 10;
};

/// BVH to BVH with every length (offsets, position channels) times --scale.
int convert_bvh(const ConvertOptions& conv) {
  if (!(conv.scale > 0 && std::isfinite(conv.scale))) {
    throw sim::InvalidArgument("--scale: must be > 0, got " + std::to_string(conv.scale));
  }
  mocap_io::BvhMotion b = mocap_io::read_bvh(conv.in);
  for (mocap_io::BvhJoint& jt : b.joints) {
    jt.offset *= conv.scale;
    for (size_t c = 0; c < jt.channels.size(); ++c) {
      const mocap_io::BvhChannel ch = jt.channels[c];
      if (ch == mocap_io::BvhChannel::kXposition || ch == mocap_io::BvhChannel::kYposition ||
          ch == mocap_io::BvhChannel::kZposition) {
        b.values.col(jt.first_channel + static_cast<int>(c)) *= conv.scale;
      }
    }
  }
  mocap_io::write_bvh(conv.out, b, conv.precision);
  std::cout << "wrote " << conv.out << ": " << b.frame_count() << " frames, " << b.joints.size()
            << " joints\n";
  return kExitOk;
}

/// The C3D output's processor and storage from --processor and --storage; integer storage at
/// the finest scale whose range holds `markers` (printed).
mocap_io::C3dWriteOptions c3d_write_options(const ConvertOptions& conv,
                                            const mocap_io::MarkerData& markers) {
  mocap_io::C3dWriteOptions w;
  if (conv.processor == "intel") {
    w.processor = mocap_io::C3dProcessor::kIntel;
  } else if (conv.processor == "dec") {
    w.processor = mocap_io::C3dProcessor::kDec;
  } else if (conv.processor == "mips") {
    w.processor = mocap_io::C3dProcessor::kMips;
  } else {
    throw sim::InvalidArgument("--processor: expected intel, dec or mips, got '" + conv.processor +
                               "'");
  }
  if (conv.storage == "float") {
    w.storage = mocap_io::C3dStorage::kFloat;
  } else if (conv.storage == "integer") {
    w.storage = mocap_io::C3dStorage::kInteger;
  } else {
    throw sim::InvalidArgument("--storage: expected float or integer, got '" + conv.storage + "'");
  }
  if (w.storage == mocap_io::C3dStorage::kInteger) {
    // The finest resolution (at least 0.1 mm) whose 16-bit range holds the data.
    constexpr double kFinestScale_mm = 0.1;
    constexpr double kUsableRange = 32000.0;  // of the int16's 32767
    double max_abs_mm = 0.0;
    for (Eigen::Index k = 0; k < markers.positions_m.size(); ++k) {
      const double v = markers.positions_m.data()[k];
      if (std::isfinite(v)) max_abs_mm = std::max(max_abs_mm, 1000.0 * std::abs(v));
    }
    w.integer_scale_mm =
        std::max(kFinestScale_mm, std::ceil(1000.0 * max_abs_mm / kUsableRange) / 1000.0);
    std::cout << "integer storage at " << w.integer_scale_mm << " mm per unit\n";
  }
  return w;
}

int run_convert(const ConvertOptions& conv) {
  const Format in = format_of(conv.in, "IN"), out = format_of(conv.out, "OUT");
  if (conv.precision < 3 || conv.precision > 17) {
    throw sim::InvalidArgument("--precision: must be within [3, 17], got " +
                               std::to_string(conv.precision));
  }
  if (in == Format::kBvh || out == Format::kBvh) {
    if (in != out) {
      throw sim::InvalidArgument("convert: BVH converts only to BVH (got " + conv.in + " -> " +
                                 conv.out + ")");
    }
    return convert_bvh(conv);
  }
  if (in == Format::kCsv || out == Format::kCsv) {
    throw sim::InvalidArgument("convert: CSV is not a capture format (use mocap ik)");
  }
  mocap_io::C3dFile data;
  if (in == Format::kC3d) {
    data = mocap_io::read_c3d(conv.in);
  } else {
    const mocap_io::TrcFile trc = mocap_io::read_trc(conv.in);
    data.markers = trc.markers;
    if (out == Format::kC3d) {
      // C3D stores one rate and no times: the Time column's when DataRate disagrees with it
      // (uniform_rate says why), refused when the rows are not evenly spaced.
      const mocap_io::TrcUniformRate rate = mocap_io::uniform_rate(trc, conv.in);
      data.markers.rate_hz = rate.rate_hz;
      if (!rate.note.empty()) sim::log(sim::LogLevel::kWarning, rate.note);
    }
  }
  if (out == Format::kTrc) {
    mocap_io::write_trc(conv.out, data.markers, conv.units, conv.precision);
  } else {
    mocap_io::write_c3d(conv.out, data, c3d_write_options(conv, data.markers));
  }
  std::cout << "wrote " << conv.out << ": " << data.markers.frame_count() << " frames, "
            << data.markers.marker_count() << " markers\n";
  return kExitOk;
}

}  // namespace

Command add_mocap_convert_command(CLI::App* mocap) {
  auto conv = std::make_shared<ConvertOptions>();
  CLI::App* conv_cmd = mocap->add_subcommand(
      "convert", "Convert C3D/TRC markers to TRC or C3D, or rewrite a BVH (scaled lengths)");
  conv_cmd->add_option("IN", conv->in, "input file (.c3d, .trc, .bvh)")->required();
  conv_cmd->add_option("OUT", conv->out, "output file (.trc, .c3d, .bvh)")->required();
  conv_cmd->add_option("--units", conv->units, "TRC output units: mm or m")->capture_default_str();
  conv_cmd->add_option("--processor", conv->processor, "C3D output: intel, dec or mips")
      ->capture_default_str();
  conv_cmd->add_option("--storage", conv->storage, "C3D output: float or integer")
      ->capture_default_str();
  conv_cmd->add_option("--scale", conv->scale, "BVH: multiply every length (offsets, positions)")
      ->capture_default_str();
  conv_cmd->add_option("--precision", conv->precision, "significant digits of text outputs")
      ->capture_default_str();
  return {conv_cmd, [conv]() { return run_convert(*conv); }};
}

}  // namespace biodyn::apps
