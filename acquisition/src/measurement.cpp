#include "paintlab/acquisition/measurement.h"

#include <fmt/format.h>

#include <cmath>

#include "paintlab/calibration/colour.h"
#include "paintlab/calibration/record.h"
#include "paintlab/calibration/rig_calibration.h"
#include "paintlab/calibration/scale.h"
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
  for (const char* name :
       {calib::kCameraFile, calib::kSphereFile, calib::kLightFile, calib::kScaleFile, calib::kColourFile})
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

void check_resume_camera(const SessionManifest& session, const CameraPreparation& camera,
                         const std::string& session_dir) {
  const std::string& started = session.options.pixel_format;
  if (!started.empty() && started != dev::to_string(camera.format))
    throw DataError(fmt::format("{}: the session was measured in {}, but the camera now records {}: set the camera "
                                "back to {} in the rig file to resume (or start a new session)",
                                session_dir, started, dev::to_string(camera.format), started));
}

ColourMap prepare_colour(const RigConfig& rig, dev::PixelFormat format, bool uncalibrated) {
  ColourMap map;
  map.pattern = dev::cfa_pattern(format);
  const bool wheel = map.pattern == dev::CfaPattern::None && rig.filter_wheel.has_value();
  if ((map.pattern == dev::CfaPattern::None && !wheel) || uncalibrated) return map;  // camera RGB, as recorded
  const fs::path dir = rig.calibration_dir;
  const fs::path colour_file = dir / calib::kColourFile, scale_file = dir / calib::kScaleFile;
  if (!fs::exists(colour_file))
    throw DataError(fmt::format("{} is missing: the camera records {}, and its RGB becomes linear sRGB through "
                                "the colour calibration: run `paintlab calibrate colour --rig {} --capture` first (or "
                                "measure with --uncalibrated for camera RGB)",
                                colour_file.string(),
                                std::string(dev::to_string(format)) + (wheel ? " behind a filter wheel" : " (colour)"),
                                rig.file.string()));
  if (!fs::exists(scale_file))
    throw DataError(fmt::format("{} is missing: a colour camera is white-balanced on the white reference: run "
                                "`paintlab calibrate scale --rig {}` first (or measure with --uncalibrated)",
                                scale_file.string(), rig.file.string()));
  const calib::ScaleCalibration scale = calib::ScaleCalibration::load(scale_file);
  if (!scale.scale_rgb)
    throw DataError(fmt::format("{}: no per-channel scale (scale_rgb): it was calibrated with a monochrome camera; run "
                                "`paintlab calibrate scale --rig {}` again with the colour camera",
                                scale_file.string(), rig.file.string()));
  map.balance = *scale.white_balance();
  auto colour = std::make_shared<const calib::ColourCalibration>(calib::ColourCalibration::load(colour_file));
  if (const std::optional<Eigen::Matrix3d> balanced = colour->balanced_srgb_matrix()) {
    const Eigen::Matrix3d& m = *balanced;
    std::array<double, 9> rows{};
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) rows[static_cast<std::size_t>(3 * i + j)] = m(i, j);
    map.matrix = rows;
  } else {
    map.nonlinear = [colour](const std::array<double, 3>& b) {
      const colour::Rgb s = colour->to_srgb_balanced(colour::Rgb(b[0], b[1], b[2]));
      return std::array<double, 3>{s[0], s[1], s[2]};
    };
  }
  map.colour_space = colour::kLinearSrgb;
  return map;
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
  if (dev::cfa_pattern(camera.format) != dev::CfaPattern::None || rig.filter_wheel) {
    m.options.colour_space = in.options.colour_space.empty() ? colour::kCameraRgb : in.options.colour_space;
    m.options.demosaic = rig.filter_wheel            ? "none (filter wheel)"
                         : in.options.demosaic.empty() ? to_string(MosaicInterpolation::Bilinear)
                                                       : in.options.demosaic;
  }
  return m;
}

BracketMerger::BracketMerger(HdrCalibration calibration, int bit_depth, ColourMap colour)
    : calibration_(std::move(calibration)), bit_depth_(bit_depth), colour_(std::move(colour)) {}

ExrImage BracketMerger::merge_per_filter(const std::vector<dev::Frame>& frames) {
  std::array<std::vector<calib::StackFrame>, 3> stacks;
  for (const auto& f : frames) {
    if (f.meta.filter < 0 || f.meta.filter > 2)
      throw DataError(fmt::format("a filter-wheel bracket has a frame without its filter (filter {})", f.meta.filter));
    stacks[static_cast<std::size_t>(f.meta.filter)].push_back({&f.pixels, f.meta.exposure_s});
  }
  std::array<ExrImage, 3> merged;
  long long valid = 0, saturated = 0;
  for (int c = 0; c < 3; ++c) {
    if (stacks[static_cast<std::size_t>(c)].empty())
      throw DataError(fmt::format("a filter-wheel bracket has no frame through the {} filter", "RGB"[c]));
    HdrResult r = merger_->merge(stacks[static_cast<std::size_t>(c)]);
    valid += r.stats.valid;
    saturated += r.stats.saturated;
    merged[static_cast<std::size_t>(c)] = std::move(r.image);
  }
  ExrImage rgb = map_colour({&merged[0], &merged[1], &merged[2]}, colour_);
  {
    std::lock_guard lock(mutex_);
    for (std::size_t c = 0; c < 3; ++c) {
      auto kept = std::make_shared<ExrImage>();
      kept->add("Y", std::move(*merged[c].find("Y")));
      kept->add("valid", std::move(*merged[c].find("valid")));
      last_filter_[c] = std::move(kept);
    }
  }
  rgb.attributes["paintlab.valid_pixels"] = std::to_string(valid / 3);
  rgb.attributes["paintlab.saturated_pixels"] = std::to_string(saturated);
  rgb.attributes["paintlab.filters"] = "R, G, B: one bracket each (filter wheel)";
  return rgb;
}

std::shared_ptr<const ExrImage> BracketMerger::last_filter_merge(int c) const {
  std::lock_guard lock(mutex_);
  return c >= 0 && c < 3 ? last_filter_[static_cast<std::size_t>(c)] : nullptr;
}

std::shared_ptr<const ExrImage> BracketMerger::last_mosaic() const {
  std::lock_guard lock(mutex_);
  return last_mosaic_;
}

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
    if (frames.front().meta.filter >= 0) return merge_per_filter(frames);
    HdrResult r = merger_->merge(stack);
    r.image.attributes["paintlab.valid_pixels"] = std::to_string(r.stats.valid);
    r.image.attributes["paintlab.saturated_pixels"] = std::to_string(r.stats.saturated);
    if (colour_.pattern == dev::CfaPattern::None) return std::move(r.image);
    ExrImage rgb = demosaic_to_colour(r.image, colour_);
    auto mosaic = std::make_shared<ExrImage>();
    mosaic->width = r.image.width;
    mosaic->height = r.image.height;
    mosaic->add("Y", std::move(*r.image.find("Y")));
    mosaic->add("valid", std::move(*r.image.find("valid")));
    std::lock_guard lock(mutex_);
    last_mosaic_ = std::move(mosaic);
    return rgb;
  };
}

std::unique_ptr<AdaptiveBracketing> make_adaptive_planner(const MeasureSetup& setup, const CameraPreparation& camera,
                                                          const BracketMerger* merger, bool filter_wheel) {
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
  auto planner = std::make_unique<AdaptiveBracketing>(o, setup.sphere_mask.value_or(Image<std::uint8_t>()));
  if (dev::cfa_pattern(camera.format) != dev::CfaPattern::None) {
    if (!merger) throw std::logic_error("make_adaptive_planner: a colour camera's planner needs its BracketMerger");
    planner->predict_from([merger] { return merger->last_mosaic(); });
  }
  if (filter_wheel) {
    if (!merger) throw std::logic_error("make_adaptive_planner: a filter wheel's planner needs its BracketMerger");
    planner->predict_per_filter([merger](int c) { return merger->last_filter_merge(c); });
  }
  return planner;
}

}  // namespace paintlab::acq
