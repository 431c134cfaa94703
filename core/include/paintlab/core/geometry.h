#pragma once
// Geometry helpers (Eigen). Angles are radians inside the code. Transforms are named
// target_from_source (cam_from_rig maps rig-frame points into the camera frame).
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>
#include <numbers>

namespace paintlab {

using Vec2 = Eigen::Vector2d;
using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;

inline constexpr double kPi = std::numbers::pi;
inline constexpr double deg_to_rad(double deg) { return deg * (kPi / 180.0); }
inline constexpr double rad_to_deg(double rad) { return rad * (180.0 / kPi); }

// Wraps an angle to (-pi, pi].
double wrap_pi(double rad);
// Wraps an angle in degrees to [0, 360).
double wrap_360(double deg);
// Signed smallest difference a - b in degrees, in (-180, 180].
double angle_diff_deg(double a_deg, double b_deg);
// Angle between two non-zero vectors, robust near 0 and pi.
double angle_between(const Vec3& a, const Vec3& b);

// A rigid transform p' = R p + t.
struct Rigid3 {
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
  Vec3 translation = Vec3::Zero();

  Vec3 operator*(const Vec3& p) const { return rotation * p + translation; }
  Rigid3 operator*(const Rigid3& o) const { return {rotation * o.rotation, rotation * o.translation + translation}; }
  Rigid3 inverse() const {
    Eigen::Quaterniond r = rotation.conjugate();
    return {r, -(r * translation)};
  }
  Mat3 matrix() const { return rotation.toRotationMatrix(); }
  // The point this transform maps to the origin's image: for cam_from_rig, the camera
  // centre in rig coordinates is inverse().translation.
};

// cam_from_world for a camera at `eye` looking at `target` with world `up` roughly up in
// the image (OpenCV camera frame: x right, y down, z forward).
Rigid3 look_at(const Vec3& eye, const Vec3& target, const Vec3& up);

// An orthonormal frame whose z axis is n (for shading); x, y arbitrary but deterministic.
Mat3 frame_from_normal(const Vec3& n);

// Unit vector from spherical angles: theta from +z, phi from +x towards +y.
Vec3 spherical_to_vec(double theta, double phi);

}  // namespace paintlab
