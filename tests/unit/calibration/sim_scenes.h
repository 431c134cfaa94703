#pragma once
// The simulated rig for the geometric calibration tests: examples/rig-sim.toml (full-size
// 1360x1024 camera, truth that differs from the nominal geometry) with optional changes,
// and helpers that expose its radiance images to raw frames and back to linear values.
#include <algorithm>
#include <string>

#include "paintlab/calibration/camera_model.h"
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
inline ImageF expose_linear(sim::SimWorld& w, const ImageF& radiance, double fill = 0.7, double* exposure_s = nullptr,
                            Image<std::uint16_t>* raw_out = nullptr) {
  const auto& sp = w.config().sensor;
  sim::ExposureSettings es;
  es.exposure_s = 0.01;
  es.frame_index = 1;
  Image<std::uint16_t> raw = w.sensor().expose(radiance, es);
  std::vector<std::uint16_t> v(raw.values());
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() * 999 / 1000), v.end());
  const double p999 = v[v.size() * 999 / 1000] - sp.black_level_dn;
  es.exposure_s *= std::clamp(fill * (sp.adc_max_dn() - sp.black_level_dn) / std::max(p999, 1.0), 0.01, 1000.0);
  es.frame_index = 2;
  raw = w.sensor().expose(radiance, es);
  if (exposure_s) *exposure_s = es.exposure_s;
  ImageF out(raw.width(), raw.height(), 1);
  const double span = sp.adc_max_dn() - sp.black_level_dn;
  for (std::size_t i = 0; i < raw.size(); ++i) {
    const double x = (raw.values()[i] - sp.black_level_dn) / span;
    out.values()[i] = static_cast<float>(x > 0 ? w.response().inverse(x) * span : x * span);
  }
  if (raw_out) *raw_out = std::move(raw);
  return out;
}

}  // namespace paintlab::calib::testing
