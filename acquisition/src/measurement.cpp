#include "paintlab/acquisition/measurement.h"

#include <fmt/format.h>

#include <cmath>

#include "paintlab/calibration/record.h"
#include "paintlab/calibration/rig_calibration.h"
#include "paintlab/core/error.h"
#include "paintlab/core/hash.h"
#include "paintlab/core/result.h"
#include "paintlab/core/version.h"

namespace fs = std::filesystem;

namespace paintlab::acq {

MeasureSetup prepare_measurement(const RigConfig& rig, bool uncalibrated, bool need_sphere_mask) {
  MeasureSetup s;
  const fs::path dir = rig.calibration_dir;
  auto use = [&](const char* name, const char* step, bool required) -> std::optional<fs::path> {
    fs::path p = dir / name;
    if (!fs::exists(p)) {
      if (required)
        throw DataError(
            fmt::format("{} is missing: run `paintlab calibrate {} --rig {}` first (or measure with "
                        "--uncalibrated)",
                        p.string(), step, rig.file.string()));
      return std::nullopt;
    }
    s.calibration_checksums[name] = sha256_file(p);
    return p;
  };
  if (auto p = use(calib::kResponseFile, "response", !uncalibrated)) s.hdr.response = calib::ResponseCurve::load(*p);
  if (auto p = use(calib::kDarkFile, "dark", !uncalibrated)) s.hdr.dark = calib::DarkFrame::load(*p);
  if (auto p = use(calib::kFlatFile, "flat", false)) s.hdr.flat = calib::FlatField::load(*p);
  // Geometry files are not used by the merge, but the session records which ones were
  // current, so the fit can tell whether they changed after the measurement.
  for (const char* name : {calib::kCameraFile, calib::kSphereFile, calib::kLightFile, calib::kScaleFile})
    use(name, "", false);
  if (need_sphere_mask) {
    calib::RigCalibration cal = calib::RigCalibration::load(dir);
    cal.require({calib::kCameraFile, calib::kSphereFile});  // --adaptive needs the sphere's outline
    const calib::CameraModel& cam = cal.camera();
    Image<std::uint8_t> mask(cam.width_px, cam.height_px, 1, 0);
    for (int y = 0; y < mask.height(); ++y)
      for (int x = 0; x < mask.width(); ++x) mask.at(x, y) = cal.sphere_point_at(Vec2(x, y)).has_value() ? 1 : 0;
    s.sphere_mask = std::move(mask);
  }
  return s;
}

CameraPreparation prepare_camera(dev::Camera& camera, const RigConfig& rig) {
  CameraPreparation c;
  c.format = value_or_throw(camera.pixel_format());
  if (dev::cfa_pattern(c.format) != dev::CfaPattern::None)
    throw DataError(fmt::format(
        "the camera records {} (a colour mosaic): `paintlab measure` merges monochrome frames only until the colour "
        "merge is built (issue 14), and would record the mosaic as grey; measure with a Mono format",
        dev::to_string(c.format)));
  c.gain_db = value_or_throw(camera.set_gain_db(rig.plan.gain_db));
  c.range = value_or_throw(camera.exposure_range());
  for (double t : rig.plan.exposures_s) {
    if (t < c.range.min_s * (1 - 1e-9) || t > c.range.max_s * (1 + 1e-9))
      throw DataError(
          fmt::format("{}: exposure {:.6g} ms of the plan is outside the camera's range [{:.6g}, {:.6g}] ms "
                      "({}); nothing was written",
                      rig.file.string(), t * 1e3, c.range.min_s * 1e3, c.range.max_s * 1e3, camera.id()));
  }
  return c;
}

SessionManifest make_manifest(const RigConfig& rig, const MeasureSetup& setup, const CameraPreparation& camera,
                              const ManifestInput& in) {
  SessionManifest m;
  m.sample = in.sample;
  m.notes = in.notes;
  m.operator_name = in.operator_name;
  m.created_utc = utc_timestamp();
  m.software_version = software_version();
  m.rig_name = rig.name;
  m.rig_file = rig.file.string();
  m.rig_sha256 = sha256_file(rig.file);
  m.angles_deg = rig.plan.angles_deg();
  m.exposures_s = rig.plan.exposures_s;
  m.settle_s = rig.plan.settle_s;
  m.gain_db = camera.gain_db;
  m.calibration = setup.calibration_checksums;
  m.devices = in.devices;
  m.options = in.options;
  m.options.pixel_format = dev::to_string(camera.format);
  return m;
}

BracketMerger::BracketMerger(HdrCalibration calibration, int bit_depth)
    : calibration_(std::move(calibration)), bit_depth_(bit_depth) {}

MergeFn BracketMerger::function() {
  return [this](const std::vector<dev::Frame>& frames) {
    if (frames.empty()) throw DataError("an empty bracket cannot be merged");
    std::vector<calib::StackFrame> stack;
    stack.reserve(frames.size());
    for (const auto& f : frames) stack.push_back({&f.pixels, f.meta.exposure_s});
    {
      std::lock_guard lock(mutex_);
      if (!merger_) {
        const auto& p = frames.front().pixels;
        merger_ =
            std::make_unique<HdrMerger>(calibration_, HdrOptions{}, p.width(), p.height(), p.channels(), bit_depth_);
      }
    }
    HdrResult r = merger_->merge(stack);
    r.image.attributes["paintlab.valid_pixels"] = std::to_string(r.stats.valid);
    r.image.attributes["paintlab.saturated_pixels"] = std::to_string(r.stats.saturated);
    return std::move(r.image);
  };
}

std::unique_ptr<AdaptiveBracketing> make_adaptive_planner(const MeasureSetup& setup, const CameraPreparation& camera) {
  AdaptiveOptions o;
  const double full_scale = std::ldexp(1.0, dev::bit_depth(camera.format)) - 1.0;
  if (setup.hdr.response) {
    const calib::ResponseCurve& g = *setup.hdr.response;
    o.linear_floor = g.to_linear(0, g.window.floor_dn);
    o.linear_saturation = g.to_linear(0, g.window.u_saturation());
    if (g.noise.known()) {
      o.read_noise_dn = g.noise.read_noise_dn;
      o.gain_dn_per_e = g.noise.gain_dn_per_e;
    }
  } else {
    o.linear_floor = 0.0;
    o.linear_saturation = full_scale;
  }
  if (!(o.linear_floor >= 0)) o.linear_floor = 0.0;
  return std::make_unique<AdaptiveBracketing>(o, setup.sphere_mask.value_or(Image<std::uint8_t>()));
}

}  // namespace paintlab::acq
