// The zero-lag low-pass (Winter 2009, §3.4.4) on samples and on marker trajectories with gaps.
#include "biodyn/mocap_io/filter.h"

#include <catch2/catch.hpp>
#include <cmath>
#include <limits>
#include <random>

#include "biodyn/sim/errors.h"
#include "biodyn/sim/units.h"

using namespace biodyn;

TEST_CASE("The zero-lag low-pass keeps slow signals and removes fast ones", "[mocap_io][filter]") {
  const double rate = 250.0;
  Eigen::MatrixXd x(1000, 2);
  for (int i = 0; i < 1000; ++i) {
    const double t = i / rate;
    x(i, 0) = std::sin(2 * kPi * 1.0 * t);   // 1 Hz: kept
    x(i, 1) = std::sin(2 * kPi * 40.0 * t);  // 40 Hz: removed
  }
  Eigen::MatrixXd y = x;
  mocap_io::low_pass(&y, rate, {6.0});
  // Away from the ends: 1 Hz passes with no lag and < 1% change; 40 Hz drops below 1%.
  CHECK((y.col(0) - x.col(0)).segment(100, 800).cwiseAbs().maxCoeff() < 0.01);
  CHECK(y.col(1).segment(100, 800).cwiseAbs().maxCoeff() < 0.01);
  CHECK_THROWS_AS(mocap_io::low_pass(&y, rate, {120.0}), sim::InvalidArgument);
}

TEST_CASE("Marker trajectories are filtered run by run: gaps stay gaps, noise drops",
          "[mocap_io][filter]") {
  // Two markers at 100 Hz: a 1 Hz swing of 10 cm with 2 mm of white noise (0.5 px through 8
  // cameras); the first has a 30-frame gap in the middle, the second a single-sample run.
  const int frames = 400;
  const double rate = 100.0, nan = std::numeric_limits<double>::quiet_NaN();
  mocap_io::MarkerData m;
  m.rate_hz = rate;
  m.labels = {"A", "B"};
  m.positions_m.resize(frames, 6);
  Eigen::MatrixXd truth(frames, 6);
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(0.0, 0.002);
  for (int f = 0; f < frames; ++f) {
    const double s = 0.1 * std::sin(2 * kPi * f / rate);
    for (int c = 0; c < 6; ++c) {
      truth(f, c) = s + 0.01 * c;
      m.positions_m(f, c) = truth(f, c) + noise(rng);
    }
  }
  for (int f = 180; f < 210; ++f) m.positions_m.block(f, 0, 1, 3).setConstant(nan);
  for (int f = 0; f < frames; ++f)
    if (f != 300) m.positions_m.block(f, 3, 1, 3).setConstant(nan);
  const Eigen::MatrixXd raw = m.positions_m;
  mocap_io::low_pass_markers(&m, {6.0});
  for (int f = 0; f < frames; ++f) {
    CHECK(m.visible(f, 0) == (f < 180 || f >= 210));
    CHECK(m.visible(f, 1) == (f == 300));
  }
  // The lone sample is its own run: unchanged.
  CHECK(m.positions_m(300, 3) == raw(300, 3));
  // Away from the runs' ends the noise falls to about a third (6 Hz of the 50 Hz band) and the
  // 1 Hz swing is kept with no lag.
  double before = 0, after = 0;
  int n = 0;
  for (int f = 20; f < frames - 20; ++f) {
    if (f >= 160 && f < 230) continue;
    for (int c = 0; c < 3; ++c) {
      before += std::pow(raw(f, c) - truth(f, c), 2);
      after += std::pow(m.positions_m(f, c) - truth(f, c), 2);
      ++n;
    }
  }
  INFO("noise RMS " << std::sqrt(before / n) << " m -> " << std::sqrt(after / n) << " m");
  CHECK(std::sqrt(after / n) < 0.5 * std::sqrt(before / n));
  mocap_io::MarkerData bad = m;
  CHECK_THROWS_AS(mocap_io::low_pass_markers(&bad, {60.0}), sim::InvalidArgument);
  CHECK_THROWS_AS(mocap_io::low_pass_markers(&bad, {-1.0}), sim::InvalidArgument);
  mocap_io::low_pass_markers(&bad, {0.0});  // 0: unfiltered
  const Eigen::ArrayXXd a = bad.positions_m.array(), b = m.positions_m.array();
  CHECK(((a == b) || (a.isNaN() && b.isNaN())).all());
}

TEST_CASE("Residual analysis picks a cut-off that removes noise and keeps the motion",
          "[mocap_io][filter]") {
  // A marker at 100 Hz moving like a foot (1 Hz swing plus 3 and 6 Hz harmonics), with 2 mm
  // of white noise and without; and a slow one (0.5 Hz) with the same noise.
  const int frames = 600;
  const double rate = 100.0;
  std::mt19937 rng(9);
  std::normal_distribution<double> noise(0.0, 0.002);
  mocap_io::MarkerData m;
  m.rate_hz = rate;
  m.labels = {"noisy", "clean", "slow"};
  m.positions_m.resize(frames, 9);
  Eigen::MatrixXd truth(frames, 9);
  for (int f = 0; f < frames; ++f) {
    const double t = f / rate;
    const double fast = 0.2 * std::sin(2 * kPi * t) + 0.03 * std::sin(2 * kPi * 3 * t) +
                        0.01 * std::sin(2 * kPi * 6 * t);
    for (int c = 0; c < 3; ++c) {
      truth(f, c) = truth(f, 3 + c) = fast + 0.1 * c;
      truth(f, 6 + c) = 0.1 * std::sin(2 * kPi * 0.5 * t) + 0.1 * c;
      m.positions_m(f, c) = truth(f, c) + noise(rng);
      m.positions_m(f, 3 + c) = truth(f, 3 + c);
      m.positions_m(f, 6 + c) = truth(f, 6 + c) + noise(rng);
    }
  }
  const double noisy = mocap_io::residual_cutoff_hz(m, 0);
  const double clean = mocap_io::residual_cutoff_hz(m, 1);
  const double slow = mocap_io::residual_cutoff_hz(m, 2);
  INFO("cut-offs: noisy " << noisy << " Hz, clean " << clean << " Hz, slow " << slow << " Hz");
  CHECK(noisy >= 4);   // keeps the 3 Hz harmonic
  CHECK(noisy <= 15);  // removes most of the noise
  CHECK(clean > noisy);
  CHECK(slow < noisy);
  const Eigen::MatrixXd raw = m.positions_m;
  std::vector<double> cutoffs;
  mocap_io::low_pass_markers_auto(&m, &cutoffs);
  REQUIRE(cutoffs.size() == 3);
  CHECK(cutoffs[0] == noisy);
  const auto rms = [&](const Eigen::MatrixXd& x, int col) {
    return std::sqrt(
        (x.block(30, col, frames - 60, 3) - truth.block(30, col, frames - 60, 3)).squaredNorm() /
        (3.0 * (frames - 60)));
  };
  INFO("noisy marker: " << rms(raw, 0) << " m -> " << rms(m.positions_m, 0) << " m");
  // Measured: 1.98 -> 1.24 mm (the 6 Hz harmonic kept costs part of the noise's removal).
  CHECK(rms(m.positions_m, 0) < 0.7 * rms(raw, 0));
  CHECK(rms(m.positions_m, 3) < 0.0005);  // the clean one is hardly touched
  // Too short to analyse: left alone.
  mocap_io::MarkerData shorty = m;
  shorty.positions_m.conservativeResize(10, 9);
  CHECK(mocap_io::residual_cutoff_hz(shorty, 0) == 0.0);
}
