#pragma once
// What `paintlab calibrate` and `paintlab check` share: the rig's devices opened with the
// stage that goes with them (acq::Stage: a technician at the keyboard on a real rig, the
// simulator on a simulated one), images from files or captured (acq::ShotCapture) and
// linearised with the rig's response/dark/flat, kept in calib/captures/.
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "paintlab/acquisition/calibration_capture.h"
#include "paintlab/acquisition/capture.h"
#include "paintlab/acquisition/hdr_merge.h"
#include "paintlab/calibration/chessboard.h"
#include "paintlab/core/image.h"
#include "paintlab/core/json.h"
#include "paintlab/core/rig.h"
#include "paintlab/devices/camera.h"
#include "paintlab/fitting/output_guard.h"
#include "rig_devices.h"

namespace paintlab::app {

using acq::Shot;
using acq::Target;

// Opened devices, the radiometric calibration to linearise with, the device serials.
struct CalibSession {
  RigConfig rig;
  std::unique_ptr<RigDevices> devices;
  std::unique_ptr<acq::Stage> stage;
  acq::Linearizer linearizer;              // the rig's response/dark/flat as they are now
  std::unique_ptr<acq::ShotCapture> shots;  // captures into calib/captures/
  Json serials = Json::object();
  int bit_depth = 16;

  dev::Camera& camera() { return *devices->camera; }
  // The devices, the stage, the shot capture and the linearizer as the calibration steps
  // capture through them (acq::capture_* in calibration_capture.h).
  acq::CalibrationRig capture_rig();
};

// Opens the rig's devices (simulated peers for kind "sim") and the stage that goes with
// them. albedo: the reference's albedo for a simulated stage (0: 0.99).
CalibSession open_calib_session(const RigConfig& rig, double albedo);
// Loads response/dark/flat that exist (for files given with --images, no devices).
acq::HdrCalibration load_radiometry(const RigConfig& rig);

// Device identities recorded in provenance: {"camera": serial, "turntable": id, "light": id}
// (turntable and light: kind and address, left out for simulated peers).
Json device_serials(RigDevices& d, const RigConfig& rig);

// What a calibration step runs with: the rig, and the devices when capturing, or a folder
// of images (one subfolder per step) for `paintlab calibrate all --images DIR`.
struct CalibrateContext {
  RigConfig rig;
  bool has_rig = false;                             // false: files only (intrinsics, dark, response, flat)
  std::vector<std::string> images;                  // --images as given (a step on its own)
  std::filesystem::path out;                        // --out; empty: the rig's calibration folder
  CalibSession* session = nullptr;                 // capturing
  std::optional<std::filesystem::path> images_dir;  // or images from files
  double albedo = 0.0;                              // the reference's (scale)
  std::string k3;                                   // intrinsics: "fix", "free", or empty (decided from the data)
  acq::CalibrationRig capture;                      // the session's devices as a step captures through them
};

// The files the calibration steps `steps` write (each .json, and the .exr beside dark's and
// flat's) checked before any device opens against what they read: `guard`'s inputs (images,
// exposure file, calibration files used) and the rig file. `out`: the one step's --out; empty:
// the rig's calibration folder. UsageError naming the flag.
void check_step_outputs(fit::OutputGuard guard, const std::string& rig_file, const std::vector<std::string>& steps,
                        const std::filesystem::path& out = {});

}  // namespace paintlab::app
