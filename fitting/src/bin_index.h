#pragma once
// MERL bin indices inlined for the binning loop. The arithmetic is brdf/src/merl.cpp's
// (the reference reader's order of operations), so every sample lands in the bin
// brdf::merl_bin() gives; tests/unit/fitting/binning_test.cpp checks that on the 1215
// reference rows and on random and edge angles.
#include <cmath>
#include <cstdint>
#include <numbers>

#include "paintlab/brdf/merl.h"

namespace paintlab::fit::detail {

inline constexpr double kPi = std::numbers::pi;
inline constexpr double kHalfPi = kPi / 2.0;
inline constexpr std::uint32_t kSlice = brdf::kMerlThetaD * brdf::kMerlPhiD;  // bins per theta_h row

inline int clamp_index(int v, int n) { return v < 0 ? 0 : (v >= n ? n - 1 : v); }

inline int theta_h_index(double theta_h) {
  if (theta_h <= 0.0) return 0;
  const double deg_scaled = theta_h / (kPi / 2.0) * brdf::kMerlThetaH;
  const double t = std::sqrt(deg_scaled * brdf::kMerlThetaH);
  return clamp_index(static_cast<int>(t), brdf::kMerlThetaH);
}

inline int theta_d_index(double theta_d) {
  return clamp_index(static_cast<int>(theta_d / (kPi * 0.5) * brdf::kMerlThetaD), brdf::kMerlThetaD);
}

// phi_d reduced to [0, pi] with one addition of pi, as the reference does.
inline double reduce_phi_d(double phi_d) { return phi_d < 0.0 ? phi_d + kPi : phi_d; }

inline int phi_d_index_reduced(double phi_reduced) {
  return clamp_index(static_cast<int>(phi_reduced / kPi * (2 * brdf::kMerlPhiD) / 2), brdf::kMerlPhiD);
}

// Lower edges of the bins (radians; phi_d in the reduced range).
inline double theta_h_edge(int i) {
  const double u = static_cast<double>(i) / brdf::kMerlThetaH;
  return u * u * kHalfPi;
}
inline double theta_d_edge(int j) { return static_cast<double>(j) / brdf::kMerlThetaD * kHalfPi; }
inline double phi_d_edge(int k) { return static_cast<double>(k) / brdf::kMerlPhiD * kPi; }

// Angles a sample may have; 1e-9 rad of rounding past an end is tolerated (it lands in
// the end bin, as in the reference). NaN fails every comparison.
inline constexpr double kAngleSlack = 1e-9;
inline bool angles_valid(double th, double td, double pd) {
  return th >= -kAngleSlack && th <= kHalfPi + kAngleSlack && td >= -kAngleSlack && td <= kHalfPi + kAngleSlack &&
         pd >= -kPi - kAngleSlack && pd <= kPi + kAngleSlack;
}

inline std::uint32_t flat_index(int i, int j, int k) {
  return static_cast<std::uint32_t>(k) +
         static_cast<std::uint32_t>(brdf::kMerlPhiD) *
             (static_cast<std::uint32_t>(j) + static_cast<std::uint32_t>(brdf::kMerlThetaD) * static_cast<std::uint32_t>(i));
}

}  // namespace paintlab::fit::detail
