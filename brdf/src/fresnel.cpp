#include "paintlab/brdf/fresnel.h"

#include <algorithm>

namespace paintlab::brdf {

double fresnel_dielectric(double cos_i, double eta) {
  cos_i = std::clamp(cos_i, 0.0, 1.0);
  const double sin_t2 = (1.0 - cos_i * cos_i) / (eta * eta);
  if (sin_t2 >= 1.0) return 1.0;
  const double cos_t = std::sqrt(1.0 - sin_t2);
  const double rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
  const double rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
  return 0.5 * (rs * rs + rp * rp);
}

Vec3 refract_into_coat(const Vec3& w, double eta) {
  const double x = w.x() / eta, y = w.y() / eta;
  return {x, y, std::sqrt(std::max(0.0, 1.0 - x * x - y * y))};
}

}  // namespace paintlab::brdf
