#include "paintlab/acquisition/calibration_capture.h"
#include "paintlab/acquisition/demosaic.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "paintlab/calibration/sphere.h"
#include "paintlab/core/error.h"
#include "paintlab/core/geometry.h"
#include "paintlab/core/input_files.h"
#include "paintlab/core/result.h"

namespace fs = std::filesystem;

namespace paintlab::acq {

namespace {

// The exposure at which the `quantile` pixel of what the camera sees sits at `fill` of the
// range above `black_dn`, at the plan's gain (the radiometric steps' 10 % tolerance).
double radiometric_exposure(CalibrationRig& rig, double black_dn, double fill, double start_s) {
  value_or_throw(rig.camera->set_gain_db(rig.gain_db));
  AutoExposureOptions o;
  o.fill = fill;
  o.quantile = 0.999;
  o.black_dn = black_dn;
  o.tolerance = 0.1;
  o.start_s = start_s;
  return auto_expose(*rig.camera, o).exposure_s;
}

// A live step that could not produce its evidence becomes a failed check of its own.
calib::CheckItem failed_live_item(const std::string& id, const std::string& what, const std::string& detail,
                                  const std::string& action) {
  calib::CheckItem i;
  i.id = id;
  i.what = what;
  i.limit = calib::Limit::Required;
  i.pass = false;
  i.detail = detail;
  i.action = action;
  return i;
}

// The live sphere fit and highlight search of both kinds of live check.
void fit_live_sphere(LiveCheck& out, const std::vector<Shot>& shots, const calib::RigCalibration& cal,
                     const RigConfig& config) {
  std::vector<calib::SphereImage> images;
  for (const auto& s : shots) images.push_back({s.name, s.rate});
  calib::SphereOptions o;
  o.radius_m = config.geometry.sphere_radius_m;
  o.image_blur_var_px2 = shots.empty() ? 0.0 : shots.front().blur_var_px2;
  try {
    out.evidence.sphere = calib::fit_sphere(images, cal.camera(), o);
  } catch (const CalibrationError& e) {
    out.failed.push_back(failed_live_item("sphere.live", "sphere silhouette now", e.what(),
                                          "the sphere is missing, unlit or out of view: mount it and check the LED"));
  }
}

void find_live_highlights(LiveCheck& out, const std::vector<Shot>& shots, const calib::RigCalibration& cal,
                          const RigConfig& config) {
  // The blur light.json's highlights were fitted with (from the highlights themselves).
  calib::LightOptions lo;
  if (cal.light() && cal.light()->blur_source == "highlights") lo.blur_sigma_px = cal.light()->blur_sigma_px;
  for (const auto& s : shots)
    out.evidence.highlights.push_back(
        calib::find_highlight(highlight_image(s, "check"), cal.camera(), *cal.sphere(), config.geometry, lo));
}

}  // namespace

// ---- The radiometric steps ----

std::vector<double> calibration_bracket(double min_s, double max_s, int count) {
  if (!(min_s > 0.0) || !(max_s > min_s) || count < 3)
    throw UsageError(fmt::format("calibration bracket: need 0 < min < max and >= 3 exposures (got {} s, {} s, {})",
                                 min_s, max_s, count));
  std::vector<double> t(static_cast<std::size_t>(count));
  const double span = std::log(max_s / min_s);
  const double jitter[3] = {0.0, 0.3, -0.3};  // fractions of a step: ratios differ step to step
  for (int i = 0; i < count; ++i) {
    const double x = (i + (i == 0 || i == count - 1 ? 0.0 : jitter[i % 3])) / (count - 1);
    t[static_cast<std::size_t>(i)] = min_s * std::exp(span * std::clamp(x, 0.0, 1.0));
  }
  return t;
}

bool constant_ratio(std::vector<double> t, double* ratio) {
  std::sort(t.begin(), t.end());
  if (t.size() < 3) return false;
  const double r0 = t[1] / t[0];
  for (std::size_t i = 2; i < t.size(); ++i)
    if (std::abs(t[i] / t[i - 1] / r0 - 1.0) > 0.02) return false;
  if (ratio) *ratio = r0;
  return true;
}

calib::ExposureStack capture_dark_stack(CalibrationRig& rig, int frames, const fs::path& save_dir) {
  if (frames < 2) throw UsageError(fmt::format("dark frames: {} per exposure; read noise needs >= 2", frames));
  if (rig.exposures_s.empty()) throw UsageError("dark frames: the plan has no exposures");
  rig.stage->cover_lens(LensView::Capped);
  calib::ExposureStack stack = capture_stack(*rig.camera, *rig.light, rig.gain_db,
                                             {rig.exposures_s.front(), rig.exposures_s.back()}, frames, false, save_dir);
  rig.stage->cover_lens(LensView::Scene);
  return stack;
}

ResponseCapture capture_response_stack(CalibrationRig& rig, double angle_deg, double black_dn, int count,
                                       const fs::path& save_dir) {
  if (count < 3) throw UsageError(fmt::format("response stack: {} exposures; needs >= 3", count));
  rig.stage->mount(Target::WhiteReference);
  if (rig.table) {
    value_or_throw(rig.table->move_to(wrap_360(angle_deg)));
    value_or_throw(rig.table->wait_settled(120.0));
    if (rig.settle_s > 0) rig.clock->sleep_s(rig.settle_s);
  }
  // The bracket follows the scene, not the measuring plan: from where the brightest pixels
  // sit at ~2 % of the range (data for the toe) to where most of the lit side saturates
  // (data up to the shoulder), 256x in all.
  ResponseCapture r;
  LightSwitch led(*rig.light, true);
  const double start_s = rig.exposures_s.empty() ? 0.01 : rig.exposures_s.back();
  r.top_s = radiometric_exposure(rig, black_dn, kResponseTopFill, start_s);
  const dev::ExposureRange range = value_or_throw(rig.camera->exposure_range());
  r.min_s = std::max(range.min_s, r.top_s / 32.0);
  r.max_s = std::min(range.max_s, r.top_s * 8.0);
  if (!(r.max_s > 4.0 * r.min_s))
    throw CalibrationError(fmt::format(
        "calibrate response: the camera's exposure range ({:.3g}..{:.3g} s) leaves no bracket around {:.3g} s, "
        "where the brightest pixels of the white reference reach {:.0f} % of the range",
        range.min_s, range.max_s, r.top_s, 100.0 * kResponseTopFill));
  r.stack = capture_stack(*rig.camera, *rig.light, rig.gain_db, calibration_bracket(r.min_s, r.max_s, count), 1, true,
                          save_dir);
  return r;
}

calib::ExposureStack capture_flat_stack(CalibrationRig& rig, double black_dn, int frames, const fs::path& save_dir) {
  if (frames < 1) throw UsageError(fmt::format("flat-field frames: {}; needs >= 1", frames));
  rig.stage->cover_lens(LensView::Diffuser);
  value_or_throw(rig.light->off());
  // The brightest pixels at 60 % of the range: well clear of saturation, far above the noise.
  const double t = radiometric_exposure(rig, black_dn, 0.6, 0.01);
  calib::ExposureStack stack = capture_stack(*rig.camera, *rig.light, rig.gain_db, {t}, frames, false, save_dir);
  rig.stage->cover_lens(LensView::Scene);
  return stack;
}

// ---- The geometric steps ----

BoardViews capture_board_views(CalibrationRig& rig, const calib::BoardSpec& board, int views) {
  if (views < 3) throw UsageError(fmt::format("chessboard views: {}; needs >= 3", views));
  BoardViews out;
  for (int k = 0; k < views; ++k) {
    rig.stage->show_board(k, views, board);
    ShotRequest r;
    r.step = "intrinsics";
    r.name = fmt::format("view{:02d}", k);
    r.fill = 0.6;
    r.quantile = 0.99;
    Shot s = rig.shot(r);
    // A colour camera's mosaic would show the corner finder a 2x2 pattern of gains: the shot's
    // grey-balanced luminance (linear, symmetric: it moves no edge) as a 16-bit image instead.
    if (s.cfa != dev::CfaPattern::None) {
      const float peak = *std::max_element(s.rate.values().begin(), s.rate.values().end());
      const double to_dn = peak > 0 ? 60000.0 / peak : 1.0;
      for (std::size_t i = 0; i < s.raw.size(); ++i)
        s.raw.values()[i] =
            static_cast<std::uint16_t>(std::lround(std::clamp(s.rate.values()[i] * to_dn, 0.0, 65535.0)));
      s.bit_depth = 16;
    }
    out.images.push_back({s.name, std::move(s.raw), s.bit_depth});
    out.files.push_back(s.file);
  }
  rig.stage->mount(Target::Sample);
  return out;
}

std::vector<Shot> capture_shots(CalibrationRig& rig, const std::string& step, const std::vector<double>& angles_deg,
                                Target target, bool led_on, double fill, double quantile) {
  rig.stage->mount(target);
  std::vector<Shot> shots;
  for (double a : angles_deg)
    shots.push_back(rig.shot({step, fmt::format("{}_angle{:g}", step, a), a, led_on, fill, quantile, std::nullopt}));
  return shots;
}

calib::HighlightImage highlight_image(const Shot& shot, const std::string& step) {
  if (!shot.table_angle_deg)
    throw UsageError(step + ": " + shot.file.string() +
                     ": the table angle is not in the file name (e.g. light_angle-30.png)");
  calib::HighlightImage h{*shot.table_angle_deg, shot.name, shot.rate};
  for (std::size_t i = 0; i < shot.saturated.size(); ++i)
    if (shot.saturated.values()[i]) h.pixels.values()[i] = std::numeric_limits<float>::infinity();
  h.saturated_at = std::numeric_limits<double>::infinity();
  return h;
}

calib::ReferenceImage reference_image(const Shot& shot, const std::string& step) {
  if (!shot.table_angle_deg)
    throw UsageError(step + ": " + shot.file.string() +
                     ": the table angle is not in the file name (e.g. scale_angle0_exp20ms.png)");
  if (!shot.per_second)
    throw UsageError(step + ": " + shot.file.string() + ": the exposure is not in the file name (e.g. _exp20ms)");
  return {*shot.table_angle_deg, shot.name, shot.rate, shot.saturated};
}

// ---- The live check ----

double saturated_on_sphere(const Shot& shot, const calib::CameraModel& camera, const calib::SphereFit& sphere) {
  if (shot.saturated.empty()) return 0.0;
  long long n = 0, sat = 0;
  for (int y = 0; y < shot.saturated.height(); ++y)
    for (int x = 0; x < shot.saturated.width(); ++x) {
      if (!calib::intersect_sphere(camera.ray(Vec2(x, y)), sphere.centre_cam_m, sphere.radius_m)) continue;
      ++n;
      sat += shot.saturated.at(x, y);
    }
  return n ? static_cast<double>(sat) / static_cast<double>(n) : 0.0;
}

LiveCheck capture_live_check(CalibrationRig& rig, const calib::RigCalibration& cal, const RigConfig& config) {
  LiveCheck out;
  if (!cal.intrinsics() || !cal.sphere()) {
    out.failed.push_back(failed_live_item("live", "live checks", "camera.json and sphere.json are needed first",
                                          "run `paintlab calibrate all --rig " + config.file.string() + "`"));
    return out;
  }
  auto shot = [&](const std::string& name, double angle, double fill, double quantile,
                  std::optional<double> exposure_s = std::nullopt) {
    return rig.shot({"check", name, angle, true, fill, quantile, exposure_s});
  };
  rig.stage->mount(Target::WhiteReference);
  const Shot first = shot("drift_start", 0.0, 0.7, 0.9999);
  out.evidence.reference_saturated_frac = saturated_on_sphere(first, cal.camera(), *cal.sphere());
  std::vector<Shot> side;
  for (double angle : {90.0, 270.0}) side.push_back(shot(fmt::format("sphere_angle{:g}", angle), angle, 0.7, 0.999));
  fit_live_sphere(out, side, cal, config);
  if (cal.light()) {
    rig.stage->mount(Target::GlossySphere);
    std::vector<Shot> highlights;
    for (double angle : {-60.0, 0.0, 60.0})
      highlights.push_back(shot(fmt::format("light_angle{:g}", angle), angle, 0.8, 1.0));
    find_live_highlights(out, highlights, cal, config);
    rig.stage->mount(Target::WhiteReference);
  }
  const Shot last = shot("drift_end", 0.0, 0.7, 0.9999, first.exposure_s);
  out.evidence.drift_rel = calib::intensity_drift_rel({first.rate, last.rate}, cal.camera(), *cal.sphere());
  rig.stage->mount(Target::Sample);
  return out;
}

LiveCheck live_check_from_images(const fs::path& dir, const calib::RigCalibration& cal, const RigConfig& config,
                                 Linearizer& linearizer) {
  if (!cal.intrinsics() || !cal.sphere())
    throw CalibrationError("check --images: camera.json and sphere.json are needed to read the live images");
  LiveCheck out;
  auto shots_in = [&](const char* sub) {
    std::vector<Shot> v;
    if (fs::is_directory(dir / sub))
      for (const auto& p : expand_input_files({(dir / sub).string()}, "--images", kCalibrationImageExtensions))
        v.push_back(load_shot(p, linearizer));
    return v;
  };
  if (auto v = shots_in("sphere"); !v.empty()) fit_live_sphere(out, v, cal, config);
  if (auto v = shots_in("light"); !v.empty() && cal.light()) find_live_highlights(out, v, cal, config);
  if (auto v = shots_in("drift"); v.size() >= 2) {
    std::vector<ImageF> rates;
    for (const auto& s : v) rates.push_back(s.rate);
    out.evidence.drift_rel = calib::intensity_drift_rel(rates, cal.camera(), *cal.sphere());
  }
  if (auto v = shots_in("reference"); !v.empty()) {
    double worst = 0;
    for (const auto& s : v) worst = std::max(worst, saturated_on_sphere(s, cal.camera(), *cal.sphere()));
    out.evidence.reference_saturated_frac = worst;
  }
  return out;
}

}  // namespace paintlab::acq
