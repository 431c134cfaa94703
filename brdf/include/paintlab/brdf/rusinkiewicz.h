#pragma once
// Rusinkiewicz half/difference coordinates (Rusinkiewicz, EGWR 1998; models.md "Frames and
// angles"). Local shading frame: normal n = +z; wi towards the light, wo towards the camera.
//   h = normalize(wi + wo), theta_h = acos(h.z), phi_h = atan2(h.y, h.x);
//   d = wi rotated by -phi_h about z, then by -theta_h about y; theta_d = acos(d.z),
//   phi_d = atan2(d.y, d.x) in [-pi, pi].
// The arithmetic follows the public MERL reference reader step by step (including its
// Rodrigues rotation), so angles that fall exactly on a bin edge (phi_d = +-pi, signed
// zeros) land in the same bin as in the reference.
#include <Eigen/Core>

namespace paintlab::brdf {

struct HalfDiff {
  double theta_h = 0;  // [0, pi]
  double phi_h = 0;    // [-pi, pi]
  double theta_d = 0;  // [0, pi]
  double phi_d = 0;    // [-pi, pi]
};

struct DirectionPair {
  Eigen::Vector3d wi;
  Eigen::Vector3d wo;
};

// (wi, wo) -> half/difference angles. wi and wo need not be normalised exactly; they are
// normalised first. Directions below the horizon are allowed (the angles are still defined).
HalfDiff half_diff_from_directions(const Eigen::Vector3d& wi, const Eigen::Vector3d& wo);

// Standard spherical coordinates of wi (theta_in, phi_in) and wo (theta_out, phi_out), in
// radians, theta from +z, phi from +x towards +y -> half/difference angles. This is the
// reference reader's std_coords_to_half_diff_coords.
HalfDiff half_diff_from_spherical(double theta_in, double phi_in, double theta_out, double phi_out);

// The inverse: half/difference angles -> unit (wi, wo). wo is wi mirrored about h.
DirectionPair directions_from_half_diff(const HalfDiff& hd);

// Cosines an isotropic BRDF needs, from (theta_h, theta_d, phi_d) alone (phi_h = 0):
//   n.wi = cos th cos td - sin th sin td cos pd, n.wo = cos th cos td + sin th sin td cos pd,
//   h.wi = h.wo = cos td, n.h = cos th.
// Templated over the scalar type so Ceres autodiff can use it (ceres::Jet).
template <class T>
struct HalfDiffCosines {
  T n_dot_h;
  T h_dot_wo;  // = h.wi
  T n_dot_wi;
  T n_dot_wo;
};

template <class T>
HalfDiffCosines<T> cosines_from_half_diff(const T& theta_h, const T& theta_d, const T& phi_d) {
  using std::cos;
  using std::sin;
  const T ch = cos(theta_h), sh = sin(theta_h), cd = cos(theta_d), sd = sin(theta_d), cp = cos(phi_d);
  const T a = ch * cd;
  const T b = sh * sd * cp;
  return {ch, cd, a - b, a + b};
}

// Rodrigues rotation of v about the unit `axis` by `angle` (right-handed).
Eigen::Vector3d rotate_about_axis(const Eigen::Vector3d& v, const Eigen::Vector3d& axis, double angle);

}  // namespace paintlab::brdf
