#include "paintlab/brdf/fresnel.h"

#include <algorithm>

namespace paintlab::brdf {

double fresnel_dielectric(double cos_i, double eta) {
  return fresnel_dielectric_t(std::clamp(cos_i, 0.0, 1.0), eta);
}

Vec3 refract_into_coat(const Vec3& w, double eta) {
  const double x = w.x() / eta, y = w.y() / eta;
  return {x, y, std::sqrt(std::max(0.0, 1.0 - x * x - y * y))};
}

}  // namespace paintlab::brdf
