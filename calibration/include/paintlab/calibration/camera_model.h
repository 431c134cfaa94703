#pragma once
// The calibrated camera: pinhole intrinsics K with OpenCV's 5-coefficient Brown-Conrady
// distortion (k1, k2, p1, p2, k3). Pixel coordinates follow OpenCV (the centre of the
// top-left pixel is (0, 0)); the camera frame is OpenCV's (x right, y down, z forward).
#include <array>
#include <string>

#include "paintlab/core/geometry.h"
#include "paintlab/core/json.h"

namespace paintlab::calib {

struct CameraModel {
  int width_px = 0;
  int height_px = 0;
  Mat3 K = Mat3::Identity();
  std::array<double, 5> dist{};  // k1, k2, p1, p2, k3 (OpenCV order)

  double fx() const { return K(0, 0); }
  double fy() const { return K(1, 1); }
  double cx() const { return K(0, 2); }
  double cy() const { return K(1, 2); }

  // Normalised undistorted image coordinates (x/z, y/z) -> distorted normalised coordinates.
  Vec2 distort(const Vec2& xy) const;
  // Inverse of distort() by Newton's method (converges to 1e-12 inside the image).
  Vec2 undistort(const Vec2& xy_distorted) const;
  // A camera-frame point -> pixel. The point must be in front of the camera (z > 0).
  Vec2 project(const Vec3& p_cam) const;
  // Pixel -> unit ray direction in the camera frame (through the camera centre).
  Vec3 ray(const Vec2& px) const;
  // Pixel -> undistorted normalised coordinates (x/z, y/z).
  Vec2 normalized(const Vec2& px) const;

  // {"K": 3x3 row-major, "dist": [k1,k2,p1,p2,k3], "image_size": [w, h]}.
  Json to_json() const;
  // Reads the keys of to_json(); DataError naming `where` and the key on a bad shape.
  static CameraModel from_json(const Json& j, const std::string& where);
  // Throws DataError naming `where` when K is not a valid upper-triangular intrinsic matrix
  // or the image size is not positive.
  void check(const std::string& where) const;
};

}  // namespace paintlab::calib
