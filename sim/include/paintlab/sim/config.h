#pragma once
// The simulated world's truth (docs/simulator.md). A rig.toml's [geometry] holds the
// technician's nominal guesses; its [sim] table holds what the simulated world really is,
// which differs slightly so that calibration has something to find. Every [sim] key has a
// default (the nominal geometry, an ideal lens, a typical scientific CMOS sensor).
//
// Frames: the rig frame has its origin on the turntable axis at the height of the nominal
// sphere centre, z up, the camera at azimuth 0 (+x). The true sphere centre is
// SphereTruth::centre_rig_m. The LED at table angle a (deg) sits at
// (R cos(a + a0), R sin(a + a0), h) with R, h, a0 of LedTruth.
#include <array>
#include <cstdint>
#include <optional>
#include <vector>

#include "paintlab/core/config.h"
#include "paintlab/core/geometry.h"
#include "paintlab/core/json.h"
#include "paintlab/core/rig.h"

namespace paintlab::sim {

// The camera: pinhole with OpenCV's Brown-Conrady distortion, pose and lens.
struct CameraTruth {
  int width_px = 1360;
  int height_px = 1024;
  double fx_px = 0.0, fy_px = 0.0;  // focal lengths in pixels
  double cx_px = 0.0, cy_px = 0.0;  // principal point, OpenCV convention (pixel centres at integers)
  std::array<double, 5> dist{};     // k1, k2, p1, p2, k3 (OpenCV order)
  double pixel_size_m = 6.45e-6;
  Vec3 position_rig_m = Vec3::Zero();  // camera centre in the rig frame
  Vec3 look_at_rig_m = Vec3::Zero();   // the optical axis passes through this point
  double roll_deg = 0.0;               // rotation about the optical axis (right-handed, +z forward)
  double f_number = 8.0;               // lens aperture: image irradiance = pi L / (4 N^2)
  // Optical blur (lens PSF, focus): a Gaussian of this standard deviation in pixels,
  // applied to the pixel-integrated radiance as a separable filter. 0 = ideal lens.
  double psf_sigma_px = 0.0;
  // Extra (mechanical) vignetting on top of the natural cos^4 falloff:
  // factor 1 + v[0] rho^2 + v[1] rho^4, rho = distance from the principal point / half diagonal.
  std::array<double, 2> vignetting{};
  // Monochrome camera: mono = w . RGB (a camera spectral mix; sums to 1 so grey stays grey).
  std::array<double, 3> mono_weights{0.2126, 0.7152, 0.0722};
  // A colour camera's channels (CFA or three-channel frames): camera RGB = diag(rgb_gain) *
  // rgb_matrix * scene linear sRGB, rgb_matrix row-major (row j: what camera channel j sees of
  // the scene's R, G, B). A real sensor's dyes are not the sRGB primaries: the colour
  // calibration has to find the inverse. Identity and unit gains: camera RGB = scene sRGB.
  std::array<double, 9> rgb_matrix{1, 0, 0, 0, 1, 0, 0, 0, 1};
  std::array<double, 3> rgb_gain{1.0, 1.0, 1.0};

  // cam_from_rig built from position, look-at point and roll (the rig's z is "up").
  Rigid3 cam_from_rig() const;
  Mat3 K() const;
};

// The sensor and its read-out chain (image irradiance -> electrons -> DN).
struct SensorParams {
  double qe = 0.6;                       // electrons per photon
  double wavelength_nm = 550.0;          // photon energy used to turn watts into photons
  double full_well_e = 18000.0;          // electrons; more are clipped
  int adc_bits = 12;                     // 8..16
  double black_level_dn = 64.0;          // ADC counts added to every pixel
  double conversion_gain_dn_per_e = 0.0; // ADC counts per electron at 0 dB; 0 = full well fills the ADC
  double read_noise_e = 6.0;             // Gaussian, electrons RMS
  double dark_current_e_per_s = 5.0;     // mean dark electrons per second
  double hot_pixel_frac = 1e-4;          // fraction of pixels with a high dark current
  double hot_pixel_dark_e_per_s = 2000.0;
  double prnu_rel = 0.005;               // pixel-to-pixel sensitivity spread (relative RMS)
  // Response curve R on normalised signal x in [0, 1]: R(x) = sum_k c_k x^(k+1) with
  // sum c_k = 1 and R increasing on [0, 1]. {1} is linear.
  std::vector<double> response_poly{1.0};
  double readout_s = 0.025;              // sensor read-out time of one frame

  double adc_max_dn() const { return static_cast<double>((1u << adc_bits) - 1u); }
  // Conversion gain at 0 dB (the configured one, or full well -> ADC range).
  double gain0_dn_per_e() const;
};

struct LedTruth {
  double arm_radius_m = 0.5;
  double arm_height_m = 0.0;
  double zero_deg = 0.0;              // LED azimuth at table angle 0
  double intensity_w_sr = 0.1;        // radiant intensity on the LED axis (W/sr, camera RGB units)
  std::array<double, 3> color{1.0, 1.0, 1.0};  // the LED's white in scene linear sRGB ((1,1,1) = D65)
  double profile_exponent = 1.0;      // I(theta) = I0 cos^n(theta) off the LED axis (1: Lambertian)
  Vec3 aim_rig_m = Vec3::Zero();      // the LED axis points at this rig point
};

struct SphereTruth {
  double radius_m = 0.04;
  Vec3 centre_rig_m = Vec3::Zero();
};

// The surroundings: black felt everywhere, turntable and arm below the equator.
struct SceneParams {
  double felt_albedo = 0.02;           // Lambertian albedo of the felt
  double table_depth_m = 0.10;         // table top below the rig origin
  double table_radius_m = 0.15;
  double pedestal_radius_m = 0.012;    // post from the table top to the sphere's bottom
  double arm_post_radius_m = 0.006;    // vertical post carrying the LED, table top to LED height
  double backdrop_distance_m = 1.0;    // felt backdrop: the plane x = -backdrop_distance_m
};

// Rendering quality knobs.
struct RenderParams {
  int edge_samples = 16;               // coverage samples per edge pixel: edge_samples^2
  int edge_shading_samples = 4;        // shaded samples per edge pixel: n^2
  // Interior sphere pixels are shaded at their centre, and integrated over the pixel on an
  // n x n grid where the centre differs from the pixel's mean by more than the tolerance
  // (relative, from the image's curvature). 1 (the default for now): centres only; 4 is what
  // a camera does (docs/simulator.md: the pipeline does not yet undo the pixel's box).
  int interior_samples = 1;
  double interior_tolerance = 1e-3;
  double sparkle_floor = 0.1;          // epsilon of the sparkle factor (K + eps) / (lambda + eps)
};

// The colour filters of a simulated filter wheel ([sim.filters]): what share of the scene's
// linear sRGB R, G, B each passes. [devices.filter_wheel]'s slot_r, slot_g, slot_b hold them;
// the wheel's other slots are empty (everything passes). Defaults: dichroic-like filters that
// leak a little of the neighbouring band.
struct FilterTruth {
  std::array<double, 3> red{0.92, 0.05, 0.01};
  std::array<double, 3> green{0.04, 0.90, 0.06};
  std::array<double, 3> blue{0.01, 0.06, 0.88};
};

struct SimConfig {
  RigGeometry nominal;                 // the rig's [geometry] (the guess)
  CameraTruth camera;
  SensorParams sensor;
  LedTruth led;
  SphereTruth sphere;
  SceneParams scene;
  RenderParams render;
  FilterTruth filters;
  std::uint64_t seed = 1;
  // The sphere's flake field (another panel of the same paint on the same rig: the sensor's
  // fixed pattern, which the calibration measured, stays). Unset: `seed`.
  std::optional<std::uint64_t> flake_seed;
  std::uint64_t flake_field_seed() const { return flake_seed.value_or(seed); }
  // Virtual clock: virtual seconds per real second (0 = never sleep for real).
  double clock_speed = 0.0;

  // Defaults derived from the nominal geometry (no [sim] table).
  static SimConfig defaults(const RigGeometry& nominal);
  // From a rig: its [geometry] and, when present, its [sim] table.
  static SimConfig from_rig(const RigConfig& rig);
  // Reads a [sim] table (validated: ranges, types, unknown keys; errors name file:line:key).
  static SimConfig parse(const ConfigTable& sim, const RigGeometry& nominal);

  // Throws DataError naming the first violated rule (for configs built in code).
  void check() const;
  Json to_json() const;
};

}  // namespace paintlab::sim
