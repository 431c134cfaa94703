#include "paintlab/core/geometry.h"

#include <algorithm>

namespace paintlab {

double wrap_pi(double rad) {
  double r = std::remainder(rad, 2.0 * kPi);  // in [-pi, pi]
  return r <= -kPi ? r + 2.0 * kPi : r;
}

double wrap_360(double deg) {
  double d = std::fmod(deg, 360.0);
  if (d < 0) d += 360.0;
  return d >= 360.0 ? 0.0 : d;
}

double angle_diff_deg(double a_deg, double b_deg) {
  double d = std::remainder(a_deg - b_deg, 360.0);
  return d <= -180.0 ? d + 360.0 : d;
}

double angle_between(const Vec3& a, const Vec3& b) {
  // atan2 of |a x b| and a.b keeps full precision near 0 and pi (unlike acos).
  return std::atan2(a.cross(b).norm(), a.dot(b));
}

Rigid3 look_at(const Vec3& eye, const Vec3& target, const Vec3& up) {
  Vec3 z = (target - eye).normalized();            // forward
  Vec3 x = z.cross(up);                            // right = forward x up (y is down)
  if (x.norm() < 1e-12) x = z.unitOrthogonal();
  x.normalize();
  Vec3 y = z.cross(x);                             // down
  Mat3 world_from_cam;
  world_from_cam.col(0) = x;
  world_from_cam.col(1) = y;
  world_from_cam.col(2) = z;
  Rigid3 cam_from_world;
  cam_from_world.rotation = Eigen::Quaterniond(world_from_cam.transpose());
  cam_from_world.rotation.normalize();
  cam_from_world.translation = -(world_from_cam.transpose() * eye);
  return cam_from_world;
}

Mat3 frame_from_normal(const Vec3& n) {
  // Duff et al. 2017, "Building an Orthonormal Basis, Revisited".
  double sign = std::copysign(1.0, n.z());
  double a = -1.0 / (sign + n.z());
  double b = n.x() * n.y() * a;
  Vec3 t(1.0 + sign * n.x() * n.x() * a, sign * b, -sign * n.x());
  Vec3 s(b, sign + n.y() * n.y() * a, -n.y());
  Mat3 m;
  m.col(0) = t;
  m.col(1) = s;
  m.col(2) = n;
  return m;
}

Vec3 spherical_to_vec(double theta, double phi) {
  double st = std::sin(theta);
  return {st * std::cos(phi), st * std::sin(phi), std::cos(theta)};
}

}  // namespace paintlab
