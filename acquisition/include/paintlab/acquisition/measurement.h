#pragma once
// Setting up a measurement (docs/measurement.md): which calibration the HDR merge applies,
// the camera settings of the plan checked before anything is written, the session manifest,
// the runner's merge function and the adaptive-bracketing planner. `paintlab measure` and
// `paintlab demo` put these together with the devices app/ opens.
#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include "paintlab/acquisition/adaptive.h"
#include "paintlab/acquisition/hdr_merge.h"
#include "paintlab/acquisition/runner.h"
#include "paintlab/acquisition/session.h"
#include "paintlab/core/image.h"
#include "paintlab/core/json.h"
#include "paintlab/core/rig.h"
#include "paintlab/devices/camera.h"

namespace paintlab::acq {

struct MeasureSetup {
  HdrCalibration hdr;                              // response, dark, flat from the rig's calibration folder
  Json calibration_checksums = Json::object();     // file name -> sha256 of every calib/*.json present
  std::optional<Image<std::uint8_t>> sphere_mask;  // from calib/sphere.json when asked for
};

// Loads calib/response.json, dark.json (required unless `uncalibrated`) and flat.json
// (optional) from the rig's calibration folder, and the checksums of every calibration file
// present. A missing file is a DataError that says which `paintlab calibrate` step makes it.
// need_sphere_mask: also the sphere's pixels (camera.json + sphere.json) for adaptive
// bracketing.
MeasureSetup prepare_measurement(const RigConfig& rig, bool uncalibrated, bool need_sphere_mask);

struct CameraPreparation {
  dev::PixelFormat format = dev::PixelFormat::Mono16;
  double gain_db = 0.0;  // applied
  dev::ExposureRange range;
};
// Sets the plan's gain and checks that every exposure of the plan is within the camera's
// range (DataError naming the exposure, the range and the camera) before anything is written.
CameraPreparation prepare_camera(dev::Camera& camera, const RigConfig& rig);

// What a new session records (session.json): the sample and the people's notes, the rig
// and its plan, the applied gain, the calibration checksums, the devices and the options.
struct ManifestInput {
  std::string sample;
  std::string notes;
  std::string operator_name;
  Json devices = Json::object();  // role -> {"id", "serial"}
  SessionOptions options;  // pixel_format is the camera's (make_manifest sets it)
};
SessionManifest make_manifest(const RigConfig& rig, const MeasureSetup& setup, const CameraPreparation& camera,
                              const ManifestInput& input);

// The runner's merge function: an HdrMerger built on the first bracket's geometry and shared
// by every later bracket; each merged image carries its valid and saturated pixel counts as
// attributes.
class BracketMerger {
 public:
  BracketMerger(HdrCalibration calibration, int bit_depth);
  MergeFn function();
  const HdrMerger* merger() const { return merger_.get(); }

 private:
  HdrCalibration calibration_;
  int bit_depth_;
  std::mutex mutex_;
  std::unique_ptr<HdrMerger> merger_;
};

// The adaptive-bracketing planner for the camera and calibration of a measurement: the
// response's floor and saturation in linear units and its noise model.
std::unique_ptr<AdaptiveBracketing> make_adaptive_planner(const MeasureSetup& setup, const CameraPreparation& camera);

}  // namespace paintlab::acq
