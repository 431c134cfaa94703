#pragma once
// SimWorld: the physical truth of the simulated rig (DESIGN.md "Simulation") and its
// image formation. It holds the sphere (radius, centre, paint, flake field), the
// turntable angle, the LED (position from the angle, emission profile, intensity, on/off),
// the camera (pose, intrinsics, distortion, vignetting), the sensor, the felt-covered
// surroundings (table, pedestal and the LED arm below the equator, backdrop) and the
// virtual clock. The simulated device peers change its state and render through it; the
// truth accessors are what calibration tests compare against.
//
// Rendering is two passes: render() gives scene radiance per pixel (W sr^-1 m^-2, linear
// camera RGB or mono), Sensor::expose() turns it into raw values for one exposure, so one
// render serves a whole exposure bracket. Per pixel: the camera ray hits the sphere, n,
// wi towards the LED (inverse-square distance, emission profile), wo towards the camera,
// L = f(wi, wo) I(wi) cos(theta_i) / d^2. Silhouette pixels are supersampled (coverage
// edge_samples^2, shading edge_shading_samples^2), so the edge is sub-pixel accurate;
// interior pixels whose centre value is not their mean (a highlight a few pixels across,
// the terminator) are integrated over the pixel (interior_samples^2).
// Flakes modulate the part of f they carry (flakes.h). Not simulated: interreflections,
// the LED housing, shadows other than the sphere's, antialiasing of the arm's edges.
#include <atomic>
#include <memory>
#include <mutex>
#include <optional>

#include "paintlab/brdf/brdf.h"
#include "paintlab/core/image.h"
#include "paintlab/sim/camera_model.h"
#include "paintlab/sim/config.h"
#include "paintlab/sim/flakes.h"
#include "paintlab/sim/sensor.h"
#include "paintlab/sim/virtual_clock.h"

namespace paintlab::sim {

// Sparkle of a paint: flakes carry `flake_part` of its BRDF and scatter it into glints
// whose average is flake_part again.
struct Sparkle {
  double density = 0.5;       // flakes per pixel footprint at the reference distance
  double roughness = 0.15;    // Beckmann m of the flake normals
  double lifetime_deg = 6.5;  // a flake glints while angle(normal, h) < lifetime
  FlakeColour colour;         // the flakes' own colour (flakes.h); default grey
  std::shared_ptr<const brdf::Brdf> flake_part;
  // Optional: the rest of the BRDF (brdf - flake_part), which makes rendering faster.
  std::shared_ptr<const brdf::Brdf> steady_part;
};

struct SimPaint {
  std::shared_ptr<const brdf::Brdf> brdf;
  std::optional<Sparkle> sparkle;
};

struct RenderOptions {
  bool mono = true;     // one channel: CameraTruth::mono_weights . RGB; false: RGB
  bool sparkle = true;  // flake glints when the paint has flakes (false: the smooth BRDF)
  int threads = 0;      // 0 = all cores
};

class SimWorld {
 public:
  explicit SimWorld(const SimConfig& config);
  ~SimWorld();
  SimWorld(const SimWorld&) = delete;
  SimWorld& operator=(const SimWorld&) = delete;

  const SimConfig& config() const { return config_; }
  const CameraModel& camera() const { return *camera_; }
  Sensor& sensor() { return *sensor_; }
  const Sensor& sensor() const { return *sensor_; }
  VirtualClock& clock() { return clock_; }

  // The scene radiance (W/(m^2 sr)) at which the image centre collects `fill` of the sensor's
  // full well in `exposure_s`, and the irradiance (W/m^2) at which a Lambertian target of
  // `albedo` shows that radiance: how bright a board, a diffuser or a flat field is lit.
  double radiance_for_fill(double fill, double exposure_s) const;
  double irradiance_for_fill(double fill, double exposure_s, double albedo) const;

  // The sphere's paint (default: grey Lambertian, albedo 0.5). Building the flake field of
  // a sparkling paint takes a moment; rendering threads keep the paint they started with.
  void set_paint(SimPaint paint);
  SimPaint paint() const;

  // State, thread-safe.
  void set_table_angle_deg(double angle_deg) { table_angle_deg_.store(angle_deg); }
  double table_angle_deg() const { return table_angle_deg_.load(); }
  void set_led_on(bool on) { led_on_.store(on); }
  bool led_on() const { return led_on_.load(); }

  // --- Truth ---
  Mat3 K() const { return config_.camera.K(); }
  const std::array<double, 5>& dist() const { return config_.camera.dist; }
  const Rigid3& cam_from_rig() const { return camera_->cam_from_rig(); }
  double sphere_radius_m() const { return config_.sphere.radius_m; }
  Vec3 sphere_centre_rig() const { return config_.sphere.centre_rig_m; }
  Vec3 sphere_centre_cam() const { return cam_from_rig() * sphere_centre_rig(); }
  Vec3 led_position_rig(double table_angle_deg) const;
  Vec3 led_position_cam(double table_angle_deg) const { return cam_from_rig() * led_position_rig(table_angle_deg); }
  // Unit LED axis (rig frame) at a table angle.
  Vec3 led_axis_rig(double table_angle_deg) const;
  // On-axis radiant intensity (W/sr) and the relative profile at an angle off the axis.
  double led_intensity_w_sr() const { return config_.led.intensity_w_sr; }
  double led_profile(double off_axis_rad) const;
  // RGB radiant intensity (W/sr) the LED sends towards a rig point at a table angle.
  brdf::Rgb led_radiant_intensity(double table_angle_deg, const Vec3& point_rig) const;
  const ResponseCurve& response() const { return sensor_->response(); }
  // Expected flakes per pixel footprint: the reference footprint is (d / fx) (d / fy)
  // with d the distance from the camera centre to the sphere centre.
  double reference_footprint_m2() const;

  // --- Rendering ---
  // Radiance of the current state (table angle, LED on/off, paint).
  ImageF render(const RenderOptions& options = {}) const;
  // Radiance at a table angle with the LED on or off and the current paint.
  ImageF render_at(double table_angle_deg, bool led_on, const RenderOptions& options = {}) const;
  // Radiance with another paint on the sphere (e.g. the white reference sphere).
  ImageF render_with(const SimPaint& paint, double table_angle_deg, bool led_on,
                     const RenderOptions& options = {}) const;
  // Fraction of each pixel covered by the sphere (1 inside, 0 outside, in between at the
  // supersampled silhouette); the arm is ignored.
  ImageF sphere_coverage() const;
  // Render of the current state and one exposure of it.
  Image<std::uint16_t> capture(const ExposureSettings& exposure, const RenderOptions& options = {});

 private:
  struct Scene;
  struct PaintState;
  std::shared_ptr<const PaintState> make_paint_state(SimPaint paint) const;
  ImageF render_impl(const PaintState& paint, double angle_deg, bool led_on, const RenderOptions& options) const;

  SimConfig config_;
  std::unique_ptr<CameraModel> camera_;
  std::unique_ptr<Sensor> sensor_;
  VirtualClock clock_;
  std::unique_ptr<Scene> scene_;
  mutable std::mutex paint_mutex_;
  std::shared_ptr<const PaintState> paint_;
  std::atomic<double> table_angle_deg_{0.0};
  std::atomic<bool> led_on_{true};
};

}  // namespace paintlab::sim
