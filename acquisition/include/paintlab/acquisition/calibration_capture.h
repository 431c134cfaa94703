#pragma once
// The capture side of the calibration steps and of the live rig check (docs/calibration.md,
// docs/radiometry.md): what each step puts in front of the camera, where it turns the table,
// how it exposes, what it keeps. The steps' computations are calibration/'s (dark.h,
// response.h, flat.h, intrinsics.h, sphere.h, light.h, scale.h, check.h); app/ opens the
// devices and the stage (the simulator or a technician at the console) and prints results.
#include <filesystem>
#include <string>
#include <vector>

#include "paintlab/acquisition/capture.h"
#include "paintlab/calibration/check.h"
#include "paintlab/calibration/exposure_stack.h"
#include "paintlab/calibration/intrinsics.h"
#include "paintlab/calibration/light.h"
#include "paintlab/calibration/rig_calibration.h"
#include "paintlab/calibration/scale.h"
#include "paintlab/core/rig.h"

namespace paintlab::acq {

// The rig as the calibration steps capture through it: the devices, what stands in front of
// the camera, the shot capture (captures/<step>/) and the linearizer of the rig's current
// response/dark/flat. Nothing here is owned.
struct CalibrationRig {
  dev::Camera* camera = nullptr;
  dev::Light* light = nullptr;
  dev::Turntable* table = nullptr;  // null: no step may ask for a table angle
  Clock* clock = nullptr;
  Stage* stage = nullptr;
  ShotCapture* shots = nullptr;
  Linearizer* linearizer = nullptr;
  double gain_db = 0.0;            // the plan's gain
  std::vector<double> exposures_s;  // the plan's bracket (the dark frames are taken at its ends)
  double settle_s = 0.0;           // wait after a table move

  Shot shot(const ShotRequest& request) { return shots->capture(request, *linearizer); }
};

// ---- The radiometric steps: exposure stacks ----

// Exposure times from min to max whose successive ratios are not all equal (a geometric
// bracket times 1, 1.37, 1.71, 1, ...): a constant ratio leaves the response ambiguous.
// UsageError unless 0 < min < max and count >= 3.
std::vector<double> calibration_bracket(double min_s, double max_s, int count);

// True (and the ratio) when the sorted exposures step by one ratio within 2 %.
bool constant_ratio(std::vector<double> exposures_s, double* ratio);

// Dark frames: the lens capped, the LED off, `frames` frames at the shortest and at the
// longest exposure of the plan, saved in `save_dir`; the lens uncovered afterwards.
calib::ExposureStack capture_dark_stack(CalibrationRig& rig, int frames, const std::filesystem::path& save_dir);

// Where the brightest pixels (the 99.9 % quantile) of the white reference sit when the
// response bracket is anchored, as a share of the range above black.
inline constexpr double kResponseTopFill = 0.7;

struct ResponseCapture {
  double top_s = 0.0;  // exposure at which the brightest pixels reach kResponseTopFill
  double min_s = 0.0, max_s = 0.0;  // the bracket: top / 32 .. top x 8 within the camera's range
  calib::ExposureStack stack;
};
// The response stack: the white reference lit from the side at `angle_deg`, so that every
// exposure of a bracket with unequal steps holds values from saturation down to black.
// `black_dn`: the black level (the dark frame's mean bias). CalibrationError when the
// camera's exposure range leaves no bracket (max < 4 x min) around the anchor.
ResponseCapture capture_response_stack(CalibrationRig& rig, double angle_deg, double black_dn, int count,
                                       const std::filesystem::path& save_dir);

// Flat-field frames: the diffuser over the lens, the LED off, `frames` frames at the exposure
// that puts the brightest pixels at 60 % of the range above `black_dn`; the lens uncovered
// afterwards.
calib::ExposureStack capture_flat_stack(CalibrationRig& rig, double black_dn, int frames,
                                        const std::filesystem::path& save_dir);

// ---- The geometric steps: shots ----

struct BoardViews {
  std::vector<calib::BoardImage> images;
  std::vector<std::filesystem::path> files;  // the saved captures, in view order
};
// `views` chessboard views (the stage shows each), LED off, the board's white at 60 % of the
// range (99 % quantile); the sample is mounted again afterwards.
BoardViews capture_board_views(CalibrationRig& rig, const calib::BoardSpec& board, int views);

// One shot of step `step` at each table angle, `target` mounted, named "<step>_angle<a>".
std::vector<Shot> capture_shots(CalibrationRig& rig, const std::string& step, const std::vector<double>& angles_deg,
                                Target target, bool led_on, double fill, double quantile);

// A shot as the light step reads it: clipped pixels +inf (left out of the lobe fit).
// UsageError naming the file when its table angle is unknown (not in the file name).
calib::HighlightImage highlight_image(const Shot& shot, const std::string& step);
// A shot as the scale step reads it. UsageError naming the file when the table angle or the
// exposure (the rate is then not per second) is not in the file name.
calib::ReferenceImage reference_image(const Shot& shot, const std::string& step);

// ---- The live check ----

// What the live part of `paintlab check` found, and the live checks that could not run
// (each a failed item saying why and what to do).
struct LiveCheck {
  calib::LiveEvidence evidence;
  std::vector<calib::CheckItem> failed;
};

// The live evidence captured now: the white reference at 0 deg (saturation, the first drift
// frame), side-lit at 90 and 270 deg (the sphere's silhouette and edge), the glossy sphere at
// -60, 0 and 60 deg when light.json exists (the highlights), the reference at 0 deg again at
// the first frame's exposure (LED drift); the sample is mounted afterwards. Needs camera.json
// and sphere.json (else one failed item says so).
LiveCheck capture_live_check(CalibrationRig& rig, const calib::RigCalibration& cal, const RigConfig& config);

// The same evidence from a folder of images: sphere/, light/, drift/ (two or more at one
// angle and exposure), reference/, each optional. CalibrationError without camera.json and
// sphere.json.
LiveCheck live_check_from_images(const std::filesystem::path& dir, const calib::RigCalibration& cal,
                                 const RigConfig& config, Linearizer& linearizer);

// The fraction of the sphere's pixels (as the calibration sees it) that are clipped in `shot`.
double saturated_on_sphere(const Shot& shot, const calib::CameraModel& camera, const calib::SphereFit& sphere);

}  // namespace paintlab::acq
