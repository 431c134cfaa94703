#pragma once
// The cosine-lobe basis (docs/design.md "Cosine-lobe basis"; the 2005 source on interactive
// colour-appearance design of automotive paints): reflected radiance under a light of unit
// irradiance at normal incidence,
//   f(wi, wo) (n.wi) = kd / pi (n.wi) + sum_i kg_i (r.wo)^E_i + (n.wi) sum_i kdd_i (r.wo)^E_i
// with r = 2 (n.wi) n - wi the mirror direction of the light, (r.wo) clamped at 0, and a
// fixed set of exponents E_i shared by every paint of a library (paintlab basis fit). The
// weights are per channel and >= 0: kd is the diffuse albedo (as Cook-Torrance's kd), kg_i
// and kdd_i are in 1/sr (the lobe's value at the mirror direction). The kg terms carry no
// (n.wi): the source's gloss lobes, whose BRDF is kg_i (r.wo)^E_i / (n.wi).
#include <vector>

#include "paintlab/brdf/brdf.h"

namespace paintlab::brdf {

inline constexpr int kMaxCosineLobes = 11;    // the source studied 1 to 11 lobes
inline constexpr double kMinLobeExponent = 0.5;
inline constexpr double kMaxLobeExponent = 1e6;

struct CosineLobeParams {
  std::vector<double> exponents;  // E_i, 1..kMaxCosineLobes, each in [0.5, 1e6], increasing
  Rgb kd = Rgb::Zero();           // diffuse albedo, >= 0
  std::vector<Rgb> kg;            // one per exponent, >= 0, 1/sr
  std::vector<Rgb> kdd;           // one per exponent, >= 0, 1/sr
  bool operator==(const CosineLobeParams& o) const;
};

// The value of lobe term E for a direction pair: (r.wo)_+^E, and its two columns of the model
// (kg: (r.wo)^E / (n.wi), kdd: (r.wo)^E) as BRDF values. wi.z() > 0 and wo.z() > 0.
double cosine_lobe(double exponent, const Vec3& wi, const Vec3& wo);

class CosineLobes final : public Brdf {
 public:
  explicit CosineLobes(CosineLobeParams p);
  Rgb eval(const Vec3& wi, const Vec3& wo) const override;
  std::string model() const override { return "cosine-lobes"; }
  const CosineLobeParams& params() const { return p_; }

 private:
  CosineLobeParams p_;
};

// Empty when the parameters are valid, else the first problem naming the key
// ("exponents[2]: 0.1 below 0.5", "kg: 3 entries for 4 exponents").
std::string cosine_lobes_problem(const CosineLobeParams& p);

}  // namespace paintlab::brdf
