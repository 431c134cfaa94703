#pragma once
// The dark frame: the black level of every pixel as a function of exposure time
// (bias + dark current x t), the read noise, and the map of hot (and noisy) pixels.
// Written as calib/dark.json with the per-pixel maps in dark.exr beside it.
#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <vector>

#include "paintlab/calibration/exposure_stack.h"
#include "paintlab/calibration/record.h"
#include "paintlab/core/image.h"
#include "paintlab/core/json.h"

namespace paintlab::calib {

struct DarkFrame {
  int bit_depth = 16;
  ImageF bias_dn;          // per pixel and channel: dark level at zero exposure (DN)
  ImageF rate_dn_per_s;    // per pixel and channel: dark current (DN/s); 0 if one exposure only
  ImageU8 hot;             // per pixel (one channel): 1 = hot or noisy, its values are not trusted
  double read_noise_dn = 0.0;      // temporal std at the shortest exposure (RMS over pixels); 0 = not measured
  bool read_noise_measured = false;
  double mean_bias_dn = 0.0;       // mean of bias over the non-hot pixels
  double mean_rate_dn_per_s = 0.0;
  long long hot_count = 0;
  std::vector<double> exposures_s;  // the distinct exposures of the dark frames
  int frame_count = 0;
  Provenance provenance;

  int width() const { return bias_dn.width(); }
  int height() const { return bias_dn.height(); }
  int channels() const { return bias_dn.channels(); }
  // Dark level (DN) of value `index` (interleaved pixel*channels + channel) at `exposure_s`.
  float level(std::size_t index, double exposure_s) const {
    return bias_dn.data()[index] + rate_dn_per_s.data()[index] * static_cast<float>(exposure_s);
  }
  double hot_fraction() const;
  // Mean dark level at `exposure_s` over the non-hot pixels.
  double mean_level_dn(double exposure_s) const { return mean_bias_dn + mean_rate_dn_per_s * exposure_s; }

  // Frames, black level, dark current, read noise (or why it is not measured), hot pixels.
  std::string describe() const;
  Json to_json(const std::string& map_file, const std::string& map_sha256) const;
  // Writes `json_path` and, beside it, the maps as <stem>.exr (channels bias[.R/G/B],
  // rate[.R/G/B], hot), both atomically; the JSON names the EXR and its SHA-256.
  void save(const std::filesystem::path& json_path) const;
  // Reads both; DataError when the EXR is missing, altered (checksum) or the wrong size.
  static DarkFrame load(const std::filesystem::path& json_path);
};

struct DarkOptions {
  // A pixel is hot when its dark level at the longest exposure lies more than hot_sigma
  // robust standard deviations (1.4826 MAD) and at least hot_min_dn above the median.
  double hot_sigma = 6.0;
  double hot_min_dn = 2.0;
  // ... or noisy when its temporal std exceeds noisy_factor x the median (needs >= 2 frames
  // at one exposure).
  double noisy_factor = 5.0;

  void check() const;  // UsageError naming the first violated rule
};

// From dark frames (lens capped or light off), at one or more exposure times and ideally
// several frames per exposure. Throws DataError for a bad stack.
DarkFrame calibrate_dark(std::span<const StackFrame> frames, int bit_depth, const DarkOptions& options = {});

}  // namespace paintlab::calib
