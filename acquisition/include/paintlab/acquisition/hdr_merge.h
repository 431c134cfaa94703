#pragma once
// HDR merging of an exposure bracket into linear radiance with a per-pixel variance and
// validity mask (Robertson et al.'s estimator):
//
//   u_j = z_j - dark(t_j)        dark-subtracted raw value of exposure j
//   y_j = g(u_j)                 linearised by the response curve (calib/response.json)
//   E   = sum w_j t_j y_j / sum w_j t_j^2 / flat
//   var = sum w_j^2 t_j^2 s_j^2 / (sum w_j t_j^2)^2 / flat^2
//
// w_j is zero at and above saturation and at and below the noise floor; s_j^2 is the
// variance of y_j (the response's residual spread, or read + shot noise). E is in
// linearised DN per second. Output channels (ExrImage, all float):
//   mono:  Y, var.Y, valid          RGB: R, G, B, var.R, var.G, var.B, valid
// valid = 1 where every channel had at least one exposure with weight > 0 and the pixel is
// not hot; elsewhere valid = 0, var = +inf, and the value is a bound: saturated in the
// shortest exposure -> g(saturation) / t_min (a lower bound), else the longest exposure's
// g(u) / t_max (at or below the noise floor).
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "paintlab/calibration/dark.h"
#include "paintlab/calibration/exposure_stack.h"
#include "paintlab/calibration/flat.h"
#include "paintlab/calibration/response.h"
#include "paintlab/calibration/rig_calibration.h"
#include "paintlab/core/image.h"
#include "paintlab/core/image_io.h"

namespace paintlab::acq {

// The calibration a merge applies; every part is optional.
struct HdrCalibration {
  std::optional<calib::ResponseCurve> response;  // none: a linear camera, g(u) = u
  std::optional<calib::DarkFrame> dark;          // none: subtract the response's black level
  std::optional<calib::FlatField> flat;          // none: gain 1 everywhere

  // The response, dark and flat of a rig's calibration folder, those it holds.
  static HdrCalibration of(const calib::RigCalibration& rig);
};

// The calibration files a merge of images from files linearises with (paintlab hdr merge):
// each one given, else the rig's.
struct HdrFiles {
  std::filesystem::path response, dark, flat;  // empty: none

  // Fills each empty one with `calibration_dir`'s response.json, dark.json or flat.json where
  // that exists.
  void complete_from(const std::filesystem::path& calibration_dir);
  bool empty() const { return response.empty() && dark.empty() && flat.empty(); }
  HdrCalibration load() const;
  // Records the files' SHA-256 in the image's header (paintlab.response_sha256, ...).
  void stamp(ExrImage& image) const;
};

struct HdrOptions {
  // Default: InverseVariance when a noise model is known (response residuals, noise below),
  // else Robertson.
  std::optional<calib::Weighting> weighting;
  double saturation_dn = -1.0;  // < 0: the response's, else 2^bits - 1
  double floor_dn = -1.0;       // < 0: the response's, else 3 x read noise of the dark frame, else 0
  double black_dn = -1.0;       // < 0: the response's black level, else 0 (used without a dark frame)
  // Noise model used when the response has no residual spread (source empty: unknown; the
  // variance then holds quantisation only, a lower bound, and says so in the EXR header).
  calib::NoiseModel noise;
  std::size_t tile_values = 16384;  // values per tile: the unit of parallel work
  // The inner loops: false = the fastest this CPU runs (AVX2 + FMA where it has them), true =
  // the x86-64 baseline ones (the same results within float rounding; for tests).
  bool baseline_simd = false;

  void check() const;  // UsageError naming the first violated rule
};

struct HdrStats {
  long long pixels = 0;
  long long valid = 0;
  long long saturated = 0;   // invalid: saturated even in the shortest exposure
  long long dark = 0;        // invalid: below the noise floor in every exposure
  long long hot = 0;         // invalid: hot pixel of the dark frame
  std::string weighting;
  std::string noise_model;   // where the variance comes from
};

struct HdrResult {
  ExrImage image;
  HdrStats stats;
};

class HdrAccumulator;

// Prepared once per calibration and image geometry; merge() may run concurrently from
// several threads. Uses TBB for parallelism inside each call.
class HdrMerger {
 public:
  // bit_depth: significant bits of the raw frames (8..16).
  HdrMerger(const HdrCalibration& calibration, const HdrOptions& options, int width, int height, int channels,
            int bit_depth);
  ~HdrMerger();
  HdrMerger(const HdrMerger&) = delete;
  HdrMerger& operator=(const HdrMerger&) = delete;

  // Merges a whole bracket, tile by tile (each tile's accumulators stay in cache while every
  // exposure streams through). Throws DataError when a frame does not match the geometry.
  HdrResult merge(std::span<const calib::StackFrame> frames) const;

  // Streaming: add frames as they arrive (each may be freed after add()), then finish().
  HdrAccumulator accumulator() const;

  int width() const;
  int height() const;
  int channels() const;
  int bit_depth() const;
  const calib::ValueWindow& window() const;
  calib::Weighting weighting() const;
  // The instruction set of the merge's inner loops on this CPU ("avx2+fma", "x86-64", ...).
  const char* simd() const;

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

class HdrAccumulator {
 public:
  ~HdrAccumulator();
  HdrAccumulator(HdrAccumulator&&) noexcept;
  HdrAccumulator& operator=(HdrAccumulator&&) noexcept;

  // Adds one frame (raw values and its applied exposure time). DataError on a mismatch.
  void add(const Image<std::uint16_t>& pixels, double exposure_s);
  int frames() const;
  // The merged result; the accumulator is spent afterwards. DataError when no frame was added.
  HdrResult finish();

 private:
  friend class HdrMerger;
  struct State;
  explicit HdrAccumulator(std::unique_ptr<State> state);
  std::unique_ptr<State> state_;
};

// Convenience: one merge with a fresh HdrMerger.
HdrResult merge_hdr(std::span<const calib::StackFrame> frames, int bit_depth, const HdrCalibration& calibration,
                    const HdrOptions& options = {});

}  // namespace paintlab::acq
