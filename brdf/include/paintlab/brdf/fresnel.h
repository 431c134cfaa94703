#pragma once
// Fresnel and refraction helpers for the clear-coat models (AxF-like car paint, layered
// pearlescent). Directions in the local frame, n = +z, pointing away from the surface.
#include <cmath>

#include "paintlab/brdf/brdf.h"

namespace paintlab::brdf {

// Unpolarised Fresnel reflectance of a dielectric boundary from the outside (index 1)
// into a medium of index eta >= 1, for the cosine of the incidence angle (clamped to [0, 1]).
double fresnel_dielectric(double cos_i, double eta);

// The direction inside a clear coat of index eta that refracts into the outside direction
// w (Snell): same azimuth, sin(theta_bar) = sin(theta) / eta, pointing up (z > 0).
// Requires w.z() > 0.
Vec3 refract_into_coat(const Vec3& w, double eta);

}  // namespace paintlab::brdf
