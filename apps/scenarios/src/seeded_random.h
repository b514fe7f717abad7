#pragma once
// The sweeps' random draws (internal): the same numbers on every machine for a seed.

#include <cmath>
#include <cstdint>
#include <random>

namespace biodyn::scenarios {

/// Uniform numbers from a seed: mt19937_64's output is fixed by the standard, the mapping to
/// [0, 1) is ours (the standard distributions differ between libraries).
class SeededUniform {
 public:
  explicit SeededUniform(std::uint64_t seed) : rng_(seed) {}
  /// Uniform in [lo, hi).
  double operator()(double lo, double hi) {
    return lo + (hi - lo) * static_cast<double>(rng_() >> 11) * 0x1.0p-53;
  }
  /// Either, with even odds.
  bool coin() { return (rng_() >> 63) != 0; }

 private:
  std::mt19937_64 rng_;
};

/// x to the nearest multiple of `unit` (0.1, 0.01, 0.001: a drawn figure rounded so that a
/// printed replay line gives the same run). Divided by the whole number 1 / unit, not multiplied
/// by unit: k / 100 is the double that "k e-2" parses to, k x 0.01 is one ulp off for 407 of
/// k = 0..3000.
inline double round_to(double x, double unit) {
  return std::round(x / unit) / std::round(1.0 / unit);
}

}  // namespace biodyn::scenarios
