#pragma once
// Exposure stacks for the radiometric calibration tests: the simulator's sensor (sim/:
// shot, read and dark noise, PRNU, hot pixels, a polynomial response, quantisation and
// clipping) exposing a scene whose radiance spans a wide range, and a simple 8-bit camera
// with a gamma curve written here.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <random>
#include <vector>

#include "paintlab/calibration/exposure_stack.h"
#include "paintlab/core/image.h"
#include "paintlab/core/rig.h"
#include "paintlab/sim/camera_model.h"
#include "paintlab/sim/config.h"
#include "paintlab/sim/sensor.h"

namespace paintlab::calib::radiometry_test {

// A small camera; `vignetting` adds mechanical falloff 1 + v rho^2 (rho: distance from the
// principal point / half diagonal) to the natural cos^4.
inline sim::CameraModel small_camera(int width, int height, double vignetting = 0.0) {
  RigGeometry g;
  g.image_width_px = width;
  g.image_height_px = height;
  g.focal_length_mm = 12.0;
  sim::CameraTruth truth = sim::SimConfig::defaults(g).camera;
  truth.vignetting = {vignetting, 0.0};
  return sim::CameraModel(truth);
}

// `count` exposures from t0 up by `ratio`.
inline std::vector<double> geometric_exposures(double t0, double ratio, int count) {
  std::vector<double> t;
  for (int i = 0; i < count; ++i) t.push_back(t0 * std::pow(ratio, i));
  return t;
}

// Radiance log-uniform over [lo, hi], independent per pixel (and channel).
inline ImageF log_uniform_radiance(int width, int height, int channels, double lo, double hi, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(std::log(lo), std::log(hi));
  ImageF img(width, height, channels);
  for (auto& v : img.values()) v = static_cast<float>(std::exp(u(rng)));
  return img;
}

// The raw frames (ExposureStack) with the sensor that took them and the scene they show.
struct SimStack : ExposureStack {
  std::unique_ptr<sim::Sensor> sensor;
  ImageF radiance;
};

// The sim sensor exposing `radiance` at every exposure (noise realisation = frame index).
inline SimStack sim_stack(const sim::CameraModel& camera, const sim::SensorParams& params, const ImageF& radiance,
                          const std::vector<double>& exposures_s, std::uint64_t seed, std::uint64_t first_frame = 0) {
  SimStack s;
  s.sensor = std::make_unique<sim::Sensor>(camera, params, seed);
  s.radiance = radiance;
  s.exposures_s = exposures_s;
  for (std::size_t j = 0; j < exposures_s.size(); ++j) {
    sim::ExposureSettings e;
    e.exposure_s = exposures_s[j];
    e.frame_index = first_frame + j;
    s.images.push_back(s.sensor->expose(radiance, e, 2));
  }
  return s;
}

// An 8-bit camera: z = round(255 (X t)^(1/gamma) + noise), clipped; X per value.
struct GammaCamera {
  double gamma = 2.2;
  double noise_dn = 0.6;
  double truth(double u) const { return std::pow(std::clamp(u, 0.0, 255.0) / 255.0, gamma); }  // g = f^-1
  Image<std::uint16_t> expose(const ImageF& exposure_per_s, double t, std::mt19937_64& rng) const {
    std::normal_distribution<double> n(0.0, noise_dn);
    Image<std::uint16_t> img(exposure_per_s.width(), exposure_per_s.height(), exposure_per_s.channels());
    for (std::size_t i = 0; i < img.size(); ++i) {
      const double x = std::min(1.0, exposure_per_s.data()[i] * t);
      const double z = std::round(255.0 * std::pow(x, 1.0 / gamma) + n(rng));
      img.data()[i] = static_cast<std::uint16_t>(std::clamp(z, 0.0, 255.0));
    }
    return img;
  }
};

// Largest |s g(u) / truth(u) - 1| over u in [u_lo, u_hi] (knots), s the least-squares scale.
template <class Curve, class Truth>
double max_relative_error(const Curve& curve, int channel, const Truth& truth, double u_lo, double u_hi,
                          double step = 1.0) {
  double sgt = 0.0, sgg = 0.0;
  for (double u = u_lo; u <= u_hi; u += step) {
    const double g = curve.to_linear(channel, u);
    const double t = truth(u);
    // Relative least squares: weight 1/t^2.
    sgt += g / t;
    sgg += g * g / (t * t);
  }
  const double s = sgt / sgg;
  double worst = 0.0;
  for (double u = u_lo; u <= u_hi; u += step)
    worst = std::max(worst, std::abs(s * curve.to_linear(channel, u) / truth(u) - 1.0));
  return worst;
}

}  // namespace paintlab::calib::radiometry_test
