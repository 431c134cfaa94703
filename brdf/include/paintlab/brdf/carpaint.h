#pragma once
// AxF-like car paint (X-Rite CPA2 model as described by Golla and Klein 2017 and as
// renderers decode it; models.md "AxF-like car paint"):
//   f(wi, wo) = (1 - F_eta(n.wi)) (1 - F_eta(n.wo)) * chi(theta_hbar, theta_ibar) *
//               ( a / pi + sum_k s_k * ct_lobe(alpha_k, F0_k; ibar, obar) )
// ibar, obar: wi and wo refracted into the clear coat (index eta), hbar their half vector,
// theta_hbar = angle(n, hbar), theta_ibar = angle(hbar, ibar). ct_lobe is the
// Cook-Torrance lobe of cook_torrance.h (Beckmann D without 1/pi, Schlick F, the
// min(1, ...) G, the pi (n.ibar)(n.obar) denominator), the same code the fits use.
// The clear coat's own mirror reflection F_eta (a delta) is not part of eval(); a renderer
// adds it with clearcoat_reflectance(). The flake BTF (Xi) is the simulator's sparkle.
#include <vector>

#include "paintlab/brdf/brdf.h"
#include "paintlab/brdf/fresnel.h"

namespace paintlab::brdf {

// What the car-paint model needs of one (wi, wo) pair seen through a clear coat of index
// eta: the cosines of ct_lobe() in refracted directions, the angles chi is indexed by
// (cos theta_hbar = n_dot_hbar, cos theta_ibar = hbar_dot_obar, since hbar.ibar = hbar.obar)
// and the transmittance (1 - F_eta(n.wi))(1 - F_eta(n.wo)). Templated so a fit can treat
// eta as a parameter (ceres::Jet). wi and wo must be above the horizon.
template <class T>
struct CoatGeometry {
  T n_dot_hbar;
  T hbar_dot_obar;
  T n_dot_ibar;
  T n_dot_obar;
  T transmittance;
};

template <class T>
CoatGeometry<T> coat_geometry(const T& eta, const Vec3& wi, const Vec3& wo) {
  using std::sqrt;
  const T ix = T(wi.x()) / eta, iy = T(wi.y()) / eta, ox = T(wo.x()) / eta, oy = T(wo.y()) / eta;
  const T iz = sqrt(T(1.0) - ix * ix - iy * iy), oz = sqrt(T(1.0) - ox * ox - oy * oy);
  const T hx = ix + ox, hy = iy + oy, hz = iz + oz;
  const T len = sqrt(hx * hx + hy * hy + hz * hz);
  CoatGeometry<T> g;
  g.n_dot_hbar = hz / len;
  g.hbar_dot_obar = (hx * ox + hy * oy + hz * oz) / len;
  g.n_dot_ibar = iz;
  g.n_dot_obar = oz;
  g.transmittance = (T(1.0) - fresnel_dielectric_t(T(wi.z()), eta)) * (T(1.0) - fresnel_dielectric_t(T(wo.z()), eta));
  return g;
}

struct AxfLobe {
  double coefficient = 0;  // s_k >= 0 (achromatic)
  double spread = 0.1;     // alpha_k, Beckmann roughness in (0, 1)
  double f0 = 0.5;         // Schlick F0 in (0, 1)
  bool operator==(const AxfLobe&) const = default;
};

// The colour table chi: RGB samples over (theta_hbar, theta_ibar), both in [0, pi/2].
// Sample (a, b) sits at u = (a + 0.5) / theta_h_samples, v = (b + 0.5) / theta_i_samples
// with u = 2 theta_hbar / pi, v = 2 theta_ibar / pi (half-texel offsets, as AxF's
// _BRDFColorMap); lookup is bilinear, clamped at the borders, times `scale`.
struct ColourTable {
  int theta_h_samples = 1;
  int theta_i_samples = 1;
  double scale = 1.0;
  std::vector<Rgb> rgb{Rgb::Ones()};  // row-major: rgb[a * theta_i_samples + b]

  Rgb eval(double theta_hbar, double theta_ibar) const;
  bool operator==(const ColourTable& o) const;
};

struct AxfCarPaintParams {
  double ior = 1.5;      // clear-coat index of refraction eta, [1, 3]
  double diffuse = 0.0;  // a: diffuse albedo before chi, >= 0
  std::vector<AxfLobe> lobes;
  ColourTable chi;
  bool operator==(const AxfCarPaintParams&) const = default;
};

class AxfCarPaint final : public Brdf {
 public:
  explicit AxfCarPaint(AxfCarPaintParams p) : p_(std::move(p)) {}
  Rgb eval(const Vec3& wi, const Vec3& wo) const override;
  std::string model() const override { return "axf-carpaint"; }

  // The body term without chi and without the transmittances, in refracted directions:
  // a / pi + sum_k s_k ct_lobe. Zero when either direction is below the horizon.
  double achromatic_refracted(const Vec3& ibar, const Vec3& obar) const;
  // The clear coat's mirror reflectance F_eta at incidence cosine cos_theta.
  double clearcoat_reflectance(double cos_theta) const;
  const AxfCarPaintParams& params() const { return p_; }

 private:
  AxfCarPaintParams p_;
};

}  // namespace paintlab::brdf
