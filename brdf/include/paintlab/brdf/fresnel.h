#pragma once
// Fresnel and refraction helpers for the clear-coat models (AxF-like car paint, layered
// pearlescent). Directions in the local frame, n = +z, pointing away from the surface.
#include <cmath>

#include "paintlab/brdf/brdf.h"

namespace paintlab::brdf {

// Unpolarised Fresnel reflectance of a dielectric boundary from the outside (index 1)
// into a medium of index eta >= 1, for the cosine of the incidence angle in [0, 1].
// Templated for Ceres autodiff (eta may be a fitted parameter).
template <class T>
T fresnel_dielectric_t(const T& cos_i, const T& eta) {
  using std::sqrt;
  const T sin_t2 = (T(1.0) - cos_i * cos_i) / (eta * eta);
  if (!(sin_t2 < T(1.0))) return T(1.0);
  const T cos_t = sqrt(T(1.0) - sin_t2);
  const T rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
  const T rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
  return T(0.5) * (rs * rs + rp * rp);
}

// The same for doubles, with cos_i clamped to [0, 1].
double fresnel_dielectric(double cos_i, double eta);

// The direction inside a clear coat of index eta that refracts into the outside direction
// w (Snell): same azimuth, sin(theta_bar) = sin(theta) / eta, pointing up (z > 0).
// Requires w.z() > 0.
Vec3 refract_into_coat(const Vec3& w, double eta);

}  // namespace paintlab::brdf
