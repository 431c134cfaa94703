#pragma once
// Counter-based random numbers: every value is a pure function of (seed, stream, counter),
// so images are identical whatever the thread count or evaluation order.
#include <array>
#include <cmath>
#include <cstdint>

namespace paintlab::sim::detail {

// SplitMix64's finaliser (Steele, Lea, Flood 2014): a bijective 64-bit mixer.
inline std::uint64_t mix64(std::uint64_t z) {
  z += 0x9e3779b97f4a7c15ull;
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  return z ^ (z >> 31);
}

inline std::uint64_t hash_key(std::uint64_t seed, std::uint64_t stream, std::uint64_t counter = 0) {
  return mix64(mix64(seed ^ mix64(stream)) + counter);
}

// A double in [0, 1) from the top 53 bits.
inline double uniform01(std::uint64_t bits) { return static_cast<double>(bits >> 11) * 0x1.0p-53; }

// Standard normal deviates from 32 random bits through a 4096-entry inverse-CDF table
// with linear interpolation (tails reach +-3.5 sigma; the table is rescaled so that the
// variance is exactly 1).
class NormalTable {
 public:
  static const NormalTable& get();
  float operator()(std::uint32_t bits) const {
    std::uint32_t i = bits >> 20;                      // 12 bits: the node
    float f = static_cast<float>(bits & 0xFFFFFu) * (1.0f / 1048576.0f);
    return nodes_[i] + f * (nodes_[i + 1] - nodes_[i]);
  }

 private:
  NormalTable();
  std::array<float, 4097> nodes_{};
};

// Inverse of the standard normal CDF (bisection on erfc; for tables, not inner loops).
double inverse_normal_cdf(double p);

// A Poisson deviate of mean mu (small mu: inversion of the CDF with one uniform).
inline double poisson_small(double mu, double u) {
  double p = std::exp(-mu), cdf = p;
  int k = 0;
  while (u > cdf && k < 200) {
    ++k;
    p *= mu / k;
    cdf += p;
  }
  return k;
}

}  // namespace paintlab::sim::detail
