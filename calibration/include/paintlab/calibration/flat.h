#pragma once
// The flat field: the relative gain of every pixel (lens vignetting x pixel response
// non-uniformity), measured on images of a uniform target (diffuse white tile or
// integrating sphere). A merged radiance is divided by it. Written as calib/flat.json with
// the gain map in flat.exr beside it.
#include <array>
#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "paintlab/calibration/exposure_stack.h"
#include "paintlab/calibration/record.h"
#include "paintlab/calibration/response.h"
#include "paintlab/core/image.h"
#include "paintlab/core/json.h"

namespace paintlab::calib {

struct DarkFrame;

struct FlatField {
  ImageF gain;                   // per pixel and channel; mean 1 per channel over the trusted pixels
  double corner_ratio = 1.0;     // darkest / brightest corner block (mean gain of each 1/8 x 1/8 corner)
  double centre_to_corner = 1.0; // darkest corner block / centre block (vignetting)
  double prnu_rel = 0.0;         // pixel non-uniformity: robust std of gain / its 7x7 local mean
  double mean_signal_dn = 0.0;   // mean dark-subtracted value of the flat frames
  double saturated_fraction = 0.0;  // values at or above saturation in the flat frames
  NoiseModel noise;              // conversion gain by photon transfer (>= 2 frames at one exposure)
  // Set for a colour-filter-array camera (ExposureStack::cfa): the gain is normalised per
  // colour, so the flat holds vignetting and pixel non-uniformity but not the camera's or the
  // diffuser's colour (white balance is the radiometric scale's business, per channel).
  std::optional<std::array<int, 4>> cfa{};
  int frame_count = 0;
  std::vector<double> exposures_s;
  Provenance provenance;

  int width() const { return gain.width(); }
  int height() const { return gain.height(); }
  int channels() const { return gain.channels(); }

  // Frames, mean signal, corner and vignetting ratios, pixel non-uniformity, conversion gain.
  std::string describe() const;
  Json to_json(const std::string& map_file, const std::string& map_sha256) const;
  // Writes `json_path` and, beside it, <stem>.exr (channel flat, or flat.R/G/B), atomically.
  void save(const std::filesystem::path& json_path) const;
  // DataError when the EXR is missing, altered (checksum) or the wrong size.
  static FlatField load(const std::filesystem::path& json_path);
};

struct FlatOptions {
  double max_saturated_fraction = 1e-4;  // more saturated values than this: CalibrationError
  double min_signal_frac = 0.05;         // mean signal below this share of full scale: CalibrationError
  // One-plane mosaic frames of a colour-filter array (ExposureStack::cfa): each colour's sites
  // normalised to mean 1 on their own, the non-uniformity measured among sites of one colour.
  std::optional<std::array<int, 4>> cfa{};

  void check() const;  // UsageError naming the first violated rule
};

// From frames of a uniform target. Each frame is dark-subtracted (`dark`, else the
// response's black level), linearised (`response`, else taken as linear) and divided by its
// exposure time; their mean, normalised per channel, is the gain. Hot pixels of `dark` get
// gain 1. Throws DataError for a bad stack and CalibrationError for saturated or too dark frames.
FlatField calibrate_flat(std::span<const StackFrame> frames, int bit_depth, const FlatOptions& options = {},
                         const ResponseCurve* response = nullptr, const DarkFrame* dark = nullptr);

}  // namespace paintlab::calib
