// The measured-versus-model comparison of preview.h (render_comparison).
#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

#include "paintlab/core/error.h"
#include "paintlab/core/robust.h"
#include "paintlab/core/geometry.h"
#include "paintlab/fitting/preview.h"

namespace paintlab::fit {

using brdf::Rgb;
using brdf::Vec3;

void CompareOptions::check() const {
  auto fail = [](const char* field, double value, const char* rule) {
    throw OptionError(std::string("CompareOptions::") + field, fmt::format("{}", value), rule);
  };
  if (!(margin_px >= 0 && margin_px <= 1000)) fail("margin_px", margin_px, "[0, 1000]");
  if (!(min_cos >= 0 && min_cos < 1)) fail("min_cos", min_cos, "[0, 1)");
  if (!(signal_floor_rel >= 0 && signal_floor_rel < 1)) fail("signal_floor_rel", signal_floor_rel, "[0, 1)");
  if (!(diff_range_log2 > 0)) fail("diff_range_log2", diff_range_log2, "> 0");
  if (!(window_px >= 0 && window_px <= 50)) fail("window_px", window_px, "[0, 50]");
}

namespace {

// The model's value at camera pixel (cx, cy) in the unit of the session's images (rate =
// f scale E) and the sphere point, or nothing off the sphere (or unlit).
struct RigPixel {
  Rgb rate;
  calib::SurfacePoint point;
  Vec3 wi;
};
std::optional<RigPixel> rig_pixel(const brdf::Brdf& brdf, const calib::RigCalibration& cal, const Vec3& led,
                                  double angle_deg, int cx, int cy, const FlakeSparkle* sparkle, bool* on_sphere) {
  const auto sp = cal.sphere_point_at(Vec2(cx, cy));
  *on_sphere = sp.has_value();
  if (!sp) return std::nullopt;
  const Vec3 wi = (led - sp->point).normalized();
  const double per_rate = cal.brdf(1.0, angle_deg, *sp);  // 1 / (scale E)
  if (!(per_rate > 0) || !std::isfinite(per_rate)) return std::nullopt;
  const Mat3 frame = frame_from_normal(sp->normal);
  const Vec3 wi_l = frame.transpose() * wi, wo_l = frame.transpose() * sp->to_camera;
  Rgb f = brdf.eval(wi_l, wo_l);
  // The camera pixel is the surface cell: the camera does not move relative to the sphere.
  if (sparkle) {
    const auto cell = static_cast<std::uint64_t>(cy) * static_cast<std::uint64_t>(cal.camera().width_px) +
                      static_cast<std::uint64_t>(cx);
    f = (f + sparkle->delta(cell, wi_l, wo_l, f)).max(0.0);
  }
  return RigPixel{f / per_rate, *sp, wi};
}

}  // namespace

ImageF render_rig(const brdf::Brdf& brdf, const calib::RigCalibration& cal, double angle_deg,
                  const FlakeSparkle* sparkle) {
  cal.require({calib::kCameraFile, calib::kSphereFile, calib::kLightFile, calib::kScaleFile});
  const calib::CameraModel& cam = cal.camera();
  ImageF out(cam.width_px, cam.height_px, 3, 0.0f);
  const Vec3 led = cal.light_model().led_position_cam(angle_deg);
  // Only the rows and columns the sphere can cover.
  const calib::SphereFit& sphere = *cal.sphere();
  const Vec2 c_px = cam.project(sphere.centre_cam_m);
  const double r_px = 1.25 * std::max(cam.fx(), cam.fy()) * sphere.radius_m / sphere.centre_cam_m.z() + 2.0;
  const int x0 = std::clamp(static_cast<int>(std::floor(c_px.x() - r_px)), 0, cam.width_px - 1);
  const int x1 = std::clamp(static_cast<int>(std::ceil(c_px.x() + r_px)), 0, cam.width_px - 1);
  const int y0 = std::clamp(static_cast<int>(std::floor(c_px.y() - r_px)), 0, cam.height_px - 1);
  const int y1 = std::clamp(static_cast<int>(std::ceil(c_px.y() + r_px)), 0, cam.height_px - 1);
  tbb::parallel_for(tbb::blocked_range<int>(y0, y1 + 1), [&](const tbb::blocked_range<int>& rows) {
    for (int y = rows.begin(); y < rows.end(); ++y)
      for (int x = x0; x <= x1; ++x) {
        bool on = false;
        if (const auto p = rig_pixel(brdf, cal, led, angle_deg, x, y, sparkle, &on))
          for (int c = 0; c < 3; ++c) out.at(x, y, c) = static_cast<float>(p->rate[c]);
      }
  });
  return out;
}

Comparison render_comparison(const brdf::Brdf& brdf, const calib::RigCalibration& cal, const ExrImage& hdr,
                             double angle_deg, const CompareOptions& o, const FlakeSparkle* sparkle) {
  o.check();
  cal.require({calib::kCameraFile, calib::kSphereFile, calib::kLightFile, calib::kScaleFile});
  const calib::CameraModel& cam = cal.camera();
  if (hdr.width != cam.width_px || hdr.height != cam.height_px)
    throw DataError(fmt::format("measured image is {} x {} but the calibrated camera is {} x {}", hdr.width, hdr.height,
                                cam.width_px, cam.height_px));
  const bool rgb = hdr.find("R") && hdr.find("G") && hdr.find("B");
  if (!rgb && !hdr.find("Y")) throw DataError("measured image: needs channels R, G, B or Y");
  const ImageF* planes[3] = {rgb ? &hdr.plane("R") : &hdr.plane("Y"), rgb ? &hdr.plane("G") : &hdr.plane("Y"),
                             rgb ? &hdr.plane("B") : &hdr.plane("Y")};
  const ImageF* valid = hdr.find("valid");

  // Crop: the sphere's projection (centre +- its apparent radius, generously) plus margin.
  const calib::SphereFit& sphere = *cal.sphere();
  const Vec2 c_px = cam.project(sphere.centre_cam_m);
  const double r_px = 1.25 * std::max(cam.fx(), cam.fy()) * sphere.radius_m / sphere.centre_cam_m.z() + o.margin_px;
  const int x0 = std::clamp(static_cast<int>(std::floor(c_px.x() - r_px)), 0, hdr.width - 1);
  const int x1 = std::clamp(static_cast<int>(std::ceil(c_px.x() + r_px)), 0, hdr.width - 1);
  const int y0 = std::clamp(static_cast<int>(std::floor(c_px.y() - r_px)), 0, hdr.height - 1);
  const int y1 = std::clamp(static_cast<int>(std::ceil(c_px.y() + r_px)), 0, hdr.height - 1);
  const int W = x1 - x0 + 1, H = y1 - y0 + 1;

  Comparison out;
  out.crop_x = x0;
  out.crop_y = y0;
  out.measured = ImageF(W, H, 3, 0.0f);
  out.model = ImageF(W, H, 3, 0.0f);
  std::vector<std::uint8_t> on_sphere(static_cast<std::size_t>(W) * H, 0), geometry_ok = on_sphere;
  const calib::LightModel light = cal.light_model();
  const Vec3 led = light.led_position_cam(angle_deg);

  tbb::parallel_for(tbb::blocked_range<int>(0, H), [&](const tbb::blocked_range<int>& rows) {
    for (int y = rows.begin(); y < rows.end(); ++y)
      for (int x = 0; x < W; ++x) {
        const int cx = x0 + x, cy = y0 + y;
        for (int c = 0; c < 3; ++c) out.measured.at(x, y, c) = planes[c]->at(cx, cy);
        bool on = false;
        const auto p = rig_pixel(brdf, cal, led, angle_deg, cx, cy, sparkle, &on);
        const std::size_t i = static_cast<std::size_t>(y) * W + x;
        on_sphere[i] = on ? 1 : 0;
        if (!p) continue;
        const calib::SurfacePoint* sp = &p->point;
        const Vec3& wi = p->wi;
        const Rgb f = rgb ? p->rate : Rgb::Constant(p->rate.mean());
        for (int c = 0; c < 3; ++c) out.model.at(x, y, c) = static_cast<float>(f[c]);
        const bool valid_px = !valid || valid->at(cx, cy) > 0.5f;
        geometry_ok[i] = valid_px && sp->normal.dot(wi) >= o.min_cos && sp->normal.dot(sp->to_camera) >= o.min_cos;
      }
  });

  out.exposure = o.tone.exposure > 0 ? o.tone.exposure : auto_exposure(out.measured, on_sphere, o.tone.percentile);
  const double floor = o.signal_floor_rel / out.exposure;

  // Usable pixels and their channel means; window sums by summed-area tables (same pixel
  // set for model and measurement, so their ratio compares like with like).
  const std::size_t N = static_cast<std::size_t>(W) * H;
  std::vector<std::uint8_t> usable(N, 0);
  std::vector<double> meas_px(N, 0.0), model_px(N, 0.0);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const std::size_t i = static_cast<std::size_t>(y) * W + x;
      if (!on_sphere[i] || !geometry_ok[i]) continue;
      double meas = 0, model = 0;
      for (int c = 0; c < 3; ++c) {
        meas += out.measured.at(x, y, c) / 3.0;
        model += out.model.at(x, y, c) / 3.0;
      }
      if (!std::isfinite(meas) || !(model > 0) || !std::isfinite(model)) continue;
      usable[i] = 1;
      meas_px[i] = meas;
      model_px[i] = model;
    }
  const std::size_t W1 = static_cast<std::size_t>(W) + 1;
  std::vector<double> sat_meas(W1 * (H + 1), 0.0), sat_model = sat_meas, sat_n = sat_meas;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const std::size_t i = static_cast<std::size_t>(y) * W + x, k = (y + 1) * W1 + (x + 1);
      sat_meas[k] = meas_px[i] + sat_meas[k - 1] + sat_meas[k - W1] - sat_meas[k - W1 - 1];
      sat_model[k] = model_px[i] + sat_model[k - 1] + sat_model[k - W1] - sat_model[k - W1 - 1];
      sat_n[k] = usable[i] + sat_n[k - 1] + sat_n[k - W1] - sat_n[k - W1 - 1];
    }
  auto box = [&](const std::vector<double>& t, int xa, int ya, int xb, int yb) {  // inclusive corners
    return t[(yb + 1) * W1 + (xb + 1)] - t[ya * W1 + (xb + 1)] - t[(yb + 1) * W1 + xa] + t[ya * W1 + xa];
  };

  out.used.assign(N, 0);
  std::vector<double> log_ratio;
  ImageU8 diff(W, H, 3, 0);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const std::size_t i = static_cast<std::size_t>(y) * W + x;
      if (!on_sphere[i]) continue;
      double meas = 0, model = 0;
      if (usable[i]) {
        const int xa = std::max(0, x - o.window_px), xb = std::min(W - 1, x + o.window_px);
        const int ya = std::max(0, y - o.window_px), yb = std::min(H - 1, y + o.window_px);
        const double n = box(sat_n, xa, ya, xb, yb);
        meas = box(sat_meas, xa, ya, xb, yb) / n;
        model = box(sat_model, xa, ya, xb, yb) / n;
      }
      if (!usable[i] || !(meas >= floor) || !(model > 0)) {
        for (int c = 0; c < 3; ++c) diff.at(x, y, c) = 40;
        continue;
      }
      out.used[i] = 1;
      const double l = std::log(model / meas);
      log_ratio.push_back(l);
      const double t = std::min(1.0, std::abs(l / std::log(2.0)) / o.diff_range_log2);
      diff.at(x, y, l > 0 ? 0 : 2) = srgb_encode(t);
    }
  out.pixels_used = log_ratio.size();
  if (!log_ratio.empty()) {
    double ss = 0;
    for (double l : log_ratio) ss += l * l;
    out.log_rms = std::sqrt(ss / static_cast<double>(log_ratio.size()));
    out.median_ratio = std::exp(upper_median_inplace(log_ratio));
  }

  const ImageU8 a = tone_map(out.measured, out.exposure), b = tone_map(out.model, out.exposure);
  const int gap = 4;
  out.png = ImageU8(3 * W + 2 * gap, H, 3, 255);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x)
      for (int c = 0; c < 3; ++c) {
        out.png.at(x, y, c) = a.at(x, y, c);
        out.png.at(W + gap + x, y, c) = b.at(x, y, c);
        out.png.at(2 * (W + gap) + x, y, c) = diff.at(x, y, c);
      }
  return out;
}

}  // namespace paintlab::fit
