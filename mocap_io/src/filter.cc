#include "biodyn/mocap_io/filter.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "biodyn/sim/errors.h"
#include "biodyn/sim/units.h"

namespace biodyn::mocap_io {
namespace {

/// Winter 2009 §3.4.4.4: a 2nd-order filter run twice has its -3 dB point at 0.802 of the
/// single pass's cut-off; dividing by it keeps the asked cut-off.
constexpr double kDoublePassCorrection = 0.802;

/// One pass of the 2nd-order Butterworth low-pass (bilinear transform, pre-warped) over x.
void butterworth_pass(std::vector<double>* x, double cutoff_hz, double rate_hz) {
  const double k = std::tan(kPi * cutoff_hz / rate_hz);
  const double norm = 1.0 / (1.0 + std::sqrt(2.0) * k + k * k);
  const double b0 = k * k * norm, b1 = 2.0 * b0, b2 = b0;
  const double a1 = 2.0 * (k * k - 1.0) * norm, a2 = (1.0 - std::sqrt(2.0) * k + k * k) * norm;
  // Start at rest on the first sample (unit DC gain): no start-up transient.
  double x1 = (*x)[0], x2 = (*x)[0], y1 = (*x)[0], y2 = (*x)[0];
  for (double& v : *x) {
    const double y = b0 * v + b1 * x1 + b2 * x2 - a1 * y1 - a2 * y2;
    x2 = x1;
    x1 = v;
    y2 = y1;
    y1 = y;
    v = y;
  }
}

}  // namespace

double single_pass_cutoff_hz(const LowPassFilter& filter, double rate_hz) {
  const double cutoff = filter.cutoff_hz / kDoublePassCorrection;
  if (!(filter.cutoff_hz > 0) || !(cutoff < 0.5 * rate_hz)) {
    throw sim::InvalidArgument("filter cut-off: must be > 0 and, corrected for the double pass (/" +
                               std::to_string(kDoublePassCorrection) +
                               "), below the Nyquist frequency " + std::to_string(0.5 * rate_hz) +
                               " Hz, got " + std::to_string(filter.cutoff_hz) + " Hz");
  }
  return cutoff;
}

void low_pass(Eigen::MatrixXd* samples, double rate_hz, const LowPassFilter& filter) {
  if (filter.cutoff_hz == 0.0) return;
  const double cutoff = single_pass_cutoff_hz(filter, rate_hz);
  if (samples->rows() < 2) return;
  const Eigen::Index n = samples->rows();
  // Pad each end by odd reflection over about two cut-off periods.
  const Eigen::Index pad =
      std::min<Eigen::Index>(n - 1, static_cast<Eigen::Index>(std::ceil(2.0 * rate_hz / cutoff)));
  std::vector<double> x(static_cast<size_t>(n + 2 * pad));
  for (Eigen::Index c = 0; c < samples->cols(); ++c) {
    const auto col = samples->col(c);
    for (Eigen::Index i = 0; i < pad; ++i) {
      x[static_cast<size_t>(i)] = 2.0 * col(0) - col(pad - i);
      x[static_cast<size_t>(n + pad + i)] = 2.0 * col(n - 1) - col(n - 2 - i);
    }
    for (Eigen::Index i = 0; i < n; ++i) x[static_cast<size_t>(pad + i)] = col(i);
    butterworth_pass(&x, cutoff, rate_hz);
    std::reverse(x.begin(), x.end());
    butterworth_pass(&x, cutoff, rate_hz);
    std::reverse(x.begin(), x.end());
    for (Eigen::Index i = 0; i < n; ++i) samples->col(c)(i) = x[static_cast<size_t>(pad + i)];
  }
}

void low_pass_markers(MarkerData* markers, const LowPassFilter& filter) {
  if (filter.cutoff_hz == 0.0) return;
  single_pass_cutoff_hz(filter, markers->rate_hz);
  const int frames = markers->frame_count();
  Eigen::MatrixXd run;
  for (int m = 0; m < markers->marker_count(); ++m) {
    for (int start = 0; start < frames;) {
      if (!markers->visible(start, m)) {
        ++start;
        continue;
      }
      int end = start;
      while (end < frames && markers->visible(end, m)) ++end;
      run = markers->positions_m.block(start, 3 * m, end - start, 3);
      low_pass(&run, markers->rate_hz, filter);
      markers->positions_m.block(start, 3 * m, end - start, 3) = run;
      start = end;
    }
  }
}

}  // namespace biodyn::mocap_io
