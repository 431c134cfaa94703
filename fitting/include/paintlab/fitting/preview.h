#pragma once
// Previews of a paint (docs/axf-like.md "Previews"): a sphere rendered with the paint's BRDF,
// lit by a point light and optionally by an HDR environment map, tone-mapped to 8-bit sRGB;
// and the comparison of a measured HDR image with the model rendered in the same rig
// geometry (render_comparison()).
//
// The preview scene: a unit sphere at the origin seen by an orthographic camera on +z
// (x right, y up, view direction wo = +z for every pixel). The point light sits at
// distance light_distance (in sphere radii) from the centre, at the given azimuth (from
// the camera direction towards +x) and elevation (towards +y). Its intensity is chosen so
// that the irradiance at normal incidence at the distance of the sphere centre is 1, so a
// pixel's linear value is  f(wi, wo) * cos(theta_i) * (light_distance / r)^2  with r the
// distance from the surface point to the light (no shadowing other than cos <= 0).
// The environment map is equirectangular (latitude-longitude): column u in [0, 1) is the
// azimuth phi = 2 pi (u - 0.5) about +y, row v in [0, 1) the polar angle theta = pi v from
// +y (top row = up); direction (sin theta sin phi, cos theta, -sin theta cos phi), so the
// map's centre lies behind the sphere as the camera sees it. Its contribution
// integral f L_env cos dwi is estimated by Monte Carlo with multiple importance sampling
// (balance heuristic) of three strategies: environment texels by luminance, cosine-
// weighted hemisphere, and a cone around the mirror direction (for narrow lobes).
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "paintlab/brdf/brdf.h"
#include "paintlab/calibration/rig_calibration.h"
#include "paintlab/core/image.h"
#include "paintlab/core/image_io.h"
#include "paintlab/fitting/flakes.h"

namespace paintlab::fit {

// Linear -> 8-bit sRGB: v' = clamp(exposure * v, 0, 1), then the sRGB transfer curve
// (IEC 61966-2-1), rounded. With exposure <= 0, the exposure is chosen automatically so
// that the 99.5th percentile of the largest channel over the `mask` pixels maps to 1
// (a small specular highlight clips, the body of the paint is well exposed).
struct ToneMapping {
  double exposure = 0;  // <= 0: automatic
  double percentile = 99.5;
};
double auto_exposure(const ImageF& rgb, const std::vector<std::uint8_t>& mask, double percentile);
// Returns the 8-bit image and the exposure used.
ImageU8 tone_map(const ImageF& rgb, double exposure);
std::uint8_t srgb_encode(double linear01);

// An equirectangular environment map (linear RGB radiance) with its sampling tables.
class EnvironmentMap {
 public:
  // Reads an EXR with channels R, G, B (or Y). DataError when channels are missing,
  // values negative or not finite, or the map is not 2:1 (width = 2 height).
  static EnvironmentMap load(const std::filesystem::path& exr, double intensity = 1.0);
  EnvironmentMap(ImageF rgb, double intensity);

  int width() const { return rgb_.width(); }
  int height() const { return rgb_.height(); }
  const ImageF& rgb() const { return rgb_; }  // the radiance, intensity applied
  // Radiance arriving from direction d (unit, preview world frame): the texel d falls into.
  brdf::Rgb radiance(const brdf::Vec3& d) const;
  // Samples a direction with probability proportional to texel luminance (times the
  // texel's solid angle); returns the direction and its solid-angle pdf.
  brdf::Vec3 sample(double u1, double u2, double* pdf) const;
  double pdf(const brdf::Vec3& d) const;
  // Direction of texel (x, y)'s centre and back.
  brdf::Vec3 direction(double u, double v) const;
  void texel_of(const brdf::Vec3& d, int* x, int* y) const;

 private:
  ImageF rgb_;
  std::vector<double> row_cdf_;   // height + 1
  std::vector<double> col_cdf_;   // height * (width + 1)
  std::vector<double> texel_p_;   // probability of each texel
};

// An equirectangular map (height h, width 2h) of a clear day, for tests, benchmarks and the
// docs' pictures when no measured map is at hand: a sky brightening from zenith (0.2, 0.3, 0.6)
// to horizon (0.6, 0.7, 0.9), a grey-brown ground (0.12, 0.10, 0.08) and a sun of 2 deg
// radius (radiance 2000 x (1, 0.95, 0.85), up and to the right in front of the preview sphere,
// where the sphere mirrors it), linear radiance.
ImageF sun_and_sky_map(int height);

struct PreviewOptions {
  int size_px = 512;                // square image, >= 16
  double light_azimuth_deg = 40;    // from the camera direction towards +x, (-180, 180]
  double light_elevation_deg = 25;  // towards +y, [-89, 89]
  double light_distance = 10;       // in sphere radii, > 1.5
  bool point_light = true;          // false: environment only
  std::optional<std::filesystem::path> environment{};  // equirectangular EXR
  double environment_intensity = 1; // multiplies the map, > 0
  int environment_samples = 64;     // per strategy and pixel, >= 1
  std::uint64_t seed = 1;
  ToneMapping tone{};
  bool sparkle = true;              // draw the paint's measured flakes (point light) when it has them
  void check() const;               // DataError naming the first violated rule
};

// The PNG's background (8-bit sRGB grey): unlit parts of the sphere are black against it.
inline constexpr std::uint8_t kPreviewBackground = 64;

struct Preview {
  ImageF linear;                    // size x size x 3, linear radiance (background 0)
  std::vector<std::uint8_t> mask;   // 1 on the sphere
  ImageU8 png;                      // tone-mapped; background kPreviewBackground
  double exposure = 0;              // the exposure used
  // The brightest sphere pixel (largest channel) and its linear value.
  int peak_x = 0, peak_y = 0;
  brdf::Rgb peak = brdf::Rgb::Zero();
};

// Renders the preview scene. `env`, when given, overrides options.environment.
// With `sparkle`, the point light's part draws the measured flakes (flakes.h; each
// preview pixel a surface cell, so the pattern stays put when the light moves).
Preview render_preview(const brdf::Brdf& brdf, const PreviewOptions& options, const EnvironmentMap* env = nullptr,
                       const FlakeSparkle* sparkle = nullptr);

// The last step of a preview: the peak, the exposure, the tone-mapped PNG on its grey
// background (out.linear and out.mask filled).
void finish_preview(Preview& out, const PreviewOptions& options);

// The preview scene's geometry at pixel (x, y): the sphere point's normal (world frame)
// and the light direction; false off the sphere. For tests and for documentation.
bool preview_geometry(const PreviewOptions& options, int x, int y, brdf::Vec3* normal, brdf::Vec3* to_light,
                      double* light_distance);

// Evaluates the BRDF with world-frame directions at a surface of normal n.
brdf::Rgb eval_world(const brdf::Brdf& brdf, const brdf::Vec3& n, const brdf::Vec3& wi, const brdf::Vec3& wo);

// The measured HDR image of a session position beside the model rendered in the same rig
// geometry. For every camera pixel on the calibrated sphere: point, normal and wo from the
// calibration (RigCalibration::sphere_point_at), wi towards the calibrated LED at the
// table angle, and the model's pixel value  rate = f(wi, wo) * scale * E  (E the
// irradiance per unit LED intensity, scale the absolute calibration): the inverse of what
// extraction does, so model and measurement are in the same unit (linear DN/s).
// The image is  [measured | model | difference]  cropped around the sphere; measured and
// model share one exposure (auto from the measured image unless tone.exposure > 0). The
// difference panel shows d = log2(model / measured) of the mean of the channels, each
// summed over the usable pixels of a (2 window_px + 1)^2 window around the pixel (flake
// sparkle puts a lobe's light into a few bright pixels that the model averages; the
// window compares like with like): red = model brighter, blue = model darker, the
// brightness is |d| / diff_range_log2 (saturating), black = equal; pixels whose
// measurement is below the signal floor (or invalid, or at grazing angles) are dark grey.
struct CompareOptions {
  double margin_px = 8;           // crop margin around the sphere silhouette
  double min_cos = 0.05;          // n.wi and n.wo at least this for the statistics
  double signal_floor_rel = 0.01; // measured value (window mean) >= this x the exposure's white level
  double diff_range_log2 = 1.0;   // |d| that saturates the difference colour
  int window_px = 4;              // half size of the comparison window, 0..50 (0: pixel by pixel)
  bool sparkle = true;            // render_comparison_png: draw the paint's measured flakes
  ToneMapping tone;
  void check() const;
};

struct Comparison {
  ImageF measured;                // cropped linear RGB (mono images repeated in R, G, B)
  ImageF model;                   // same crop, same unit
  std::vector<std::uint8_t> used; // 1 where the pixel enters the statistics
  ImageU8 png;                    // 3 panels side by side
  int crop_x = 0, crop_y = 0;     // top-left of the crop in the camera image
  double exposure = 0;
  std::size_t pixels_used = 0;
  double log_rms = 0;             // RMS of ln(model / measured) over the pixels used (channel mean, windowed)
  double median_ratio = 0;        // median of model / measured (windowed)
};

// measured: an HDR image of the session (channels R, G, B or Y, optional "valid"); the
// calibration needs camera, sphere, light and scale (CalibrationError names what is
// missing). DataError when the image size differs from the camera's.
// With `sparkle`, the model panel draws the paint's measured flakes (flakes.h), each camera
// pixel a surface cell.
Comparison render_comparison(const brdf::Brdf& brdf, const calib::RigCalibration& calibration,
                             const ExrImage& measured, double table_angle_deg, const CompareOptions& options = {},
                             const FlakeSparkle* sparkle = nullptr);

// The paint rendered in the rig geometry over the whole camera image, in the unit of the
// session's HDR images (linear DN/s: f scale E, as render_comparison's model panel), RGB, 0
// off the sphere; with `sparkle` each camera pixel is a surface cell. For simulated
// comparisons (tests, bench) of the exported flake model with the measurement.
ImageF render_rig(const brdf::Brdf& brdf, const calib::RigCalibration& calibration, double table_angle_deg,
                  const FlakeSparkle* sparkle = nullptr);

// Writes a linear RGB image as EXR (channels R, G, B) atomically.
void write_exr_rgb(const std::filesystem::path& path, const ImageF& rgb, const std::string& description);

}  // namespace paintlab::fit
