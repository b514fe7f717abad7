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

namespace {

/// Marker m's trajectory filtered at `filter` into `out` (each unbroken run on its own); the
/// sum of squared differences from the raw samples and their count into sum2 / n.
void filter_marker(const MarkerData& markers, int m, const LowPassFilter& filter,
                   Eigen::MatrixXd* out, double* sum2, long* n) {
  const int frames = markers.frame_count();
  *out = markers.positions_m.middleCols(3 * m, 3);
  *sum2 = 0;
  *n = 0;
  Eigen::MatrixXd run;
  for (int start = 0; start < frames;) {
    if (!markers.visible(start, m)) {
      ++start;
      continue;
    }
    int end = start;
    while (end < frames && markers.visible(end, m)) ++end;
    run = out->middleRows(start, end - start);
    low_pass(&run, markers.rate_hz, filter);
    *sum2 += (run - out->middleRows(start, end - start)).squaredNorm();
    *n += 3L * (end - start);
    out->middleRows(start, end - start) = run;
    start = end;
  }
}

}  // namespace

double residual_cutoff_hz(const MarkerData& markers, int m) {
  constexpr double kStep_hz = 0.5, kLowest_hz = 1.0, kHighest_hz = 25.0;
  const double highest = std::min(kHighest_hz, 0.6 * 0.5 * markers.rate_hz * kDoublePassCorrection);
  Eigen::MatrixXd filtered;
  std::vector<double> fc, residual;
  long n = 0;
  for (double f = kLowest_hz; f <= highest + 1e-9; f += kStep_hz) {
    double sum2 = 0;
    filter_marker(markers, m, {f}, &filtered, &sum2, &n);
    if (n < 60) return 0.0;  // fewer than 20 samples
    fc.push_back(f);
    residual.push_back(std::sqrt(sum2 / static_cast<double>(n)));
  }
  if (fc.size() < 6) return 0.0;  // a frame rate too low to tell signal from noise
  // The noise line: least squares over the top third of the cut-offs.
  const std::size_t from = fc.size() - fc.size() / 3;
  double sx = 0, sy = 0, sxx = 0, sxy = 0, k = 0;
  for (std::size_t i = from; i < fc.size(); ++i) {
    sx += fc[i];
    sy += residual[i];
    sxx += fc[i] * fc[i];
    sxy += fc[i] * residual[i];
    k += 1;
  }
  const double slope = (k * sxy - sx * sy) / (k * sxx - sx * sx);
  const double noise = (sy - slope * sx) / k;  // the line at 0 Hz
  for (std::size_t i = 0; i < fc.size(); ++i)
    if (residual[i] <= noise) return fc[i];
  return fc.back();
}

void low_pass_markers_auto(MarkerData* markers, std::vector<double>* cutoffs_hz) {
  if (cutoffs_hz) cutoffs_hz->clear();
  Eigen::MatrixXd filtered;
  double sum2 = 0;
  long n = 0;
  for (int m = 0; m < markers->marker_count(); ++m) {
    const double f = residual_cutoff_hz(*markers, m);
    if (cutoffs_hz) cutoffs_hz->push_back(f);
    if (f == 0) continue;
    filter_marker(*markers, m, {f}, &filtered, &sum2, &n);
    markers->positions_m.middleCols(3 * m, 3) = filtered;
  }
}

void low_pass_markers(MarkerData* markers, const LowPassFilter& filter) {
  if (filter.cutoff_hz == 0.0) return;
  single_pass_cutoff_hz(filter, markers->rate_hz);
  Eigen::MatrixXd filtered;
  double sum2 = 0;
  long n = 0;
  for (int m = 0; m < markers->marker_count(); ++m) {
    filter_marker(*markers, m, filter, &filtered, &sum2, &n);
    markers->positions_m.middleCols(3 * m, 3) = filtered;
  }
}

}  // namespace biodyn::mocap_io
