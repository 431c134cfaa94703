#pragma once
// The steps of the calibration procedure (calibration/procedure.h) from their images to
// their result. The radiometric steps (dark, response, flat) take an exposure stack read
// from files or capture one (calibration_capture.h); the geometric steps (sphere, light,
// scale) read images from files or capture them, linearise them with the rig's response,
// dark and flat as they are now and fit (calibration/sphere.h, light.h, scale.h). Each
// records its provenance; the caller saves the result and prints result.describe().
// `paintlab calibrate STEP` and `calibrate all` are this plus their options.
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "paintlab/acquisition/calibration_capture.h"
#include "paintlab/calibration/colour.h"
#include "paintlab/calibration/dark.h"
#include "paintlab/calibration/flat.h"
#include "paintlab/calibration/light.h"
#include "paintlab/calibration/response.h"
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

// The camera's intrinsics from chessboard views: the files (8 or 16 bit), or `views` (>= 3)
// captured as the stage shows the board in each.
calib::IntrinsicsResult intrinsics_step(const StepImages& in, const calib::BoardSpec& board,
                                        const calib::IntrinsicsOptions& options, int views);

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

// The colour characterisation from images of a ColorChecker 24: linear RGB EXR files (R, G, B
// channels; `paintlab hdr merge` of a colour stack, or the simulator's render), the chart
// found and measured in each (calibration/colour.h), patch values averaged over the images
// (repeated shots of one set-up), the model fitted; or, without files, one shot of the chart
// the stage shows (Stage::show_chart) through a colour camera, linearised with the rig's
// response, dark and flat. DataError for an image without R, G, B; CalibrationError for a
// monochrome camera or no chart found.
calib::ColourCalibration colour_step(const StepImages& in, const calib::ChartReference& reference,
                                     const calib::ColourFitOptions& options);

// ---- The radiometric steps ----

// Where a radiometric step's frames come from: a stack read from files (exposures known),
// or without one, captures through `capture`, kept in `capture_dir` with exposures.txt.
struct StackImages {
  std::optional<calib::ExposureStack> stack;
  CalibrationRig* capture = nullptr;
  std::filesystem::path capture_dir;
  std::vector<std::filesystem::path> also_read;  // calibration files the step uses (provenance)
  Json devices = Json::object();
};

// The dark frame; captured: `frames` frames (>= 2, read noise needs repeats) at each end of
// the plan's bracket, the lens capped and the LED off.
calib::DarkFrame dark_step(const StackImages& in, const calib::DarkOptions& options, int frames);

struct ResponseStep {
  calib::ResponseCurve curve;
  std::optional<ResponseCapture> captured;  // the bracket, when captured (its stack moved out)
  double constant_ratio = 0.0;              // > 0: the exposures step by this one ratio (say so)
};
// The response curve; captured: `count` (>= 3) exposures of the white reference lit from the
// side at `angle_deg`, bracketed around the brightest pixels (black level: the dark frame's,
// else options.black_dn). `dark`: subtracted per pixel when given.
ResponseStep response_step(const StackImages& in, const calib::ResponseOptions& options, const calib::DarkFrame* dark,
                           double angle_deg, int count);

// The flat field, linearised with `response` and `dark` when given; captured: `frames` (>= 1)
// frames through the diffuser, the LED off.
calib::FlatField flat_step(const StackImages& in, const calib::ResponseCurve* response, const calib::DarkFrame* dark,
                           int frames);

}  // namespace paintlab::acq
