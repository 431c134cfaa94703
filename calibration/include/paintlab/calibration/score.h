#pragma once
// A calibration scored against a known truth: the simulator's (`paintlab demo`, the tests) or
// a reference rig's measured by other means. The truth is plain numbers, so the scorer knows
// nothing of where they came from.
//
//   CalibrationTruth t;  t.K = ...;  t.sphere_centre_cam_m = ...;  t.angles_deg / t.led_cam_m = ...;
//   CalibrationScore s = score_calibration(RigCalibration::load(dir), t);
//   s.focal_error_rel, s.light_angle_error_deg, ...   (each present when its files are)
#include <optional>
#include <utility>
#include <vector>

#include "paintlab/calibration/rig_calibration.h"
#include "paintlab/core/geometry.h"
#include "paintlab/core/json.h"

namespace paintlab::calib {

struct CalibrationTruth {
  Mat3 K = Mat3::Identity();                // the camera matrix
  Vec3 sphere_centre_cam_m = Vec3::Zero();  // camera frame
  std::vector<double> angles_deg;           // table angles the light is scored at
  std::vector<Vec3> led_cam_m;              // the LED's true position at each (camera frame)
  // The true inverse response: (raw value above black, linear value), both as fractions of
  // the ADC span above black, ascending in raw value over [0, 1]; empty: not scored.
  std::vector<std::pair<double, double>> inverse_response;
  int adc_bits = 16;
  double black_level_dn = 0.0;
  double adc_max_dn = 65535.0;
};

// Each figure is present when the calibration has the files it needs.
struct CalibrationScore {
  std::optional<double> reprojection_rms_px;     // camera.json's own RMS
  std::optional<double> focal_error_rel;         // (fx - fx_true) / fx_true
  std::optional<double> principal_point_error_px;
  std::optional<double> principal_point_std_px;  // camera.json's own 1-sigma of (cx, cy)
  std::optional<double> sphere_centre_error_mm;
  // Worst over the angles: the angle at the sphere centre between camera and LED (what the
  // BRDF sees; a small rotation of the whole camera frame, which a long lens leaves
  // uncertain, does not change it), calibrated vs true; and the LED direction itself.
  std::optional<double> light_angle_error_deg;
  std::optional<double> light_direction_error_deg;
  std::optional<double> sphere_distance_error_mm;  // |c| calibrated - true
  // Worst |k g(u) / g_true(u) - 1| over the response curve's used range (from 2 % of the
  // span), after the one scale k that fits best (the absolute scale is scale.json's).
  std::optional<double> response_error_rel;
  Json to_json() const;  // the present figures, by these names
};

// Throws DataError when the truth's LED positions do not match its angles.
CalibrationScore score_calibration(const RigCalibration& cal, const CalibrationTruth& truth);

}  // namespace paintlab::calib
