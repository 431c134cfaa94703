#pragma once
// Small simulated worlds and analytic BRDFs for the sim tests.
#include <array>
#include <cmath>

#include "paintlab/brdf/brdf.h"
#include "paintlab/core/rig.h"
#include "paintlab/sim/config.h"

namespace paintlab::sim::test {

// A 320 x 240 camera 1.2 m from a 40 mm sphere; focal length chosen per test.
inline SimConfig small_config(double focal_length_mm = 12.0, int width = 320, int height = 240) {
  RigGeometry g;
  g.sphere_radius_m = 0.04;
  g.arm_radius_m = 0.5;
  g.arm_height_m = 0.0;
  g.camera_distance_m = 1.2;
  g.camera_height_m = 0.05;
  g.focal_length_mm = focal_length_mm;
  g.pixel_size_um = 6.45;
  g.image_width_px = width;
  g.image_height_px = height;
  return SimConfig::defaults(g);
}

// The small rig's 8 mm camera with these intrinsics (px) and OpenCV distortion.
inline CameraTruth camera_with(double fx, double fy, double cx, double cy, const std::array<double, 5>& dist) {
  CameraTruth t = small_config(8.0).camera;
  t.fx_px = fx;
  t.fy_px = fy;
  t.cx_px = cx;
  t.cy_px = cy;
  t.dist = dist;
  return t;
}

// f = kd / pi + ks * D(theta_h) / (4 cos_i cos_o) with a Beckmann D of roughness m: an
// analytic microfacet-style lobe the tests evaluate themselves.
class TestLobeBrdf final : public brdf::Brdf {
 public:
  TestLobeBrdf(double kd, double ks, double m) : kd_(kd), ks_(ks), m_(m) {}
  static double beckmann(double cos_h, double m) {
    double c2 = cos_h * cos_h;
    double tan2 = (1.0 - c2) / c2;
    return std::exp(-tan2 / (m * m)) / (3.14159265358979323846 * m * m * c2 * c2);
  }
  double value(const Eigen::Vector3d& wi, const Eigen::Vector3d& wo) const {
    if (wi.z() <= 0 || wo.z() <= 0) return 0.0;
    Eigen::Vector3d h = (wi + wo).normalized();
    return kd_ / 3.14159265358979323846 + ks_ * beckmann(h.z(), m_) / (4.0 * wi.z() * wo.z());
  }
  brdf::Rgb eval(const Eigen::Vector3d& wi, const Eigen::Vector3d& wo) const override {
    double v = value(wi, wo);
    return brdf::Rgb(v, 0.8 * v, 0.6 * v);
  }
  std::string model() const override { return "test-lobe"; }

 private:
  double kd_, ks_, m_;
};

}  // namespace paintlab::sim::test
