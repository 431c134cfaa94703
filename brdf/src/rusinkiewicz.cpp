#include "paintlab/brdf/rusinkiewicz.h"

#include <cmath>

namespace paintlab::brdf {

namespace {
// Normalises by dividing each component by the length (not multiplying by its inverse),
// the same rounding as the reference reader.
Eigen::Vector3d normalized_by_division(const Eigen::Vector3d& v) {
  const double len = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
  return {v[0] / len, v[1] / len, v[2] / len};
}

Eigen::Vector3d cross(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}

// in_raw/out_raw: the directions before normalisation (the half vector is formed from them).
HalfDiff half_diff_impl(const Eigen::Vector3d& in_raw, const Eigen::Vector3d& out_raw) {
  const Eigen::Vector3d in = normalized_by_division(in_raw);
  // The reference halves the sum before normalising; with the same operations the
  // rounding is the same.
  Eigen::Vector3d half((in_raw[0] + out_raw[0]) / 2.0, (in_raw[1] + out_raw[1]) / 2.0, (in_raw[2] + out_raw[2]) / 2.0);
  half = normalized_by_division(half);

  HalfDiff hd;
  hd.theta_h = std::acos(half[2]);
  hd.phi_h = std::atan2(half[1], half[0]);
  const Eigen::Vector3d normal(0.0, 0.0, 1.0), binormal(0.0, 1.0, 0.0);
  const Eigen::Vector3d tmp = rotate_about_axis(in, normal, -hd.phi_h);
  const Eigen::Vector3d diff = rotate_about_axis(tmp, binormal, -hd.theta_h);
  hd.theta_d = std::acos(diff[2]);
  hd.phi_d = std::atan2(diff[1], diff[0]);
  return hd;
}
}  // namespace

Eigen::Vector3d rotate_about_axis(const Eigen::Vector3d& v, const Eigen::Vector3d& axis, double angle) {
  // v cos + axis (axis.v)(1 - cos) + (axis x v) sin, evaluated term by term in this order:
  // the zero products of the axis components keep the signs of zeros the reference has.
  const double c = std::cos(angle), s = std::sin(angle);
  Eigen::Vector3d out(v[0] * c, v[1] * c, v[2] * c);
  double t = axis[0] * v[0] + axis[1] * v[1] + axis[2] * v[2];
  t = t * (1.0 - c);
  out[0] += axis[0] * t;
  out[1] += axis[1] * t;
  out[2] += axis[2] * t;
  const Eigen::Vector3d x = cross(axis, v);
  out[0] += x[0] * s;
  out[1] += x[1] * s;
  out[2] += x[2] * s;
  return out;
}

HalfDiff half_diff_from_directions(const Eigen::Vector3d& wi, const Eigen::Vector3d& wo) {
  return half_diff_impl(normalized_by_division(wi), normalized_by_division(wo));
}

HalfDiff half_diff_from_spherical(double theta_in, double phi_in, double theta_out, double phi_out) {
  const double pin = std::sin(theta_in), pout = std::sin(theta_out);
  const Eigen::Vector3d in(pin * std::cos(phi_in), pin * std::sin(phi_in), std::cos(theta_in));
  const Eigen::Vector3d out(pout * std::cos(phi_out), pout * std::sin(phi_out), std::cos(theta_out));
  return half_diff_impl(in, out);
}

DirectionPair directions_from_half_diff(const HalfDiff& hd) {
  const double sd = std::sin(hd.theta_d);
  const Eigen::Vector3d d(sd * std::cos(hd.phi_d), sd * std::sin(hd.phi_d), std::cos(hd.theta_d));
  const Eigen::Vector3d tmp = rotate_about_axis(d, Eigen::Vector3d::UnitY(), hd.theta_h);
  Eigen::Vector3d wi = rotate_about_axis(tmp, Eigen::Vector3d::UnitZ(), hd.phi_h);
  const double sh = std::sin(hd.theta_h);
  const Eigen::Vector3d h(sh * std::cos(hd.phi_h), sh * std::sin(hd.phi_h), std::cos(hd.theta_h));
  wi.normalize();
  Eigen::Vector3d wo = 2.0 * wi.dot(h) * h - wi;
  wo.normalize();
  return {wi, wo};
}

}  // namespace paintlab::brdf
