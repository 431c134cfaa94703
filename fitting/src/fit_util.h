#pragma once
// Small helpers shared by the fits, binning and hole filling (the MERL dimensions, JSON of
// numbers that may be NaN, a hash for deterministic subsampling).
#include <cmath>
#include <cstdint>

#include "paintlab/brdf/brdf.h"
#include "paintlab/brdf/merl.h"
#include "paintlab/core/json.h"

namespace paintlab::fit {

// The MERL table's dimensions, as the fitting code names them.
using brdf::kMerlBins;
using brdf::kMerlPhiD;
using brdf::kMerlThetaD;
using brdf::kMerlThetaH;

// NaN and infinities become null (JSON has no NaN).
inline Json number_or_null(double v) { return std::isfinite(v) ? Json(v) : Json(nullptr); }

inline Json rgb_to_json(const brdf::Rgb& v) {
  return Json::array({number_or_null(v[0]), number_or_null(v[1]), number_or_null(v[2])});
}

// SplitMix64 (Steele, Lea, Flood 2014): a well-mixed 64-bit hash of an integer.
inline std::uint64_t splitmix64(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

}  // namespace paintlab::fit
