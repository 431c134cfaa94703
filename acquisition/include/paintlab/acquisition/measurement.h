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
#include "paintlab/acquisition/demosaic.h"
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
// A resumed session goes on with the pixel format it started with (a colour session does not
// take monochrome frames, nor a 12-bit one 8-bit frames): DataError naming both and `session_dir`.
void check_resume_camera(const SessionManifest& session, const CameraPreparation& camera,
                         const std::string& session_dir);

// What a colour camera's session stores (docs/colour.md "Measuring in colour"): the merged
// mosaic demosaiced (bilinear, with its variance), white-balanced on the white reference
// (camera channel c times scale / scale_rgb[c] of calib/scale.json, so that the white
// reference is grey and one scale still turns radiance into BRDF) and mapped to linear sRGB
// (D65) by calib/colour.json. `uncalibrated`: camera RGB as it is. DataError for a colour camera
// without colour.json or without a per-channel scale.json, naming the `paintlab calibrate`
// step that makes it. A monochrome camera behind the rig's filter wheel takes the same
// (pattern None: every channel is sampled at every pixel); without a wheel nothing to do.
ColourMap prepare_colour(const RigConfig& rig, dev::PixelFormat format, bool uncalibrated);

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
// attributes. A colour camera's bracket (colour.pattern set) is merged as a mosaic and then
// turned into R, G, B by demosaic_to_colour; the last merged mosaic is kept for the planner.
// A filter-wheel camera's frames (FrameMeta::filter set) are merged per filter and mapped by
// `colour` (map_colour).
class BracketMerger {
 public:
  BracketMerger(HdrCalibration calibration, int bit_depth, ColourMap colour = {});
  MergeFn function();
  const HdrMerger* merger() const { return merger_.get(); }
  // The radiance mosaic of the last merged bracket (Y, valid), before demosaicing; null for a
  // monochrome camera or before the first bracket.
  std::shared_ptr<const ExrImage> last_mosaic() const;
  // A filter-wheel camera's last merge through filter c (0 R, 1 G, 2 B: Y, valid), before the
  // colour map; null before the first position.
  std::shared_ptr<const ExrImage> last_filter_merge(int c) const;

 private:
  // A filter-wheel camera's position (frames carrying FrameMeta::filter): one merge per
  // filter, then the colour map (map_colour).
  ExrImage merge_per_filter(const std::vector<dev::Frame>& frames);

  HdrCalibration calibration_;
  int bit_depth_;
  ColourMap colour_;
  mutable std::mutex mutex_;
  std::unique_ptr<HdrMerger> merger_;
  std::shared_ptr<const ExrImage> last_mosaic_;
  std::array<std::shared_ptr<const ExrImage>, 3> last_filter_{};
};

// The adaptive-bracketing planner for the camera and calibration of a measurement: the
// response's floor and saturation in linear units and its noise model. A colour camera's
// planner predicts from `merger`'s last mosaic: every site planned as the pixel it is, so each
// colour channel keeps the exposures it needs (required then); with `filter_wheel`, each
// filter's bracket from that filter's last merge.
std::unique_ptr<AdaptiveBracketing> make_adaptive_planner(const MeasureSetup& setup, const CameraPreparation& camera,
                                                          const BracketMerger* merger = nullptr,
                                                          bool filter_wheel = false);

}  // namespace paintlab::acq
