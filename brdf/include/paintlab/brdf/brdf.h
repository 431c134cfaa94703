#pragma once
// The one interface every reflectance model implements (models.md). Directions are unit
// vectors in the local shading frame (normal n = +z): wi towards the light, wo towards
// the camera. eval() returns the BRDF in 1/sr as linear camera RGB; it returns zero when
// either direction is below the horizon (z <= 0).
#include <Eigen/Core>
#include <memory>
#include <string>

namespace paintlab::brdf {

using Rgb = Eigen::Array3d;
using Vec3 = Eigen::Vector3d;

class Brdf {
 public:
  virtual ~Brdf() = default;
  virtual Rgb eval(const Vec3& wi, const Vec3& wo) const = 0;
  // The paint file's model name: "cook-torrance", "axf-carpaint", "layered-pearlescent",
  // "merl", "lambertian".
  virtual std::string model() const = 0;
};

// A Lambertian surface of RGB albedo rho: f = rho / pi. The reference white target of
// the scale calibration.
class Lambertian final : public Brdf {
 public:
  explicit Lambertian(const Rgb& albedo) : albedo_(albedo) {}
  Rgb eval(const Vec3& wi, const Vec3& wo) const override {
    if (wi.z() <= 0 || wo.z() <= 0) return Rgb::Zero();
    return albedo_ * (1.0 / 3.14159265358979323846);
  }
  std::string model() const override { return "lambertian"; }
  const Rgb& albedo() const { return albedo_; }

 private:
  Rgb albedo_;
};

}  // namespace paintlab::brdf
