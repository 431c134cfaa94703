#include "paintlab/calibration/procedure.h"

#include <fmt/format.h>

#include <cmath>
#include <sstream>

#include "paintlab/calibration/record.h"
#include "paintlab/calibration/rig_calibration.h"
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

std::vector<double> parse_angles(const std::string& text, const std::string& option) {
  std::vector<double> out;
  auto num = [&](const std::string& s) {
    try {
      std::size_t used = 0;
      const double v = std::stod(s, &used);
      if (used != s.size() || !std::isfinite(v)) throw std::invalid_argument(s);
      return v;
    } catch (const std::exception&) {
      throw UsageError(option + " '" + text + "': '" + s + "' is not a number of degrees");
    }
  };
  std::vector<std::string> parts;
  const char sep = text.find(':') != std::string::npos ? ':' : ',';
  std::stringstream ss(text);
  for (std::string p; std::getline(ss, p, sep);) parts.push_back(p);
  if (sep == ':') {
    if (parts.size() != 3) throw UsageError(option + " '" + text + "': expected START:STOP:STEP");
    const double a = num(parts[0]), b = num(parts[1]), st = num(parts[2]);
    if (!(st > 0) || b < a) throw UsageError(option + " '" + text + "': need STEP > 0 and STOP >= START");
    if ((b - a) / st > 3600) throw UsageError(option + " '" + text + "': more than 3600 angles");
    for (double v = a; v <= b + 1e-9; v += st) out.push_back(v);
  } else {
    for (const std::string& p : parts) out.push_back(num(p));
  }
  if (out.empty()) throw UsageError(option + ": no angles given");
  return out;
}

void require_step_inputs(const std::filesystem::path& calibration_dir, const std::string& step,
                         const std::filesystem::path& rig_file) {
  std::string missing;
  for (const std::string& f : procedure_step(step).needs)
    if (!std::filesystem::exists(calibration_dir / f))
      missing += fmt::format("\n  {}: run `paintlab calibrate {} --rig {}` first", (calibration_dir / f).string(),
                             calibrate_step_for(f), rig_file.string());
  if (!missing.empty()) throw CalibrationError("calibrate " + step + " needs what the calibration folder lacks:" + missing);
}

}  // namespace paintlab::calib
