#pragma once
// The pieces `paintlab measure` (and the demo) put together: which calibration the HDR
// merge applies, the camera settings of the plan, the simulated paint on a sim rig, and
// the final report.
#include <filesystem>
#include <memory>
#include <mutex>
#include <optional>

#include "paintlab/acquisition/adaptive.h"
#include "paintlab/acquisition/hdr_merge.h"
#include "paintlab/acquisition/runner.h"
#include "paintlab/acquisition/session.h"
#include "paintlab/core/json.h"
#include "paintlab/core/rig.h"
#include "paintlab/devices/camera.h"
#include "rig_devices.h"

namespace paintlab::app {

struct MeasureSetup {
  acq::HdrCalibration hdr;            // response, dark, flat from the rig's calibration folder
  Json calibration_checksums = Json::object();  // file name -> sha256 of every calib/*.json used
  std::optional<Image<std::uint8_t>> sphere_mask;  // from calib/sphere.json when present
};

// Loads calib/response.json, dark.json (required unless `uncalibrated`) and flat.json
// (optional) from the rig's calibration folder. A missing file is a DataError that says
// which `paintlab calibrate` step makes it. need_sphere_mask: also the sphere's pixels
// (camera.json + sphere.json) for adaptive bracketing.
MeasureSetup prepare_measurement(const RigConfig& rig, bool uncalibrated, bool need_sphere_mask);

struct CameraPreparation {
  dev::PixelFormat format = dev::PixelFormat::Mono16;
  double gain_db = 0.0;  // applied
  dev::ExposureRange range;
};
// Sets the plan's gain and checks that every exposure of the plan is within the camera's
// range (DataError naming the exposure and the range) before anything is written.
CameraPreparation prepare_camera(dev::Camera& camera, const RigConfig& rig);

// The paint of a simulated sphere as JSON (brdf::to_json): from a paint file, or the
// built-in silver metallic when `paint_file` is empty.
Json load_sim_paint_json(const std::string& paint_file);
void apply_sim_paint(RigDevices& devices, const Json& paint_json, const std::filesystem::path& where);

// The runner's merge function: an HdrMerger built on the first bracket's geometry.
class MergeState {
 public:
  MergeState(acq::HdrCalibration calibration, int bit_depth);
  acq::MergeFn function();
  const acq::HdrMerger* merger() const { return merger_.get(); }

 private:
  acq::HdrCalibration calibration_;
  int bit_depth_;
  std::mutex mutex_;
  std::unique_ptr<acq::HdrMerger> merger_;
};

std::unique_ptr<acq::AdaptiveBracketing> make_adaptive_planner(const MeasureSetup& setup, const RigConfig& rig,
                                                                const CameraPreparation& camera);

// Prints the final summary: positions, timing against the physical minimum, retries,
// adaptive savings, and how to resume when the run did not finish.
void print_run_summary(const acq::RunSummary& s, const acq::SessionDir& session);

}  // namespace paintlab::app
