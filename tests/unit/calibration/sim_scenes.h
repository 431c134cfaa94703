#pragma once
// The simulated rig for the geometric calibration tests: examples/rig-sim.toml (full-size
// 1360x1024 camera, truth that differs from the nominal geometry) with optional changes,
// and helpers that expose its radiance images to raw frames and back to linear values.
#include <algorithm>
#include <cstdint>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "paintlab/calibration/camera_model.h"
#include "paintlab/calibration/light.h"
#include "paintlab/calibration/sphere.h"
#include "paintlab/core/config.h"
#include "paintlab/core/rig.h"
#include "paintlab/sim/config.h"
#include "paintlab/sim/paint.h"
#include "paintlab/sim/scenes.h"
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

// Raw values (ADC counts) linearised with the sensor's true response (what a calibrated
// response curve gives), black level subtracted, in ADC units, divided by `exposure_s`
// when it is given. The response is inverted once per ADC code (a table), not per pixel.
inline ImageF linearise_raw(const sim::SimWorld& w, const Image<std::uint16_t>& raw, double exposure_s = 1.0,
                            Image<std::uint8_t>* saturated = nullptr) {
  const auto& sp = w.config().sensor;
  const double span = sp.adc_max_dn() - sp.black_level_dn;
  std::vector<float> table(static_cast<std::size_t>(sp.adc_max_dn()) + 1);
  for (std::size_t dn = 0; dn < table.size(); ++dn) {
    const double x = (static_cast<double>(dn) - sp.black_level_dn) / span;
    table[dn] = static_cast<float>((x > 0 ? w.response().inverse(x) * span : x * span) / exposure_s);
  }
  ImageF out(raw.width(), raw.height(), 1);
  if (saturated) *saturated = Image<std::uint8_t>(raw.width(), raw.height(), 1, 0);
  for (std::size_t i = 0; i < raw.size(); ++i) {
    const std::uint16_t dn = std::min<std::uint16_t>(raw.values()[i], static_cast<std::uint16_t>(table.size() - 1));
    out.values()[i] = table[dn];
    if (saturated) saturated->values()[i] = raw.values()[i] >= sp.adc_max_dn() ? 1 : 0;
  }
  return out;
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
  ImageF out = linearise_raw(w, raw);
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

// `count` poses of a dense chessboard that fills most of the view (70-95 % of the image
// width), tilted 20-45 deg in varied directions and rolled up to 20 deg, the whole printed
// area inside the image with a 2 % margin: the views that pin down the principal point of a
// long lens (its information comes from the perspective across the field and so grows with
// the number of corners and the field they cover, not with more views of a small board).
inline std::vector<Rigid3> view_filling_board_poses(const sim::CameraModel& camera, const sim::Chessboard& board,
                                                    int count, std::uint64_t seed) {
  const double w = camera.width(), h = camera.height(), margin_px = 0.02 * std::min(w, h);
  const Vec2 lo = board.outline_lo(), hi = board.outline_hi();
  const Vec3 centre_board(0.5 * (lo.x() + hi.x()), 0.5 * (lo.y() + hi.y()), 0.0);
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  std::vector<Rigid3> poses;
  for (int attempt = 0; static_cast<int>(poses.size()) < count; ++attempt) {
    if (attempt > 200 * count) throw std::runtime_error("view_filling_board_poses: the board does not fit the image");
    const double fill = 0.7 + 0.25 * u01(rng);
    const double distance = camera.truth().fx_px * (hi.x() - lo.x()) / (fill * w);
    const double tilt = deg_to_rad(20.0 + 25.0 * u01(rng)), dir = 2.0 * kPi * u01(rng);
    const double roll = deg_to_rad(40.0 * (u01(rng) - 0.5));
    const double cu = 0.5 * w + (u01(rng) - 0.5) * (1.0 - fill) * w;
    const double cv = 0.5 * h + (u01(rng) - 0.5) * (1.0 - fill) * h;
    Rigid3 pose;
    pose.rotation = Eigen::AngleAxisd(tilt * std::cos(dir), Vec3::UnitX()) *
                    Eigen::AngleAxisd(tilt * std::sin(dir), Vec3::UnitY()) * Eigen::AngleAxisd(roll, Vec3::UnitZ());
    const Vec3 ray = camera.ray_cam(Vec2(cu, cv));
    pose.translation = ray * (distance / ray.z()) - pose.rotation * centre_board;
    bool fits = true;
    for (int k = 0; k < 4 && fits; ++k) {
      const Vec3 pc = pose * Vec3((k & 1) ? hi.x() : lo.x(), (k & 2) ? hi.y() : lo.y(), 0.0);
      const Vec2 px = camera.project(pc);
      fits = pc.z() > 0 && px.x() >= margin_px && px.y() >= margin_px && px.x() <= w - 1 - margin_px &&
             px.y() <= h - 1 - margin_px;
    }
    if (fits) poses.push_back(pose);
  }
  return poses;
}

}  // namespace paintlab::calib::testing
