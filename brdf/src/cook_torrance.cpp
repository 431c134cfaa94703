#include "paintlab/brdf/cook_torrance.h"

namespace paintlab::brdf {

LobeGeometry LobeGeometry::from_directions(const Vec3& wi, const Vec3& wo) {
  LobeGeometry g;
  if (wi.z() <= 0.0 || wo.z() <= 0.0) {
    g.valid = false;
    return g;
  }
  const Vec3 h = (wi + wo).normalized();
  g.n_dot_h = h.z();
  g.h_dot_wo = h.dot(wo);
  g.n_dot_wi = wi.z();
  g.n_dot_wo = wo.z();
  return g;
}

LobeGeometry LobeGeometry::from_half_diff(double theta_h, double theta_d, double phi_d) {
  const HalfDiffCosines<double> c = cosines_from_half_diff(theta_h, theta_d, phi_d);
  LobeGeometry g{c.n_dot_h, c.h_dot_wo, c.n_dot_wi, c.n_dot_wo, true};
  g.valid = c.n_dot_wi > 0.0 && c.n_dot_wo > 0.0;
  return g;
}

Rgb CookTorrance::eval_at(const LobeGeometry& g) const {
  if (!g.valid) return Rgb::Zero();
  // ct_lobe() per lobe, with the terms every lobe shares computed once (the simulator
  // evaluates this per pixel): tan^2, cos^4, G, (1 - h.wo)^5 and the denominator.
  const double c2 = g.n_dot_h * g.n_dot_h;
  const double tan2 = (1.0 - c2) / c2;
  const double x = 1.0 - g.h_dot_wo, x2 = x * x, x5 = x2 * x2 * x;
  const double common = ct_geometry(g.n_dot_h, g.h_dot_wo, g.n_dot_wi, g.n_dot_wo) /
                        (std::numbers::pi * g.n_dot_wi * g.n_dot_wo * c2 * c2);
  Rgb f = kd_ * (1.0 / std::numbers::pi);
  for (const CtLobe& l : lobes_) {
    const double m2 = l.m * l.m;
    f += l.ks * ((l.r + (1.0 - l.r) * x5) * std::exp(-tan2 / m2) / m2 * common);
  }
  return f;
}

Rgb CookTorrance::eval(const Vec3& wi, const Vec3& wo) const { return eval_at(LobeGeometry::from_directions(wi, wo)); }

Rgb CookTorrance::eval_half_diff(double theta_h, double theta_d, double phi_d) const {
  return eval_at(LobeGeometry::from_half_diff(theta_h, theta_d, phi_d));
}

Rgb CookTorrance::eval_diffuse(const Vec3& wi, const Vec3& wo) const {
  if (wi.z() <= 0.0 || wo.z() <= 0.0) return Rgb::Zero();
  return kd_ * (1.0 / std::numbers::pi);
}

Rgb CookTorrance::eval_lobe(std::size_t lobe, const Vec3& wi, const Vec3& wo) const {
  const CtLobe& l = lobes_.at(lobe);
  return l.ks * ct_lobe(l.m, l.r, LobeGeometry::from_directions(wi, wo));
}

}  // namespace paintlab::brdf
