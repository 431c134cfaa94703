#include "paintlab/brdf/pearlescent.h"

#include <algorithm>
#include <cmath>
#include <complex>
#include <numbers>

#include "paintlab/brdf/cook_torrance.h"
#include "paintlab/brdf/fresnel.h"

namespace paintlab::brdf {

namespace {
using Cx = std::complex<double>;

// Airy reflectance of medium n0 | film n1 (thickness d_nm) | n2 at incidence cosine c0
// in n0 for wavelength lambda_nm; s and p averaged.
double thin_film_reflectance(double n0, double n1, double n2, double d_nm, double c0, double lambda_nm) {
  const double s0_2 = 1.0 - c0 * c0;
  const Cx c1 = std::sqrt(Cx(1.0 - (n0 / n1) * (n0 / n1) * s0_2, 0.0));
  const Cx c2 = std::sqrt(Cx(1.0 - (n0 / n2) * (n0 / n2) * s0_2, 0.0));
  const Cx rs01 = (n0 * c0 - n1 * c1) / (n0 * c0 + n1 * c1);
  const Cx rp01 = (n1 * c0 - n0 * c1) / (n1 * c0 + n0 * c1);
  const Cx rs12 = (n1 * c1 - n2 * c2) / (n1 * c1 + n2 * c2);
  const Cx rp12 = (n2 * c1 - n1 * c2) / (n2 * c1 + n1 * c2);
  const Cx phase = std::exp(Cx(0.0, 2.0) * (2.0 * std::numbers::pi * n1 * d_nm / lambda_nm) * c1);
  const Cx rs = (rs01 + rs12 * phase) / (1.0 + rs01 * rs12 * phase);
  const Cx rp = (rp01 + rp12 * phase) / (1.0 + rp01 * rp12 * phase);
  return 0.5 * (std::norm(rs) + std::norm(rp));
}

// Beckmann distribution of normals normalised with 1/pi: integral of D cos(theta) = 1.
double beckmann_normalised(double m, double cos_theta) {
  if (cos_theta <= 0.0) return 0.0;
  return beckmann_d(m, cos_theta) / std::numbers::pi;
}
}  // namespace

bool PearlescentParams::operator==(const PearlescentParams& o) const {
  return (substrate == o.substrate).all() && ior == o.ior && gloss_roughness == o.gloss_roughness &&
         (absorption == o.absorption).all() && coverage == o.coverage && opacity == o.opacity &&
         flake_roughness == o.flake_roughness && film_ior == o.film_ior && film_thickness_nm == o.film_thickness_nm &&
         core_ior == o.core_ior;
}

Rgb LayeredPearlescent::flake_reflectance(double alpha) const {
  constexpr int kSteps = 8;
  constexpr double kBands[3][2] = {{590.0, 680.0}, {500.0, 590.0}, {410.0, 500.0}};
  const double c0 = std::clamp(std::cos(alpha), 0.0, 1.0);
  Rgb out;
  for (int ch = 0; ch < 3; ++ch) {
    double sum = 0;
    for (int s = 0; s < kSteps; ++s) {
      const double lambda = kBands[ch][0] + (s + 0.5) / kSteps * (kBands[ch][1] - kBands[ch][0]);
      sum += thin_film_reflectance(p_.ior, p_.film_ior, p_.core_ior, p_.film_thickness_nm, c0, lambda);
    }
    out[ch] = sum / kSteps;
  }
  return out;
}

namespace {
constexpr int kRpTableSize = 1025;
}  // namespace

LayeredPearlescent::LayeredPearlescent(PearlescentParams p) : p_(std::move(p)) {
  // Diffuse (cosine-weighted) Fresnel reflectance of the boundary from outside, by the
  // midpoint rule; from inside it is 1 - (1 - F_ext) / eta^2 (light outside the critical
  // cone is reflected totally).
  constexpr int kSteps = 2000;
  double f_ext = 0;
  for (int i = 0; i < kSteps; ++i) {
    const double c = (i + 0.5) / kSteps;
    f_ext += 2.0 * c * fresnel_dielectric(c, p_.ior) / kSteps;
  }
  internal_reflectance_ = 1.0 - (1.0 - f_ext) / (p_.ior * p_.ior);
  rp_table_.resize(kRpTableSize);
  for (int i = 0; i < kRpTableSize; ++i)
    rp_table_[static_cast<std::size_t>(i)] =
        flake_reflectance(std::acos(static_cast<double>(i) / (kRpTableSize - 1)));
}

Rgb LayeredPearlescent::flake_reflectance_fast(double cos_alpha) const {
  const double x = std::clamp(cos_alpha, 0.0, 1.0) * (kRpTableSize - 1);
  const int i0 = std::min(static_cast<int>(x), kRpTableSize - 2);
  const double f = x - i0;
  return (1.0 - f) * rp_table_[static_cast<std::size_t>(i0)] + f * rp_table_[static_cast<std::size_t>(i0) + 1];
}

LayeredPearlescent::Terms LayeredPearlescent::terms(const Vec3& wi, const Vec3& wo) const {
  Terms t{Rgb::Zero(), Rgb::Zero(), Rgb::Zero()};
  if (wi.z() <= 0.0 || wo.z() <= 0.0) return t;
  const double eta = p_.ior;

  // Gloss: the slightly rough air-binder boundary.
  const Vec3 h = (wi + wo).normalized();
  const double g = ct_geometry(h.z(), h.dot(wo), wi.z(), wo.z());
  t.gloss = Rgb::Constant(fresnel_dielectric(h.dot(wi), eta) * beckmann_normalised(p_.gloss_roughness, h.z()) * g /
                          (4.0 * wi.z() * wo.z()));

  // Below the boundary: refracted directions, transmittances and the 1/eta^2 of radiance.
  const Vec3 ibar = refract_into_coat(wi, eta), obar = refract_into_coat(wo, eta);
  const double transmit =
      (1.0 - fresnel_dielectric(wi.z(), eta)) * (1.0 - fresnel_dielectric(wo.z(), eta)) / (eta * eta);
  const double ci = ibar.z(), co = obar.z();
  // (tau(tbar_i) + tau(tbar_o)) h per channel.
  const Rgb depth = (p_.absorption + p_.coverage * p_.opacity) * (1.0 / ci + 1.0 / co);

  // Glitter: single scattering by the flakes, depth-averaged attenuation A.
  const Vec3 hbar = (ibar + obar).normalized();
  Rgb a;
  for (int c = 0; c < 3; ++c) a[c] = depth[c] > 1e-9 ? -std::expm1(-depth[c]) / depth[c] : 1.0;
  const double p = beckmann_normalised(p_.flake_roughness, hbar.z());
  t.glitter = transmit * p_.coverage * p / (4.0 * ci * co) * flake_reflectance_fast(hbar.dot(ibar)) * a;

  // Shade: the substrate seen through the flake layer, both ways, with the diffuse
  // inter-reflections between substrate and boundary summed as a geometric series
  // (diffuse light crosses the layer at 60 deg on average: twice the vertical depth).
  const Rgb layer_diffuse = (-2.0 * 2.0 * (p_.absorption + p_.coverage * p_.opacity)).exp();
  const Rgb series = 1.0 / (1.0 - p_.substrate * internal_reflectance_ * layer_diffuse);
  t.shade = transmit * p_.substrate / std::numbers::pi * (-depth).exp() * series;
  return t;
}

Rgb LayeredPearlescent::eval_gloss(const Vec3& wi, const Vec3& wo) const { return terms(wi, wo).gloss; }
Rgb LayeredPearlescent::eval_glitter(const Vec3& wi, const Vec3& wo) const { return terms(wi, wo).glitter; }
Rgb LayeredPearlescent::eval_shade(const Vec3& wi, const Vec3& wo) const { return terms(wi, wo).shade; }

Rgb LayeredPearlescent::eval(const Vec3& wi, const Vec3& wo) const {
  const Terms t = terms(wi, wo);
  return t.gloss + t.glitter + t.shade;
}

}  // namespace paintlab::brdf
