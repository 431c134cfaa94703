#pragma once
// The absolute BRDF scale from a reference sphere of known albedo (a white diffuse,
// Lambertian sphere in the sample's place), and the LED's angular emission profile.
// Written as calib/scale.json.
//
// A linear pixel value per second of exposure is V = s f E with f the BRDF (1/sr) at the
// pixel's sphere point and E = P(alpha) cos(theta_i) / d^2 the irradiance per unit LED
// intensity (LightModel::irradiance; P = cos^n of the angle off the LED axis). On the
// reference f = albedo / pi, so every lit reference pixel gives s P(alpha) = V / (albedo/pi
// cos(theta_i) / d^2); a least-squares line of log(s P) against log(cos alpha) gives log s
// and n. A sample's BRDF is then V / (s E): in 1/sr.
#include <array>
#include <filesystem>
#include <optional>
#include <limits>
#include <string>
#include <vector>

#include "paintlab/calibration/camera_model.h"
#include "paintlab/calibration/light.h"
#include "paintlab/calibration/record.h"
#include "paintlab/calibration/sphere.h"
#include "paintlab/core/image.h"
#include "paintlab/core/json.h"

namespace paintlab::calib {

// One image of the reference sphere with the LED at a table angle: linear values per
// second of exposure (linearised DN/s, as the HDR merge gives), 1 channel, and which
// pixels were clipped (empty: none known; else 1 = saturated, same size).
struct ReferenceImage {
  double table_angle_deg = 0.0;
  std::string name;
  ImageF rate;
  Image<std::uint8_t> saturated;
};

struct ScaleOptions {
  double albedo = 0.0;          // the reference's certified (hemispherical) albedo, required
  double min_cos = 0.25;        // pixels with cos(theta_i) or cos(theta_o) below this are not used
  bool fit_profile = true;      // fit the LED profile exponent (else keep profile_exponent)
  double profile_exponent = 0.0;  // used when fit_profile is false
  void check() const;
};

struct ScaleImageReport {
  double table_angle_deg = 0.0;
  std::string name;
  long long pixels = 0;          // used
  long long saturated = 0;       // reference pixels clipped (on the sphere, lit)
  double scale = 0.0;            // this image alone (with the common profile exponent)
};

struct ScaleCalibration {
  double scale = 0.0;            // s: linear DN/s per (1/sr x 1/m^2 per unit LED intensity)
  double uncertainty_rel = 0.0;  // 1-sigma relative: statistics and the spread between images
  double spread_rel = 0.0;       // relative std of the per-image scales (LED drift, stray light)
  double profile_exponent = 0.0;
  double profile_exponent_std = 0.0;
  double albedo = 0.0;
  long long pixels = 0;
  long long saturated = 0;
  double saturated_frac = 0.0;   // clipped / (clipped + used) reference pixels
  double residual_rel = 0.0;     // RMS relative residual of the pixels
  std::vector<ScaleImageReport> images;
  // A colour camera's scale per camera channel (R, G, B), each from the white reference seen
  // in that channel, the LED profile shared: their ratios are the camera's white balance under
  // the LED. `scale` is then the luminance's (the grey-balanced mosaic's, docs/calibration.md).
  std::optional<std::array<double, 3>> scale_rgb{};
  Provenance provenance;

  // BRDF (1/sr) of a pixel value per second V seen on a surface with irradiance E per unit
  // LED intensity (LightModel::irradiance with this profile exponent).
  double brdf(double rate, double irradiance) const { return rate / (scale * irradiance); }

  // A colour camera's white balance under the LED: scale / scale_rgb per channel, the factors
  // that make the camera channels of a grey surface equal. Unset without scale_rgb.
  std::optional<std::array<double, 3>> white_balance() const;

  // The scale with its uncertainty, the agreement between images, the LED profile and the
  // saturated share, in one line.
  std::string describe() const;
  Json to_json() const;
  static ScaleCalibration from_json(const Json& j, const std::string& where);
  void save(const std::filesystem::path& path) const;
  static ScaleCalibration load(const std::filesystem::path& path);
};

// Throws CalibrationError when no usable reference pixel remains (every lit pixel clipped,
// the LED off, the sphere not where sphere.json says).
ScaleCalibration calibrate_scale(const std::vector<ReferenceImage>& images, const CameraModel& camera,
                                 const SphereFit& sphere, const LightModel& light, const ScaleOptions& options);

}  // namespace paintlab::calib
