#pragma once
// The sensor pass: scene radiance per pixel -> raw camera values for one exposure.
// Per pixel and channel:
//   mean electrons  mu = L * g(x, y) * t + d(x, y) * t
//     g = QE * pixel area * pi / (4 N^2) * vignetting(x, y) * (1 + PRNU(x, y)) / photon energy
//     d = dark current (hot pixels: their own, higher dark current)
//   electrons       e  = Poisson(mu) + Normal(0, read noise)   (mu >= 20: Normal(mu, mu + read^2))
//                   e <= full well
//   normalised      x  = e * G / (ADC max - black),  G = conversion gain * 10^(gain_db / 20)
//   raw (ADC DN)    v  = round(black + R(min(x, 1)) * (ADC max - black)) clipped to [0, ADC max]
//   output          v * 2^(output_bits - adc_bits)   (MSB aligned, as Mono16 from a 12-bit ADC)
// Noise is a pure function of (seed, frame index, pixel): deterministic with a seed. One
// radiance image serves a whole exposure bracket.
#include <array>
#include <atomic>
#include <cstdint>
#include <optional>
#include <vector>

#include "paintlab/core/image.h"
#include "paintlab/sim/camera_model.h"
#include "paintlab/sim/config.h"

namespace paintlab::sim {

// The camera's response R on normalised linear signal x: polynomial sum_k c_k x^(k+1),
// R(0) = 0, R(1) = 1, increasing. Below 0 (read noise under the black level) it continues
// with its slope at 0.
class ResponseCurve {
 public:
  explicit ResponseCurve(std::vector<double> coefficients);
  double operator()(double x) const;
  double slope(double x) const;
  // The x in [0, 1] with R(x) = y (y clamped to [0, 1]).
  double inverse(double y) const;
  bool linear() const { return linear_; }
  const std::vector<double>& coefficients() const { return c_; }

 private:
  std::vector<double> c_;
  bool linear_;
};

struct ExposureSettings {
  double exposure_s = 0.01;
  double gain_db = 0.0;
  // Output bit depth 8..16 (0 = the ADC's): ADC values are shifted to it, MSB aligned.
  int output_bits = 0;
  // Which noise realisation; unset = the sensor's own frame counter (then incremented).
  std::optional<std::uint64_t> frame_index;
  // A colour-filter array: the camera channel (0 R, 1 G, 2 B) each pixel of the top-left 2x2
  // block records, row by row (GenICam's BayerRG is {0, 1, 1, 2}). Needs a 3-channel scene;
  // gives one channel, each pixel its own camera channel. Unset: as many channels out as in.
  std::optional<std::array<int, 4>> cfa{};
  // A monochrome sensor behind a colour filter: every pixel records w . scene RGB (w: the
  // sensor's spectral mix times the filter's transmission per channel). Needs a 3-channel
  // scene; gives one channel. Exclusive with cfa.
  std::optional<std::array<double, 3>> mono_mix{};
};

class Sensor {
 public:
  Sensor(const CameraModel& camera, const SensorParams& params, std::uint64_t seed);

  const SensorParams& params() const { return p_; }
  const ResponseCurve& response() const { return response_; }
  int width() const { return width_; }
  int height() const { return height_; }

  // Mean signal electrons per second per unit scene radiance (W sr^-1 m^-2) at a pixel.
  double electrons_per_s_per_radiance(int x, int y) const;
  // Mean dark electrons per second at a pixel (hot pixels included).
  double dark_e_per_s(int x, int y) const;
  // Hot pixels as indices y * width + x, ascending.
  const std::vector<std::uint32_t>& hot_pixels() const { return hot_; }
  // ADC counts per electron at a gain.
  double gain_dn_per_e(double gain_db) const;
  // The mean electrons of a pixel for radiance L (before noise and the full-well clip).
  double mean_electrons(double radiance, int x, int y, double exposure_s) const;
  // The noise-free raw value (ADC DN, unquantised) the chain maps mean electrons to.
  double raw_from_electrons(double electrons, double gain_db) const;
  // The noise-free raw value (ADC DN) for radiance L: raw_from_electrons(mean_electrons()).
  double expected_raw(double radiance, int x, int y, double exposure_s, double gain_db) const;

  // Exposes a radiance image (1 or 3 channels, the sensor's size). A 3-channel image is scene
  // linear sRGB: the camera's channel mix (CameraTruth::rgb_matrix, rgb_gain) turns it into
  // camera RGB first, then settings.cfa or mono_mix may sample it to one channel. Channels get
  // independent noise. threads: 0 = all cores. Thread-safe.
  Image<std::uint16_t> expose(const ImageF& radiance, const ExposureSettings& settings, int threads = 0);
  // Frames exposed so far (the next default frame index).
  std::uint64_t frames() const { return frames_.load(); }

 private:
  SensorParams p_;
  ResponseCurve response_;
  std::uint64_t seed_;
  int width_, height_;
  std::vector<float> gain_map_;     // electrons per second per radiance, per pixel
  std::array<double, 9> mix_{};     // scene sRGB -> camera RGB (diag(gain) * matrix), row-major
  bool mix_identity_ = true;
  std::vector<std::uint32_t> hot_;  // hot pixel indices
  std::atomic<std::uint64_t> frames_{0};
};

}  // namespace paintlab::sim
