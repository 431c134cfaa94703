#pragma once
// Synthetic BRDF samples as the rig would deliver them, without images: the upper half of
// a 40 mm sphere seen from 1 m, the LED 0.5 m from the sphere in the horizontal plane at
// table angle a (deg), one sample per pixel of a camera whose focal length is chosen so
// the sphere is `sphere_px` pixels across. Each sample is the paint's value times
// (1 + noise_rel * N(0, 1)), with that noise variance attached.
#include <cmath>
#include <random>

#include "paintlab/brdf/brdf.h"
#include "paintlab/brdf/cook_torrance.h"
#include "paintlab/brdf/merl.h"
#include "paintlab/brdf/pearlescent.h"
#include "paintlab/brdf/rusinkiewicz.h"
#include "paintlab/core/geometry.h"
#include "paintlab/fitting/binning.h"

namespace paintlab::fit::test_support {

inline void sphere_samples(const brdf::Brdf& paint, double angle_deg, int sphere_px, double noise_rel,
                           std::mt19937_64& rng, SampleBatch& out) {
  std::normal_distribution<double> gauss(0.0, 1.0);
  const double radius = 0.04, distance = 1.0;
  const double f = sphere_px / (2.0 * radius / distance);
  const Vec3 cam(distance, 0, 0);
  const double ang = deg_to_rad(angle_deg);
  const Vec3 led(0.5 * std::cos(ang), 0.5 * std::sin(ang), 0);
  const int half = sphere_px / 2 + 2;
  for (int y = -half; y < half; ++y)
    for (int x = -half; x < half; ++x) {
      const Vec3 d = Vec3(-1, (x + 0.5) / f, -(y + 0.5) / f).normalized();
      const double b = cam.dot(d), c = cam.squaredNorm() - radius * radius, disc = b * b - c;
      if (disc < 0) continue;
      const Vec3 p = cam + (-b - std::sqrt(disc)) * d, n = p / radius;
      if (n.z() <= 0.0) continue;  // the upper half, down to the equator (where the highlight is)
      const Mat3 frame = frame_from_normal(n);
      const Vec3 wi = frame.transpose() * (led - p).normalized(), wo = frame.transpose() * (cam - p).normalized();
      if (wi.z() <= 0.01 || wo.z() <= 0.01) continue;
      const brdf::HalfDiff hd = brdf::half_diff_from_directions(wi, wo);
      const brdf::Rgb v = paint.eval(wi, wo);
      float rgb[3], var[3];
      for (int ch = 0; ch < 3; ++ch) {
        rgb[ch] = static_cast<float>(v[ch] * (1.0 + noise_rel * gauss(rng)));
        var[ch] = static_cast<float>(v[ch] * v[ch] * noise_rel * noise_rel);
      }
      out.push_back(hd.theta_h, hd.theta_d, hd.phi_d, rgb, var);
    }
}

// brdf::tabulate() on one bin in `stride`: bin k * stride + (k * 7919) % stride for
// k = 0, 1, ..., so every theta_h row keeps about 1 / stride of its bins, scattered over
// theta_d and phi_d. The other bins stay Empty (written as -1 in a .binary file). Keeps
// fits of "every bin" tables fast in unit tests without losing the narrow peaks.
inline brdf::MerlTable tabulate_sparse(const brdf::Brdf& paint, std::size_t stride) {
  brdf::MerlTable table;
  for (std::size_t k = 0; k * stride < brdf::kMerlBins; ++k) {
    const std::size_t b = k * stride + (k * 7919) % stride;
    if (b >= brdf::kMerlBins) break;
    const Eigen::Vector3d c = brdf::merl_bin_centre(b);
    const brdf::DirectionPair d = brdf::directions_from_half_diff({c[0], 0.0, c[1], c[2]});
    if (d.wi.z() <= 0.0 || d.wo.z() <= 0.0) continue;
    table.set_value(b, paint.eval(d.wi, d.wo), brdf::BinState::Measured);
  }
  return table;
}

// Gives every measured bin of `table` the statistics of `count` samples whose relative spread
// var / v^2 is `spread` (a scatter, like the flakes' glints, that the pixel noise does not hold)
// and returns the per-sample pixel-noise variances, `noise` v^2 (fit_data.h: the delta
// correction then takes spread / count outside the peak).
inline std::vector<float> with_sample_spread(brdf::MerlTable& table, std::uint32_t count, double spread, double noise) {
  std::vector<float> noise_variance(3 * brdf::kMerlBins, 0.0f);
  for (std::size_t b = 0; b < brdf::kMerlBins; ++b) {
    if (table.state(b) != brdf::BinState::Measured) continue;
    const brdf::Rgb v = table.value(b);
    table.set_statistics(b, count, spread * v * v, brdf::merl_bin_centre(b));
    for (int c = 0; c < 3; ++c) noise_variance[3 * b + c] = static_cast<float>(noise * v[c] * v[c]);
  }
  return noise_variance;
}

// A white pearlescent paint: a layered paint that is no sum of Cook-Torrance lobes, so one
// iteration of a Cook-Torrance fit cannot converge on it (and a full fit needs many).
// Small multi-start fits for unit tests: two grid starts, one random, a 6000-bin subsample.
template <class Options>
Options quick_fit(int lobes) {
  Options opt;
  opt.lobes = lobes;
  opt.grid_starts = 2;
  opt.random_starts = 1;
  opt.start_bins = 6000;
  return opt;
}

// Two Cook-Torrance paints of the fit tests: a silver metallic with three lobes (broad,
// medium, a narrow clear-coat peak) and a deep-blue solid with two.
inline brdf::CookTorranceParams silver_params() {
  return {brdf::Rgb(0.030, 0.032, 0.035),
          {{brdf::Rgb(0.060, 0.062, 0.066), 0.38, 0.85},
           {brdf::Rgb(0.045, 0.046, 0.048), 0.16, 0.55},
           {brdf::Rgb(0.15, 0.15, 0.15), 0.015, 0.04}}};
}
inline brdf::CookTorranceParams blue_params() {
  return {brdf::Rgb(0.030, 0.060, 0.300),
          {{brdf::Rgb(0.010, 0.010, 0.010), 0.30, 0.04}, {brdf::Rgb(0.15, 0.15, 0.15), 0.02, 0.04}}};
}

inline brdf::PearlescentParams white_pearl() {
  brdf::PearlescentParams p;
  p.substrate = brdf::Rgb(0.85, 0.85, 0.87);
  p.gloss_roughness = 0.03;
  p.coverage = 0.9;
  p.opacity = 0.15;
  p.flake_roughness = 0.18;
  p.film_ior = 2.5;
  p.film_thickness_nm = 160;
  return p;
}

// A whole sweep (angles start..stop in step) binned.
inline BinnedTable binned_sweep(const brdf::Brdf& paint, int sphere_px, double noise_rel, std::uint64_t seed,
                                double step_deg = 1.0, double start_deg = 0.0, double stop_deg = 180.0) {
  std::mt19937_64 rng(seed);
  BinAccumulator acc;
  SampleBatch batch;
  for (double a = start_deg; a <= stop_deg + 1e-9; a += step_deg) {
    batch.clear();
    sphere_samples(paint, a, sphere_px, noise_rel, rng, batch);
    acc.add(batch);
  }
  return acc.finish();
}

}  // namespace paintlab::fit::test_support
