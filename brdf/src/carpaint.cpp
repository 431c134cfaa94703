#include "paintlab/brdf/carpaint.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "paintlab/brdf/cook_torrance.h"
#include "paintlab/brdf/fresnel.h"

namespace paintlab::brdf {

namespace {
// Texel coordinate with half-texel offset, clamped: returns (index, fraction).
void texel(double unit, int n, int& i0, double& frac) {
  double x = unit * n - 0.5;
  x = std::clamp(x, 0.0, static_cast<double>(n - 1));
  i0 = std::min(static_cast<int>(x), std::max(n - 2, 0));
  frac = x - i0;
}
}  // namespace

Rgb ColourTable::eval(double theta_hbar, double theta_ibar) const {
  const double half_pi = std::numbers::pi / 2;
  int a0, b0;
  double fa, fb;
  texel(theta_hbar / half_pi, theta_h_samples, a0, fa);
  texel(theta_ibar / half_pi, theta_i_samples, b0, fb);
  const int a1 = std::min(a0 + 1, theta_h_samples - 1), b1 = std::min(b0 + 1, theta_i_samples - 1);
  auto at = [&](int a, int b) -> const Rgb& { return rgb[static_cast<std::size_t>(a * theta_i_samples + b)]; };
  const Rgb v = (1 - fa) * ((1 - fb) * at(a0, b0) + fb * at(a0, b1)) + fa * ((1 - fb) * at(a1, b0) + fb * at(a1, b1));
  return v * scale;
}

bool ColourTable::operator==(const ColourTable& o) const {
  if (theta_h_samples != o.theta_h_samples || theta_i_samples != o.theta_i_samples || scale != o.scale ||
      rgb.size() != o.rgb.size())
    return false;
  for (std::size_t i = 0; i < rgb.size(); ++i)
    if (!(rgb[i] == o.rgb[i]).all()) return false;
  return true;
}

double AxfCarPaint::achromatic_refracted(const Vec3& ibar, const Vec3& obar) const {
  if (ibar.z() <= 0.0 || obar.z() <= 0.0) return 0.0;
  double f = p_.diffuse / std::numbers::pi;
  const LobeGeometry g = LobeGeometry::from_directions(ibar, obar);
  for (const AxfLobe& l : p_.lobes) f += l.coefficient * ct_lobe(l.spread, l.f0, g);
  return f;
}

double AxfCarPaint::clearcoat_reflectance(double cos_theta) const { return fresnel_dielectric(cos_theta, p_.ior); }

Rgb AxfCarPaint::eval(const Vec3& wi, const Vec3& wo) const {
  if (wi.z() <= 0.0 || wo.z() <= 0.0) return Rgb::Zero();
  const CoatGeometry<double> g = coat_geometry(p_.ior, wi, wo);
  double f = p_.diffuse / std::numbers::pi;
  for (const AxfLobe& l : p_.lobes)
    f += l.coefficient * ct_lobe(l.spread, l.f0, g.n_dot_hbar, g.hbar_dot_obar, g.n_dot_ibar, g.n_dot_obar);
  const double theta_hbar = std::acos(std::clamp(g.n_dot_hbar, -1.0, 1.0));
  const double theta_ibar = std::acos(std::clamp(g.hbar_dot_obar, -1.0, 1.0));
  return p_.chi.eval(theta_hbar, theta_ibar) * (g.transmittance * f);
}

}  // namespace paintlab::brdf
