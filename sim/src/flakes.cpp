#include "paintlab/sim/flakes.h"

#include <tbb/parallel_for.h>

#include "paintlab/core/error.h"
#include "rng.h"

namespace paintlab::sim {

namespace {
constexpr std::uint64_t kStreamFlakes = 0x464c'414b;  // "FLAK"
constexpr std::uint64_t kStreamColour = 0x434f'4c52;  // "COLR"
constexpr int kQuadraturePoints = 2048;
}  // namespace

double FlakeCapTable::integrate(double m, double delta, double theta_h) {
  // P = integral over the flake polar angle theta of p(theta) * (fraction of the azimuth
  // circle within delta of h). With w = 1 - exp(-tan^2(theta) / m^2) the flake's theta is
  // uniform in w (that is how flakes are sampled), so P = integral_0^1 frac(theta(w)) dw.
  double t_lo = std::max(0.0, theta_h - delta);
  double t_hi = std::min(0.5 * kPi, theta_h + delta);
  if (t_lo >= t_hi) return 0.0;
  auto w_of = [m](double theta) {
    if (theta >= 0.5 * kPi) return 1.0;
    double t = std::tan(theta) / m;
    return -std::expm1(-t * t);
  };
  double w_lo = w_of(t_lo), w_hi = w_of(t_hi);
  if (!(w_hi > w_lo)) return 0.0;
  double cos_d = std::cos(delta), ch = std::cos(theta_h), sh = std::sin(theta_h);
  double sum = 0.0;
  for (int i = 0; i < kQuadraturePoints; ++i) {
    double w = w_lo + (w_hi - w_lo) * (i + 0.5) / kQuadraturePoints;
    double theta = std::atan(m * std::sqrt(-std::log1p(-w)));
    double ct = std::cos(theta), st = std::sin(theta);
    double denom = st * sh;
    double frac;
    if (denom < 1e-300) {
      frac = ct * ch >= cos_d ? 1.0 : 0.0;
    } else {
      double c = (cos_d - ct * ch) / denom;
      frac = c <= -1.0 ? 1.0 : (c >= 1.0 ? 0.0 : std::acos(c) / kPi);
    }
    sum += frac;
  }
  return sum * (w_hi - w_lo) / kQuadraturePoints;
}

FlakeCapTable::FlakeCapTable(double roughness, double lifetime_rad, int entries) {
  if (!(roughness > 0 && roughness < 1)) throw DataError("flakes: roughness must be in (0, 1)");
  if (!(lifetime_rad > 0 && lifetime_rad < 0.5 * kPi)) throw DataError("flakes: lifetime must be in (0, 90) deg");
  if (entries < 2) throw DataError("flakes: the cap table needs at least 2 entries");
  values_.resize(static_cast<std::size_t>(entries));
  step_ = std::sin(0.25 * kPi) / (entries - 1);
  tbb::parallel_for(0, entries, [&](int i) {
    double theta_h = 2.0 * std::asin(std::min(1.0, i * step_));
    values_[static_cast<std::size_t>(i)] = integrate(roughness, lifetime_rad, theta_h);
  });
}

double FlakeCapTable::operator()(double cos_theta_h) const {
  double s = std::sqrt(std::max(0.0, 0.5 * (1.0 - cos_theta_h)));
  double f = s / step_;
  auto last = static_cast<double>(values_.size() - 1);
  if (f >= last) return values_.back();
  auto i = static_cast<std::size_t>(f);
  double t = f - static_cast<double>(i);
  return values_[i] + t * (values_[i + 1] - values_[i]);
}

FlakeField::FlakeField(double radius_m, double flakes_per_m2, double roughness, std::uint64_t seed)
    : radius_(radius_m), density_(flakes_per_m2), roughness_(roughness), seed_(seed) {
  if (!(radius_m > 0)) throw DataError("flakes: sphere radius must be > 0");
  if (!(flakes_per_m2 >= 0) || !std::isfinite(flakes_per_m2)) throw DataError("flakes: density must be >= 0");
  if (!(roughness > 0 && roughness < 1)) throw DataError("flakes: roughness must be in (0, 1)");
  // About 4 flakes per cell, cells roughly square at the equator (n_phi = pi n_z).
  double nz = std::clamp(std::round(radius_m * std::sqrt(flakes_per_m2)), 1.0, 2048.0);
  nz_ = static_cast<int>(nz);
  nphi_ = std::max(1, static_cast<int>(std::round(kPi * nz)));
  mean_per_cell_ = flakes_per_m2 * 4.0 * kPi * radius_m * radius_m / (static_cast<double>(nz_) * nphi_);
}

std::vector<Flake> FlakeField::cell(int iz, int iphi) const {
  std::uint64_t key = detail::hash_key(seed_, kStreamFlakes, static_cast<std::uint64_t>(iz) * nphi_ + iphi);
  std::uint64_t bits = detail::mix64(key);
  int count;
  if (mean_per_cell_ < 30.0) {
    count = static_cast<int>(detail::poisson_small(mean_per_cell_, detail::uniform01(bits)));
  } else {
    float z = detail::NormalTable::get()(static_cast<std::uint32_t>(bits >> 32));
    count = std::max(0, static_cast<int>(std::lround(mean_per_cell_ + std::sqrt(mean_per_cell_) * z)));
  }
  std::vector<Flake> out;
  out.reserve(static_cast<std::size_t>(count));
  double z_lo = -1.0 + 2.0 * iz / nz_, dz = 2.0 / nz_;
  double phi_lo = 2.0 * kPi * iphi / nphi_, dphi = 2.0 * kPi / nphi_;
  for (int j = 0; j < count; ++j) {
    std::uint64_t a = detail::mix64(key + 1 + 2 * static_cast<std::uint64_t>(j));
    std::uint64_t b = detail::mix64(key + 2 + 2 * static_cast<std::uint64_t>(j));
    double z = z_lo + dz * (static_cast<double>(a >> 32) * 0x1.0p-32);
    double phi = phi_lo + dphi * (static_cast<double>(a & 0xFFFFFFFFull) * 0x1.0p-32);
    double r1 = static_cast<double>(b >> 32) * 0x1.0p-32;
    double r2 = static_cast<double>(b & 0xFFFFFFFFull) * 0x1.0p-32;
    double s = std::sqrt(std::max(0.0, 1.0 - z * z));
    Vec3 u(s * std::cos(phi), s * std::sin(phi), z);
    double theta_f = std::atan(roughness_ * std::sqrt(-std::log1p(-r1)));
    Vec3 n = frame_from_normal(u) * spherical_to_vec(theta_f, 2.0 * kPi * r2);
    out.push_back({u, n, detail::mix64(detail::hash_key(key, kStreamColour, static_cast<std::uint64_t>(j)))});
  }
  return out;
}

FlakeTint draw_flake_tint(std::uint64_t bits, const FlakeColour& colour) {
  FlakeTint t;
  const double u0 = static_cast<double>(bits >> 43) * 0x1.0p-21;             // kind
  const double u1 = (static_cast<double>((bits >> 22) & 0x1FFFFF) + 0.5) * 0x1.0p-21;  // radius, (0, 1)
  const double u2 = static_cast<double>(bits & 0x3FFFFF) * 0x1.0p-22;       // hue
  t.hue_rad = 2.0 * kPi * u2;
  if (u0 < colour.interference) {
    t.interference = true;
    t.chroma = colour.interference_chroma;
  } else if (colour.tint_sd > 0) {
    // Box-Muller radius of a 2D normal; psi uniform.
    t.chroma = std::min(1.0, colour.tint_sd * std::sqrt(-2.0 * std::log(u1)));
  }
  return t;
}

Vec3 flake_tint_rgb(double chroma, double hue_rad) {
  static const Vec3 u = Vec3(2.0, -1.0, -1.0) / std::sqrt(6.0);
  static const Vec3 v = Vec3(0.0, 1.0, -1.0) / std::sqrt(2.0);
  return Vec3::Ones() + chroma * (std::cos(hue_rad) * u + std::sin(hue_rad) * v);
}

}  // namespace paintlab::sim
