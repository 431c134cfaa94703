#pragma once
// The simulated camera's geometry: a pinhole with OpenCV's Brown-Conrady distortion
// (k1, k2, p1, p2, k3; cv::projectPoints' formula), its pose in the rig and the lens'
// vignetting. Pixel coordinates follow OpenCV: pixel (i, j) covers [i-0.5, i+0.5] x
// [j-0.5, j+0.5], its centre is at (i, j).
#include <array>
#include <mutex>
#include <vector>

#include "paintlab/core/geometry.h"
#include "paintlab/core/image.h"
#include "paintlab/sim/config.h"

namespace paintlab::sim {

class CameraModel {
 public:
  explicit CameraModel(const CameraTruth& truth);

  const CameraTruth& truth() const { return truth_; }
  int width() const { return truth_.width_px; }
  int height() const { return truth_.height_px; }
  Mat3 K() const { return truth_.K(); }
  const std::array<double, 5>& dist() const { return truth_.dist; }
  const Rigid3& cam_from_rig() const { return cam_from_rig_; }
  const Rigid3& rig_from_cam() const { return rig_from_cam_; }
  Vec3 centre_rig() const { return rig_from_cam_.translation; }

  // Normalised undistorted (x/z, y/z) -> distorted normalised coordinates (OpenCV model).
  Vec2 distort(const Vec2& xn) const;
  // The inverse of distort() by Newton's method (converged to 1e-14 where it is invertible).
  Vec2 undistort(const Vec2& xd) const;
  // A camera-frame point (z > 0) -> pixel coordinates, exactly as cv::projectPoints.
  Vec2 project(const Vec3& p_cam) const;
  Vec2 project_rig(const Vec3& p_rig) const { return project(cam_from_rig_ * p_rig); }
  // Pixel coordinates -> normalised undistorted coordinates, and -> unit ray (camera frame).
  Vec2 unproject(const Vec2& pixel) const;
  Vec3 ray_cam(const Vec2& pixel) const;

  // Relative irradiance on the sensor at a pixel: cos^4 of the field angle times the
  // configured mechanical vignetting (1 at the principal point).
  double vignetting(const Vec2& pixel) const;
  // Image irradiance per unit scene radiance at the principal point: pi / (4 N^2).
  double irradiance_per_radiance() const;

  // Applies the lens PSF (CameraTruth::psf_sigma_px) to a radiance image in place:
  // separable, normalised Gaussian taps out to 4 sigma, edges clamped. threads: 0 = all.
  void blur(ImageF& image, int threads = 0) const;

  // Normalised undistorted coordinates of every pixel corner: (width+1) x (height+1),
  // corner (i, j) at pixel coordinates (i - 0.5, j - 0.5). Computed once, then shared.
  const std::vector<Vec2>& corner_grid() const;
  // Undistorted normalised coordinates at a point inside pixel (px, py), (fx, fy) in
  // [0, 1] across the pixel, interpolated bilinearly from the corner grid (error far
  // below 1e-4 px for lens distortion of real lenses).
  Vec2 grid_point(int px, int py, double fx, double fy) const;

 private:
  CameraTruth truth_;
  Rigid3 cam_from_rig_;
  Rigid3 rig_from_cam_;
  mutable std::vector<Vec2> corners_;
  mutable std::once_flag corners_once_;
};

}  // namespace paintlab::sim
