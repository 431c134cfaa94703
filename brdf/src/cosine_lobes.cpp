#include "paintlab/brdf/cosine_lobes.h"

#include <cmath>
#include <fmt/format.h>
#include <numbers>

namespace paintlab::brdf {

bool CosineLobeParams::operator==(const CosineLobeParams& o) const {
  if (exponents != o.exponents || !(kd == o.kd).all() || kg.size() != o.kg.size() || kdd.size() != o.kdd.size())
    return false;
  for (std::size_t i = 0; i < kg.size(); ++i)
    if (!(kg[i] == o.kg[i]).all()) return false;
  for (std::size_t i = 0; i < kdd.size(); ++i)
    if (!(kdd[i] == o.kdd[i]).all()) return false;
  return true;
}

double cosine_lobe(double exponent, const Vec3& wi, const Vec3& wo) {
  // r = 2 (n.wi) n - wi with n = +z: (-x, -y, z).
  const double rv = -wi.x() * wo.x() - wi.y() * wo.y() + wi.z() * wo.z();
  if (rv <= 0) return 0.0;
  return std::pow(std::min(rv, 1.0), exponent);
}

CosineLobes::CosineLobes(CosineLobeParams p) : p_(std::move(p)) {}

Rgb CosineLobes::eval(const Vec3& wi, const Vec3& wo) const {
  if (wi.z() <= 0 || wo.z() <= 0) return Rgb::Zero();
  Rgb f = p_.kd * (1.0 / std::numbers::pi);
  const double inv_cos_i = 1.0 / wi.z();
  for (std::size_t i = 0; i < p_.exponents.size(); ++i) {
    const double c = cosine_lobe(p_.exponents[i], wi, wo);
    if (c == 0.0) continue;
    f += (p_.kg[i] * inv_cos_i + p_.kdd[i]) * c;
  }
  return f;
}

std::string cosine_lobes_problem(const CosineLobeParams& p) {
  const std::size_t n = p.exponents.size();
  if (n < 1 || n > static_cast<std::size_t>(kMaxCosineLobes))
    return fmt::format("exponents: {} entries, expected 1 to {}", n, kMaxCosineLobes);
  for (std::size_t i = 0; i < n; ++i) {
    const double e = p.exponents[i];
    if (!std::isfinite(e) || e < kMinLobeExponent || e > kMaxLobeExponent)
      return fmt::format("exponents[{}]: {} outside [{}, {:g}]", i, e, kMinLobeExponent, kMaxLobeExponent);
    if (i > 0 && !(e > p.exponents[i - 1]))
      return fmt::format("exponents[{}]: {} not above exponents[{}] = {} (exponents increase)", i, e, i - 1,
                         p.exponents[i - 1]);
  }
  auto rgb_problem = [](const Rgb& c) { return !(c.isFinite().all() && (c >= 0).all()); };
  if (rgb_problem(p.kd)) return fmt::format("kd: [{}, {}, {}] must be finite and >= 0", p.kd[0], p.kd[1], p.kd[2]);
  for (const auto* name : {"kg", "kdd"}) {
    const auto& v = std::string(name) == "kg" ? p.kg : p.kdd;
    if (v.size() != n) return fmt::format("{}: {} entries for {} exponents", name, v.size(), n);
    for (std::size_t i = 0; i < n; ++i)
      if (rgb_problem(v[i]))
        return fmt::format("{}[{}]: [{}, {}, {}] must be finite and >= 0", name, i, v[i][0], v[i][1], v[i][2]);
  }
  return {};
}

}  // namespace paintlab::brdf
