#pragma once
// The simulated rig for the geometric calibration tests: examples/rig-sim.toml (full-size
// 1360x1024 camera, truth that differs from the nominal geometry) with optional changes,
// and helpers that expose its radiance images to raw frames and back to linear values.
#include <algorithm>
#include <string>

#include "paintlab/calibration/camera_model.h"
#include "paintlab/calibration/light.h"
#include "paintlab/calibration/sphere.h"
#include "paintlab/core/config.h"
#include "paintlab/core/rig.h"
#include "paintlab/sim/config.h"
#include "paintlab/sim/paint.h"
#include "paintlab/sim/world.h"
#include "test_util.h"

namespace paintlab::calib::testing {

inline sim::SimConfig sim_rig_config() {
  RigConfig rig = RigConfig::load(test::source_dir() / "examples" / "rig-sim.toml");
  return sim::SimConfig::from_rig(rig);
}

// The world's true camera as a calibration CameraModel.
inline CameraModel truth_camera(const sim::SimWorld& w) {
  CameraModel c;
  c.width_px = w.camera().width();
  c.height_px = w.camera().height();
  c.K = w.K();
  c.dist = w.dist();
  return c;
}

// One exposure of a radiance image whose brightest pixels reach `fill` of the ADC range;
// returns black-level-subtracted values linearised with the sensor's true response (what
// a calibrated response curve gives), in ADC units, and the exposure used.
// `quantile` picks the pixel that reaches `fill`: 0.999 lets a few small highlights clip,
// 1.0 keeps every pixel below saturation.
inline ImageF expose_linear(sim::SimWorld& w, const ImageF& radiance, double fill = 0.7, double* exposure_s = nullptr,
                            Image<std::uint16_t>* raw_out = nullptr, double quantile = 0.999) {
  const auto& sp = w.config().sensor;
  const double span = sp.adc_max_dn() - sp.black_level_dn;
  sim::ExposureSettings es;
  es.exposure_s = 0.01;
  es.frame_index = 1;
  double level = 0;
  for (int tries = 0; tries < 12; ++tries) {  // a clipped probe says nothing: shorten until it is not
    Image<std::uint16_t> probe = w.sensor().expose(radiance, es);
    std::vector<std::uint16_t> v(probe.values());
    const std::size_t q = std::min(v.size() - 1, static_cast<std::size_t>(quantile * static_cast<double>(v.size() - 1)));
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(q), v.end());
    level = v[q] - sp.black_level_dn;
    if (level < 0.9 * span) break;
    es.exposure_s *= 0.1;
  }
  es.exposure_s *= std::clamp(fill * span / std::max(level, 1.0), 0.01, 1000.0);
  es.frame_index = 2;
  Image<std::uint16_t> raw = w.sensor().expose(radiance, es);
  if (exposure_s) *exposure_s = es.exposure_s;
  ImageF out(raw.width(), raw.height(), 1);
  for (std::size_t i = 0; i < raw.size(); ++i) {
    const double x = (raw.values()[i] - sp.black_level_dn) / span;
    out.values()[i] = static_cast<float>(x > 0 ? w.response().inverse(x) * span : x * span);
  }
  if (raw_out) *raw_out = std::move(raw);
  return out;
}

// The simulator's true LED circle in calibration's convention: origin on the table axis at
// the sphere centre's height, x horizontal towards the camera.
inline LightModel truth_light(const sim::SimWorld& w) {
  const Rigid3& cfr = w.cam_from_rig();
  const Vec3 c_rig = w.sphere_centre_rig();
  LightModel m;
  m.axis_cam = cfr.rotation * Vec3::UnitZ();
  m.origin_cam = cfr * Vec3(0.0, 0.0, c_rig.z());
  m.arm_radius_m = w.config().led.arm_radius_m;
  m.arm_height_m = w.config().led.arm_height_m - c_rig.z();
  const Vec3 cam = w.camera().centre_rig();
  m.zero_deg = w.config().led.zero_deg - rad_to_deg(std::atan2(cam.y(), cam.x()));
  m.profile_exponent = w.config().led.profile_exponent;
  return m;
}

// The true sphere as a SphereFit, with the camera blur the sphere step measures here.
inline SphereFit truth_sphere(const sim::SimWorld& w) {
  SphereFit s;
  s.radius_m = w.sphere_radius_m();
  s.centre_cam_m = w.sphere_centre_cam();
  s.edge_sigma_px = w.config().camera.psf_sigma_px;
  return s;
}

}  // namespace paintlab::calib::testing
