#pragma once
// Multi-lobe Cook-Torrance (Günther et al., VMV 2005, eq. 1; models.md):
//   f(wi, wo) = kd / pi + sum_l ks_l * F(r_l, h.wo) * D(m_l, theta_h) * G / (pi (n.wi)(n.wo))
//   D(m, theta_h) = exp(-tan^2(theta_h) / m^2) / (m^2 cos^4(theta_h))   (Beckmann WITHOUT 1/pi:
//                   the pi of the denominator is the normalisation's 1/pi)
//   F(r, c) = r + (1 - r)(1 - c)^5                                          (Schlick)
//   G = min(1, 2 (n.h)(n.wo) / (wo.h), 2 (n.h)(n.wi) / (wo.h))
// With this convention a lobe reflects about 4 ks F of the incident light (the standard
// microfacet form is F D_norm G / (4 (n.wi)(n.wo)) with D_norm = D / pi).
//
// The lobe functions are templates over the scalar type so Ceres autodiff (ceres::Jet)
// evaluates exactly the code the simulator uses. They include no Ceres header: Jet
// finds exp() by argument-dependent lookup and supports < and the arithmetic used here.
#include <cmath>
#include <numbers>
#include <vector>

#include "paintlab/brdf/brdf.h"
#include "paintlab/brdf/rusinkiewicz.h"

namespace paintlab::brdf {

// Beckmann distribution without the 1/pi (see above). cos_theta_h = n.h > 0.
template <class T>
T beckmann_d(const T& m, const T& cos_theta_h) {
  using std::exp;
  const T c2 = cos_theta_h * cos_theta_h;
  const T tan2 = (T(1.0) - c2) / c2;
  const T m2 = m * m;
  return exp(-tan2 / m2) / (m2 * c2 * c2);
}

// Schlick's Fresnel approximation with normal-incidence reflectance r; c = h.wo.
template <class T>
T schlick_f(const T& r, const T& c) {
  const T x = T(1.0) - c;
  const T x2 = x * x;
  return r + (T(1.0) - r) * (x2 * x2 * x);
}

// Cook-Torrance shadowing/masking G = min(1, 2 (n.h)(n.wo)/(wo.h), 2 (n.h)(n.wi)/(wo.h)).
template <class T>
T ct_geometry(const T& n_dot_h, const T& h_dot_wo, const T& n_dot_wi, const T& n_dot_wo) {
  T g(1.0);
  const T a = T(2.0) * n_dot_h * n_dot_wo / h_dot_wo;
  const T b = T(2.0) * n_dot_h * n_dot_wi / h_dot_wo;
  if (a < g) g = a;
  if (b < g) g = b;
  return g;
}

// One lobe without its ks: F(r, h.wo) D(m, theta_h) G / (pi (n.wi)(n.wo)), in 1/sr.
// All cosines must be > 0 (both directions above the horizon).
template <class T>
T ct_lobe(const T& m, const T& r, const T& cos_theta_h, const T& h_dot_wo, const T& n_dot_wi, const T& n_dot_wo) {
  return schlick_f(r, h_dot_wo) * beckmann_d(m, cos_theta_h) * ct_geometry(cos_theta_h, h_dot_wo, n_dot_wi, n_dot_wo) /
         (T(std::numbers::pi) * n_dot_wi * n_dot_wo);
}

// The same lobe from the isotropic half/difference angles (theta_h, theta_d, phi_d),
// e.g. a MERL bin's mean coordinates. Returns 0 where wi or wo is below the horizon.
template <class T>
T ct_lobe_half_diff(const T& m, const T& r, const T& theta_h, const T& theta_d, const T& phi_d) {
  const HalfDiffCosines<T> c = cosines_from_half_diff(theta_h, theta_d, phi_d);
  if (!(c.n_dot_wi > T(0.0)) || !(c.n_dot_wo > T(0.0))) return T(0.0);
  return ct_lobe(m, r, c.n_dot_h, c.h_dot_wo, c.n_dot_wi, c.n_dot_wo);
}

// Precomputed cosines of one (wi, wo) pair (or one bin), for fits that evaluate many
// parameter sets at fixed coordinates. valid is false below the horizon.
struct LobeGeometry {
  double n_dot_h = 1;
  double h_dot_wo = 1;
  double n_dot_wi = 1;
  double n_dot_wo = 1;
  bool valid = true;

  static LobeGeometry from_directions(const Vec3& wi, const Vec3& wo);
  static LobeGeometry from_half_diff(double theta_h, double theta_d, double phi_d);
};

// ct_lobe at fixed geometry with (possibly Jet) parameters; 0 when !g.valid.
template <class T>
T ct_lobe(const T& m, const T& r, const LobeGeometry& g) {
  if (!g.valid) return T(0.0);
  return ct_lobe(m, r, T(g.n_dot_h), T(g.h_dot_wo), T(g.n_dot_wi), T(g.n_dot_wo));
}

struct CtLobe {
  Rgb ks = Rgb::Zero();  // RGB lobe weight
  double m = 0.1;        // Beckmann roughness, plausible in (0, 1)
  double r = 0.5;        // Schlick F0, plausible in (0, 1)
  bool operator==(const CtLobe& o) const { return (ks == o.ks).all() && m == o.m && r == o.r; }
};

// kd/pi + sum of lobes. eval() is zero below the horizon.
class CookTorrance final : public Brdf {
 public:
  CookTorrance(const Rgb& kd, std::vector<CtLobe> lobes) : kd_(kd), lobes_(std::move(lobes)) {}
  Rgb eval(const Vec3& wi, const Vec3& wo) const override;
  std::string model() const override { return "cook-torrance"; }

  // The same BRDF at half/difference angles (phi_h irrelevant: isotropic).
  Rgb eval_half_diff(double theta_h, double theta_d, double phi_d) const;
  // The diffuse part kd / pi (above the horizon) and one lobe alone (ks included), for
  // the simulator's sparkle, which redistributes the energy of the flake lobes.
  Rgb eval_diffuse(const Vec3& wi, const Vec3& wo) const;
  Rgb eval_lobe(std::size_t lobe, const Vec3& wi, const Vec3& wo) const;

  const Rgb& kd() const { return kd_; }
  const std::vector<CtLobe>& lobes() const { return lobes_; }

 private:
  Rgb eval_at(const LobeGeometry& g) const;
  Rgb kd_;
  std::vector<CtLobe> lobes_;
};

}  // namespace paintlab::brdf
