#include "paintlab/calibration/camera_model.h"

#include <Eigen/Dense>
#include <cmath>

#include "paintlab/core/error.h"

namespace paintlab::calib {

Vec2 CameraModel::distort(const Vec2& xy) const {
  const double x = xy.x(), y = xy.y();
  const double k1 = dist[0], k2 = dist[1], p1 = dist[2], p2 = dist[3], k3 = dist[4];
  const double r2 = x * x + y * y;
  const double radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
  return {x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x),
          y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y};
}

Vec2 CameraModel::undistort(const Vec2& xy_distorted) const {
  const double k1 = dist[0], k2 = dist[1], p1 = dist[2], p2 = dist[3], k3 = dist[4];
  Vec2 p = xy_distorted;
  for (int it = 0; it < 50; ++it) {
    const double x = p.x(), y = p.y();
    const double r2 = x * x + y * y;
    const double radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
    const double dradial_dr2 = k1 + r2 * (2.0 * k2 + 3.0 * k3 * r2);
    const Vec2 f = distort(p) - xy_distorted;
    // The 2x2 Jacobian (symmetric) solved in closed form.
    const double a = radial + 2.0 * x * x * dradial_dr2 + 2.0 * p1 * y + 6.0 * p2 * x;
    const double b = 2.0 * x * y * dradial_dr2 + 2.0 * p1 * x + 2.0 * p2 * y;
    const double d = radial + 2.0 * y * y * dradial_dr2 + 6.0 * p1 * y + 2.0 * p2 * x;
    const double det = a * d - b * b;
    if (!(std::abs(det) > 1e-300)) break;
    Vec2 step((d * f.x() - b * f.y()) / det, (a * f.y() - b * f.x()) / det);
    // Far outside the valid region of a strongly distorting model the Newton step can
    // overshoot: damp it so the iteration stays bounded.
    const double n = step.norm();
    if (n > 0.5) step *= 0.5 / n;
    p -= step;
    if (step.norm() < 1e-14) break;
  }
  return p;
}

Vec2 CameraModel::project(const Vec3& p_cam) const {
  Vec2 d = distort(Vec2(p_cam.x() / p_cam.z(), p_cam.y() / p_cam.z()));
  return {K(0, 0) * d.x() + K(0, 1) * d.y() + K(0, 2), K(1, 1) * d.y() + K(1, 2)};
}

Vec2 CameraModel::normalized(const Vec2& px) const {
  const double yd = (px.y() - K(1, 2)) / K(1, 1);
  const double xd = (px.x() - K(0, 2) - K(0, 1) * yd) / K(0, 0);
  return undistort(Vec2(xd, yd));
}

Vec3 CameraModel::ray(const Vec2& px) const {
  Vec2 n = normalized(px);
  return Vec3(n.x(), n.y(), 1.0).normalized();
}

Json CameraModel::to_json() const {
  return {{"K", matrix_to_json(K)},
          {"dist", Json::array({dist[0], dist[1], dist[2], dist[3], dist[4]})},
          {"image_size", Json::array({width_px, height_px})}};
}

CameraModel CameraModel::from_json(const Json& j, const std::string& where) {
  CameraModel m;
  if (!j.contains("K")) throw DataError(where + ": missing key 'K'");
  Eigen::MatrixXd k = matrix_from_json(j.at("K"), where + ": key 'K'");
  if (k.rows() != 3 || k.cols() != 3) throw DataError(where + ": key 'K' must be a 3x3 matrix");
  m.K = k;
  auto d = json_get<std::vector<double>>(j, "dist", where);
  if (d.size() != 5 && d.size() != 4)
    throw DataError(where + ": key 'dist' must hold 5 coefficients k1, k2, p1, p2, k3 (got " +
                    std::to_string(d.size()) + ")");
  for (std::size_t i = 0; i < d.size(); ++i) m.dist[i] = d[i];
  auto size = json_get<std::vector<int>>(j, "image_size", where);
  if (size.size() != 2) throw DataError(where + ": key 'image_size' must be [width, height]");
  m.width_px = size[0];
  m.height_px = size[1];
  m.check(where);
  return m;
}

void CameraModel::check(const std::string& where) const {
  if (width_px <= 0 || height_px <= 0)
    throw DataError(where + ": key 'image_size' must be positive (got " + std::to_string(width_px) + "x" +
                    std::to_string(height_px) + ")");
  if (!(K(0, 0) > 0 && K(1, 1) > 0) || K(1, 0) != 0 || K(2, 0) != 0 || K(2, 1) != 0 || K(2, 2) != 1)
    throw DataError(where + ": key 'K' must be [[fx, s, cx], [0, fy, cy], [0, 0, 1]] with fx, fy > 0");
  for (double v : dist)
    if (!std::isfinite(v)) throw DataError(where + ": key 'dist' holds a non-finite coefficient");
}

}  // namespace paintlab::calib
