#pragma once
// The geometric steps of the calibration procedure (calibration/procedure.h) from their
// images to their result: sphere, light and scale read images from files or capture them
// (calibration_capture.h), linearise them with the rig's response, dark and flat as they
// are now, fit (calibration/sphere.h, light.h, scale.h) and record their provenance. The
// caller saves the result and prints result.describe(); `paintlab calibrate STEP` and
// `calibrate all` are this plus their options.
#include <filesystem>
#include <string>
#include <vector>

#include "paintlab/acquisition/calibration_capture.h"
#include "paintlab/calibration/light.h"
#include "paintlab/calibration/rig_calibration.h"
#include "paintlab/calibration/scale.h"
#include "paintlab/calibration/sphere.h"
#include "paintlab/core/json.h"
#include "paintlab/core/rig.h"

namespace paintlab::acq {

// Where a step's images come from: the files given (image files, already expanded), or
// without files, captures through `capture`.
struct StepImages {
  std::vector<std::filesystem::path> files;
  CalibrationRig* capture = nullptr;
  Json devices = Json::object();  // device identities for the provenance (calib::Provenance::make)
};

// How a geometric step captures: what is mounted, whether the LED is lit, and where the
// auto-exposure puts the `quantile` of the sphere's pixels (`fill` of the range).
struct StepCapture {
  Target target = Target::WhiteReference;
  bool led_on = true;
  double fill = 0.7;
  double quantile = 0.999;
};
// sphere: the white reference at 0.7 of the range (99.9 % quantile); light: the glossy
// sphere, its highlight at 0.8 (the brightest pixel); scale: the white reference at 0.7
// (99.99 %). UsageError for another step.
StepCapture step_capture(const std::string& step);

// The step's shots: the files read and linearised with `cal`'s response/dark/flat, or
// captured at `angles_deg` as step_capture(step) says. UsageError when there are neither
// files nor a rig to capture with.
std::vector<Shot> step_shots(const StepImages& in, const calib::RigCalibration& cal, const std::string& step,
                             const std::vector<double>& angles_deg);

// The sphere's centre from its silhouette (needs camera.json; the radius from the rig).
calib::SphereFit sphere_step(const StepImages& in, const calib::RigCalibration& cal, const RigConfig& rig,
                             const std::vector<double>& angles_deg);

// The LED positions from the glossy sphere's highlights (needs camera.json, sphere.json).
calib::LightCalibration light_step(const StepImages& in, const calib::RigCalibration& cal, const RigConfig& rig,
                                   const std::vector<double>& angles_deg);

// The absolute scale from the white reference of certified `albedo` (needs camera.json,
// sphere.json, light.json). The LED profile is fitted only with a flat field (it changes
// the irradiance by as much as the vignetting does). CalibrationError, and no result, when
// more of the reference's lit pixels are clipped than rig.tolerances.saturated_frac.
calib::ScaleCalibration scale_step(const StepImages& in, const calib::RigCalibration& cal, const RigConfig& rig,
                                   const std::vector<double>& angles_deg, double albedo);

}  // namespace paintlab::acq
