#pragma once
// Layered pearlescent paint after Ershov, Durikovic, Kolchin and Myszkowski (2004);
// models.md "Layered pearlescent paint". A Lambertian substrate (albedo rs) under a binder
// film (index eta, vertical absorption optical depth kappa h) that holds interference-
// coated flakes (coverage c = D<S>h, opacity <1 - t_p>, Beckmann orientation spread), under
// an air-binder boundary:
//   f = gloss + (1 - F(n.wi)) (1 - F(n.wo)) / eta^2 * (glitter + shade)(ibar, obar)
//   gloss   = F(h.wi) D_b(h) G / (4 (n.wi)(n.wo))            boundary, Beckmann D_b normalised
//                                                           (with 1/pi), roughness gloss_roughness
//   glitter = c r_p(alpha) P(beta) A / (4 cos tbar_i cos tbar_o)   flake layer (single scattering)
//   shade   = rs / pi * exp(-tau(tbar_i) h - tau(tbar_o) h) / (1 - rs R_int T_layer)
//             the substrate through the flakes; the last factor sums the diffuse
//             inter-reflections between substrate and boundary (R_int: diffuse internal
//             reflectance of the boundary, T_layer = exp(-4 (kappa h + c <1 - t_p>)): the
//             two-way transmittance of the layer for diffuse light)
// with tau(t) h = (kappa h + c <1 - t_p>) / cos t, A = (1 - exp(-(tau_i + tau_o) h)) / ((tau_i + tau_o) h),
// beta = angle(n, hbar), alpha = angle(ibar, hbar), P the Beckmann distribution of flake
// normals (normalised: integral of P cos(beta) = 1), r_p the RGB reflectance of a thin
// film (index film_ior, thickness film_thickness_nm) on a flake core (core_ior) seen
// from the binder: Airy's formula, s and p averaged, box-averaged over each colour band
// (R 590-680 nm, G 500-590 nm, B 410-500 nm). r_p depends on alpha, so the colour shifts
// with the angle between light and view. The 1/eta^2 and the transmittances are the
// radiance bookkeeping of Ershov's R+ (cos t / (eta^2 cos tbar)) written as a BRDF.
// Not a sum of Cook-Torrance lobes (that is why the simulator offers it).
#include <vector>

#include "paintlab/brdf/brdf.h"

namespace paintlab::brdf {

struct PearlescentParams {
  Rgb substrate = Rgb::Constant(0.8);  // rs, Lambertian albedo of the base coat, [0, 1]
  double ior = 1.5;                    // eta of the binder and clear coat, [1, 3]
  double gloss_roughness = 0.04;       // Beckmann m of the boundary, (0, 1)
  Rgb absorption = Rgb::Zero();        // kappa h, vertical optical depth of the binder, >= 0
  double coverage = 0.8;               // c = D <S> h, flake area per unit paint area, >= 0
  double opacity = 0.9;                // <1 - t_p>, [0, 1]
  double flake_roughness = 0.2;        // Beckmann m of the flake normals, (0, 1)
  double film_ior = 2.4;               // interference coating (TiO2 ~ 2.4-2.6), > 1
  double film_thickness_nm = 130;      // coating thickness, (0, 2000]
  double core_ior = 1.58;              // flake core (mica ~ 1.58), > 1
  bool operator==(const PearlescentParams& o) const;
};

class LayeredPearlescent final : public Brdf {
 public:
  explicit LayeredPearlescent(PearlescentParams p);
  Rgb eval(const Vec3& wi, const Vec3& wo) const override;
  std::string model() const override { return "layered-pearlescent"; }

  // The three terms separately (each zero below the horizon); eval() is their sum.
  Rgb eval_gloss(const Vec3& wi, const Vec3& wo) const;
  Rgb eval_glitter(const Vec3& wi, const Vec3& wo) const;
  Rgb eval_shade(const Vec3& wi, const Vec3& wo) const;
  // r_p: RGB reflectance of a coated flake at incidence angle alpha (radians) in the
  // binder, computed with Airy's formula (exact, slow).
  Rgb flake_reflectance(double alpha) const;
  // The same, interpolated in a table over cos(alpha) (what eval() uses; within 1e-4).
  Rgb flake_reflectance_fast(double cos_alpha) const;
  const PearlescentParams& params() const { return p_; }

 private:
  struct Terms {
    Rgb gloss, glitter, shade;
  };
  Terms terms(const Vec3& wi, const Vec3& wo) const;
  PearlescentParams p_;
  double internal_reflectance_ = 0;  // R_int
  std::vector<Rgb> rp_table_;  // r_p at cos(alpha) = i / (size - 1)
};

}  // namespace paintlab::brdf
