#include "paintlab/acquisition/calibration_steps.h"

#include <fmt/format.h>

#include "paintlab/acquisition/hdr_merge.h"
#include "paintlab/calibration/record.h"
#include "paintlab/core/error.h"

namespace paintlab::acq {

namespace {

std::vector<std::filesystem::path> files_of(const std::vector<Shot>& shots) {
  std::vector<std::filesystem::path> f;
  for (const Shot& s : shots)
    if (!s.file.empty()) f.push_back(s.file);
  return f;
}

}  // namespace

StepCapture step_capture(const std::string& step) {
  if (step == "sphere") return {Target::WhiteReference, true, 0.7, 0.999};
  if (step == "light") return {Target::GlossySphere, true, 0.8, 1.0};
  if (step == "scale") return {Target::WhiteReference, true, 0.7, 0.9999};
  throw UsageError("calibrate " + step + ": not a step that captures shots (sphere, light or scale)");
}

std::vector<Shot> step_shots(const StepImages& in, const calib::RigCalibration& cal, const std::string& step,
                             const std::vector<double>& angles_deg) {
  const StepCapture how = step_capture(step);
  std::vector<Shot> shots;
  if (!in.files.empty()) {
    Linearizer linearizer(HdrCalibration::of(cal));
    for (const auto& p : in.files) shots.push_back(load_shot(p, linearizer));
    return shots;
  }
  if (!in.capture) throw UsageError("calibrate " + step + ": give --images or --capture");
  return capture_shots(*in.capture, step, angles_deg, how.target, how.led_on, how.fill, how.quantile);
}

calib::SphereFit sphere_step(const StepImages& in, const calib::RigCalibration& cal, const RigConfig& rig,
                             const std::vector<double>& angles_deg) {
  cal.require({calib::kCameraFile});
  const std::vector<Shot> shots = step_shots(in, cal, "sphere", angles_deg);
  std::vector<calib::SphereImage> images;
  for (const Shot& s : shots) images.push_back({s.name, s.rate});
  calib::SphereOptions o;
  o.radius_m = rig.geometry.sphere_radius_m;
  calib::SphereFit fit = calib::fit_sphere(images, cal.camera(), o);
  fit.provenance = calib::Provenance::make("sphere", files_of(shots), in.devices);
  return fit;
}

calib::LightCalibration light_step(const StepImages& in, const calib::RigCalibration& cal, const RigConfig& rig,
                                   const std::vector<double>& angles_deg) {
  cal.require({calib::kCameraFile, calib::kSphereFile});
  const std::vector<Shot> shots = step_shots(in, cal, "light", angles_deg);
  std::vector<calib::HighlightImage> images;
  for (const Shot& s : shots) images.push_back(highlight_image(s, "calibrate light"));
  calib::LightCalibration l = calib::calibrate_light(images, cal.camera(), *cal.sphere(), rig.geometry);
  l.provenance = calib::Provenance::make("light", files_of(shots), in.devices);
  return l;
}

calib::ScaleCalibration scale_step(const StepImages& in, const calib::RigCalibration& cal, const RigConfig& rig,
                                   const std::vector<double>& angles_deg, double albedo) {
  cal.require({calib::kCameraFile, calib::kSphereFile, calib::kLightFile});
  if (!(albedo > 0 && albedo <= 1))
    throw UsageError(fmt::format("calibrate scale: albedo {}: give the reference sphere's certified albedo (0..1, e.g. "
                                 "0.99)",
                                 albedo));
  const std::vector<Shot> shots = step_shots(in, cal, "scale", angles_deg);
  std::vector<calib::ReferenceImage> images;
  for (const Shot& s : shots) images.push_back(reference_image(s, "calibrate scale"));
  calib::ScaleOptions o;
  o.albedo = albedo;
  o.fit_profile = cal.has(calib::kFlatFile);
  calib::ScaleCalibration sc = calib::calibrate_scale(images, cal.camera(), *cal.sphere(), cal.light()->model, o);
  sc.provenance = calib::Provenance::make("scale", files_of(shots), in.devices);
  if (sc.saturated_frac > rig.tolerances.saturated_frac)
    throw CalibrationError(fmt::format("calibrate scale: the reference is saturated in {:.3f} % of its lit pixels "
                                       "(tolerance {:.3f} %): shorten the exposure; scale.json was not written\n  {}",
                                       100 * sc.saturated_frac, 100 * rig.tolerances.saturated_frac, sc.describe()));
  return sc;
}

}  // namespace paintlab::acq
