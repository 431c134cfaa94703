#include "paintlab/calibration/procedure.h"

#include "paintlab/calibration/record.h"
#include "paintlab/core/error.h"

namespace paintlab::calib {

const std::vector<ProcedureStep>& calibration_procedure() {
  static const std::vector<ProcedureStep> steps = {
      {"intrinsics", kCameraFile, {}, {}, "the chessboard, held in a different tilt for each view", false, "",
       "Camera intrinsics from chessboard views (writes camera.json)"},
      {"dark", kDarkFile, {}, {}, "the lens cap", false, "",
       "Dark frame (black level per pixel, dark current, read noise) and hot pixels (writes dark.json + dark.exr)"},
      {"response", kResponseFile, {}, {kDarkFile}, "the white reference sphere, lit from the side", true, "90",
       "Camera response curve from an exposure stack (Robertson's or Debevec's method; writes response.json)"},
      {"flat", kFlatFile, {}, {kResponseFile, kDarkFile}, "the diffuser over the lens (or a uniformly lit white target)",
       false, "", "Flat field (vignetting and pixel gain) from images of a uniform target (writes flat.json + flat.exr)"},
      {"sphere", kSphereFile, {kCameraFile}, {kResponseFile, kDarkFile, kFlatFile},
       "the white reference sphere, the LED beside it", true, "90,270",
       "Sphere centre from its silhouette, LED beside it (writes sphere.json)"},
      {"light", kLightFile, {kCameraFile, kSphereFile}, {kResponseFile, kDarkFile, kFlatFile},
       "the glossy calibration sphere", true, "-150:150:10",
       "LED positions from highlights on a glossy sphere (writes light.json)"},
      {"scale", kScaleFile, {kCameraFile, kSphereFile, kLightFile}, {kResponseFile, kDarkFile, kFlatFile},
       "the white reference sphere", true, "-40,0,40",
       "Absolute BRDF scale from the white reference sphere (writes scale.json)"},
  };
  return steps;
}

const ProcedureStep& procedure_step(std::string_view name) {
  std::string names;
  for (const ProcedureStep& s : calibration_procedure()) {
    if (s.name == name) return s;
    names += (names.empty() ? "" : ", ") + s.name;
  }
  throw UsageError("no calibration step '" + std::string(name) + "' (the steps: " + names + ")");
}

}  // namespace paintlab::calib
