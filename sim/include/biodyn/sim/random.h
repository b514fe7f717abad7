#pragma once
/// Seeded random numbers that are the same on every platform and thread count: SplitMix64
/// (Steele et al. 2014) as a counter-based stream, keyed by a seed and the indices of what is
/// drawn (window, camera, frame, ...), so a draw never depends on the order work is done in.
/// (std's distributions are implementation-defined.)
#include <cmath>
#include <cstdint>
#include <initializer_list>

namespace biodyn::sim {

/// SplitMix64's output function of the counter `x`.
inline std::uint64_t splitmix64(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

/// The key of one stream: the seed mixed with each index in turn.
inline std::uint64_t stream_key(std::uint64_t seed, std::initializer_list<int> indices) {
  std::uint64_t k = splitmix64(seed);
  for (const int v : indices) k = splitmix64(k ^ static_cast<std::uint64_t>(v));
  return k;
}

/// Uniform numbers in (0, 1) and standard normal numbers (Box–Muller) from one key.
class RandomStream {
 public:
  explicit RandomStream(std::uint64_t key) : state_(key) {}
  /// In (0, 1), 53 bits.
  double uniform() { return (static_cast<double>(splitmix64(state_++) >> 11) + 0.5) * 0x1.0p-53; }
  double normal() {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    const double u1 = uniform();
    const double u2 = uniform();
    const double r = std::sqrt(-2.0 * std::log(u1)), a = 2.0 * M_PI * u2;
    spare_ = r * std::sin(a);
    has_spare_ = true;
    return r * std::cos(a);
  }

 private:
  std::uint64_t state_;
  double spare_ = 0;
  bool has_spare_ = false;
};

}  // namespace biodyn::sim
