#include "paintlab/acquisition/calibration_steps.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <cmath>

#include "paintlab/acquisition/hdr_merge.h"
#include "paintlab/calibration/record.h"
#include "paintlab/core/error.h"
#include "paintlab/core/image_io.h"

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

calib::IntrinsicsResult intrinsics_step(const StepImages& in, const calib::BoardSpec& board,
                                        const calib::IntrinsicsOptions& options, int views) {
  std::vector<calib::BoardImage> images;
  std::vector<std::filesystem::path> read;
  if (!in.files.empty()) {
    for (const auto& p : in.files) {
      RawImage raw = read_raw_image(p);
      images.push_back({p.filename().string(), std::move(raw.pixels), raw.bit_depth});
      read.push_back(p);
    }
  } else {
    if (!in.capture) throw UsageError("calibrate intrinsics: give --images or --capture");
    if (views < 3) throw UsageError(fmt::format("calibrate intrinsics: --views {}: must be >= 3", views));
    BoardViews captured = capture_board_views(*in.capture, board, views);
    images = std::move(captured.images);
    read = std::move(captured.files);
  }
  calib::IntrinsicsResult r = calib::calibrate_intrinsics(images, board, options);
  r.provenance = calib::Provenance::make("intrinsics", read, in.devices);
  return r;
}

calib::ColourCalibration colour_step(const StepImages& in, const calib::ChartReference& reference,
                                     const calib::ColourFitOptions& options) {
  if (in.files.empty() && !in.capture)
    throw UsageError("calibrate colour: give --images (linear RGB EXR images of the chart, e.g. from `paintlab hdr merge`) "
                     "or --rig R --capture");
  std::vector<calib::PatchMeasurement> sum;
  if (in.files.empty()) {  // captured: one shot of the chart, auto-exposed so that its white stays unclipped
    in.capture->stage->show_chart();
    const Shot s = in.capture->shot({"colour", "chart", std::nullopt, true, 0.7, 0.9999, std::nullopt});
    in.capture->stage->mount(Target::Sample);
    if (s.rgb.channels() != 3)
      throw CalibrationError("calibrate colour: the camera is monochrome (" + s.file.filename().string() +
                             "): a colour chart needs a colour camera (a Bayer pixel_format in rig.toml)");
    calib::ChartDetection found = calib::find_colour_chart(s.rgb, reference);
    // A patch with a clipped site near its centre is clipped.
    for (std::size_t k = 0; k < found.patches.size(); ++k) {
      const int r = static_cast<int>(0.3 * found.pitch_px);
      const int cx = static_cast<int>(found.centres[k].x()), cy = static_cast<int>(found.centres[k].y());
      for (int y = std::max(0, cy - r); y <= std::min(s.saturated.height() - 1, cy + r); ++y)
        for (int x = std::max(0, cx - r); x <= std::min(s.saturated.width() - 1, cx + r); ++x)
          if (s.saturated.at(x, y)) found.patches[k].clipped = true;
    }
    calib::ColourCalibration cal = calib::fit_colour(reference, found.patches, options);
    std::vector<std::filesystem::path> read = {s.file, std::filesystem::path(reference.source)};
    cal.provenance = calib::Provenance::make("colour", read, in.devices);
    return cal;
  }
  for (const auto& path : in.files) {
    const ExrImage exr = read_exr(path);
    ImageF rgb(exr.width, exr.height, 3);
    const char* names[3] = {"R", "G", "B"};
    for (int c = 0; c < 3; ++c) {
      const ImageF* plane = exr.find(names[c]);
      if (!plane)
        throw DataError(fmt::format("{}: no channel {}: the colour chart needs a linear RGB image (channels R, G, B)",
                                    path.string(), names[c]));
      for (int y = 0; y < exr.height; ++y)
        for (int x = 0; x < exr.width; ++x) rgb.at(x, y, c) = plane->at(x, y);
    }
    const calib::ChartDetection found = calib::find_colour_chart(rgb, reference);
    spdlog::info("{}: chart found, patches {:.0f} px apart", path.filename().string(), found.pitch_px);
    if (sum.empty()) {
      sum = found.patches;
      continue;
    }
    for (std::size_t i = 0; i < sum.size(); ++i) {
      sum[i].rgb += found.patches[i].rgb;
      sum[i].stderr_rgb += found.patches[i].stderr_rgb;
      sum[i].pixels += found.patches[i].pixels;
      sum[i].clipped = sum[i].clipped || found.patches[i].clipped;
    }
  }
  const double n = static_cast<double>(in.files.size());
  for (calib::PatchMeasurement& p : sum) {
    p.rgb /= n;
    p.stderr_rgb /= n * std::sqrt(n);
  }
  calib::ColourCalibration cal = calib::fit_colour(reference, sum, options);
  std::vector<std::filesystem::path> read = in.files;
  read.emplace_back(reference.source);
  cal.provenance = calib::Provenance::make("colour", read, in.devices);
  return cal;
}

calib::SphereFit sphere_step(const StepImages& in, const calib::RigCalibration& cal, const RigConfig& rig,
                             const std::vector<double>& angles_deg) {
  cal.require({calib::kCameraFile});
  const std::vector<Shot> shots = step_shots(in, cal, "sphere", angles_deg);
  std::vector<calib::SphereImage> images;
  for (const Shot& s : shots) images.push_back({s.name, s.rate});
  calib::SphereOptions o;
  o.radius_m = rig.geometry.sphere_radius_m;
  o.image_blur_var_px2 = shots.empty() ? 0.0 : shots.front().blur_var_px2;
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
  if (!shots.empty() && shots.front().rgb.channels() == 3) {
    // A colour camera: the white reference per camera channel, with the LED profile found above.
    calib::ScaleOptions per_channel = o;
    per_channel.fit_profile = false;
    per_channel.profile_exponent = sc.profile_exponent;
    std::array<double, 3> rgb{};
    for (int c = 0; c < 3; ++c) {
      std::vector<calib::ReferenceImage> channel = images;
      for (std::size_t k = 0; k < shots.size(); ++k) {
        ImageF& rate = channel[k].rate;
        for (int y = 0; y < rate.height(); ++y)
          for (int x = 0; x < rate.width(); ++x) rate.at(x, y) = shots[k].rgb.at(x, y, c);
      }
      rgb[static_cast<std::size_t>(c)] =
          calib::calibrate_scale(channel, cal.camera(), *cal.sphere(), cal.light()->model, per_channel).scale;
    }
    sc.scale_rgb = rgb;
  }
  sc.provenance = calib::Provenance::make("scale", files_of(shots), in.devices);
  if (sc.saturated_frac > rig.tolerances.saturated_frac)
    throw CalibrationError(fmt::format("calibrate scale: the reference is saturated in {:.3f} % of its lit pixels "
                                       "(tolerance {:.3f} %): shorten the exposure; scale.json was not written\n  {}",
                                       100 * sc.saturated_frac, 100 * rig.tolerances.saturated_frac, sc.describe()));
  return sc;
}

namespace {

// The stack from files, or captured by `capture` when there are none.
template <class Capture>
calib::ExposureStack stack_of(const StackImages& in, const char* step, Capture capture) {
  if (in.stack) return *in.stack;
  if (!in.capture) throw UsageError(fmt::format("calibrate {}: give --images (or --rig R --capture)", step));
  return capture(*in.capture);
}

std::vector<std::filesystem::path> read_files(const calib::ExposureStack& stack, const StackImages& in) {
  std::vector<std::filesystem::path> files = stack.files;
  files.insert(files.end(), in.also_read.begin(), in.also_read.end());
  return files;
}

}  // namespace

calib::DarkFrame dark_step(const StackImages& in, const calib::DarkOptions& options, int frames) {
  options.check();
  const calib::ExposureStack stack = stack_of(in, "dark", [&](CalibrationRig& rig) {
    if (frames < 2) throw UsageError("calibrate dark: --frames must be >= 2 (read noise needs repeated frames)");
    return capture_dark_stack(rig, frames, in.capture_dir);
  });
  calib::DarkFrame d = calib::calibrate_dark(stack.frames(), stack.bit_depth, options);
  d.provenance = calib::Provenance::make("dark", read_files(stack, in), in.devices);
  return d;
}

ResponseStep response_step(const StackImages& in, const calib::ResponseOptions& options, const calib::DarkFrame* dark,
                           double angle_deg, int count) {
  options.check();
  ResponseStep out;
  calib::ExposureStack stack = stack_of(in, "response", [&](CalibrationRig& rig) {
    if (count < 3) throw UsageError("calibrate response: --count must be >= 3");
    out.captured = capture_response_stack(rig, angle_deg, dark ? dark->mean_bias_dn : options.black_dn, count,
                                          in.capture_dir);
    return std::move(out.captured->stack);
  });
  if (!constant_ratio(stack.exposures_s, &out.constant_ratio)) out.constant_ratio = 0.0;
  out.curve = calib::recover_response(stack.frames(), stack.bit_depth, options, dark);
  out.curve.provenance = calib::Provenance::make("response", read_files(stack, in), in.devices);
  return out;
}

calib::FlatField flat_step(const StackImages& in, const calib::ResponseCurve* response, const calib::DarkFrame* dark,
                           int frames) {
  const calib::ExposureStack stack = stack_of(in, "flat", [&](CalibrationRig& rig) {
    if (frames < 1) throw UsageError("calibrate flat: --frames must be >= 1");
    const double black = dark ? dark->mean_bias_dn : response ? response->window.black_dn : 0.0;
    return capture_flat_stack(rig, black, frames, in.capture_dir);
  });
  calib::FlatOptions options;
  options.cfa = stack.cfa;  // a Bayer camera's flat: normalised per filter colour
  calib::FlatField f = calib::calibrate_flat(stack.frames(), stack.bit_depth, options, response, dark);
  f.provenance = calib::Provenance::make("flat", read_files(stack, in), in.devices);
  return f;
}

}  // namespace paintlab::acq
