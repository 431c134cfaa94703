#pragma once
// Monte Carlo directional albedo rho(wi) = integral of f(wi, wo) cos(theta_o) dwo with a
// fixed seed: one-sample multiple importance sampling over a mixture of cosine sampling
// and Beckmann half-vector sampling for each given roughness (so narrow lobes converge).
#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include "paintlab/brdf/brdf.h"

namespace paintlab::brdf::test_support {

struct AlbedoEstimate {
  Rgb mean = Rgb::Zero();
  Rgb std_error = Rgb::Zero();  // standard error of the mean
};

inline AlbedoEstimate directional_albedo(const Brdf& brdf, const Vec3& wi, const std::vector<double>& roughness,
                                         int samples, std::uint64_t seed) {
  constexpr double kPi = std::numbers::pi;
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const std::size_t n_comp = roughness.size() + 1;
  const double w_comp = 1.0 / static_cast<double>(n_comp);
  auto beckmann_pdf_h = [&](double m, double cos_h) {
    if (cos_h <= 0) return 0.0;
    const double c2 = cos_h * cos_h, tan2 = (1 - c2) / c2;
    return std::exp(-tan2 / (m * m)) / (kPi * m * m * c2 * cos_h);
  };
  Rgb sum = Rgb::Zero(), sum2 = Rgb::Zero();
  for (int s = 0; s < samples; ++s) {
    const std::size_t comp = std::min(n_comp - 1, static_cast<std::size_t>(u(rng) * static_cast<double>(n_comp)));
    const double u1 = u(rng), u2 = u(rng);
    Vec3 wo;
    if (comp == 0) {
      const double r = std::sqrt(u1), phi = 2 * kPi * u2;
      wo = Vec3(r * std::cos(phi), r * std::sin(phi), std::sqrt(std::max(0.0, 1 - u1)));
    } else {
      const double m = roughness[comp - 1];
      const double tan2 = -m * m * std::log(1 - u1), phi = 2 * kPi * u2;
      const double ch = 1 / std::sqrt(1 + tan2), sh = std::sqrt(1 - ch * ch);
      const Vec3 h(sh * std::cos(phi), sh * std::sin(phi), ch);
      wo = 2 * wi.dot(h) * h - wi;
    }
    Rgb contrib = Rgb::Zero();
    if (wo.z() > 0) {
      double pdf = w_comp * wo.z() / kPi;
      const Vec3 h = (wi + wo).normalized();
      for (double m : roughness) pdf += w_comp * beckmann_pdf_h(m, h.z()) / (4 * std::abs(wo.dot(h)));
      contrib = brdf.eval(wi, wo) * wo.z() / pdf;
    }
    sum += contrib;
    sum2 += contrib * contrib;
  }
  AlbedoEstimate e;
  e.mean = sum / samples;
  e.std_error = ((sum2 / samples - e.mean * e.mean).max(0.0) / samples).sqrt();
  return e;
}

}  // namespace paintlab::brdf::test_support
