// What each calibration step's result tells the technician: the lines `paintlab calibrate`
// prints after a step (and the reports show). Each figure's meaning: docs/calibration.md and
// docs/radiometry.md.
#include <fmt/format.h>

#include <algorithm>

#include "paintlab/calibration/dark.h"
#include "paintlab/calibration/flat.h"
#include "paintlab/calibration/intrinsics.h"
#include "paintlab/calibration/light.h"
#include "paintlab/calibration/response.h"
#include "paintlab/calibration/scale.h"
#include "paintlab/calibration/sphere.h"

namespace paintlab::calib {

namespace {

std::string percent(double v) { return fmt::format("{:.2f} %", 100.0 * v); }

}  // namespace

std::string IntrinsicsResult::describe() const {
  std::string s = fmt::format(
      "intrinsics: {} of {} views, RMS {:.3f} px (worst corner {:.3f} px), fx {:.2f} +- {:.2f}, fy {:.2f} +- {:.2f}, "
      "cx {:.2f} +- {:.2f}, cy {:.2f} +- {:.2f} px, dist [{:.4g}, {:.4g}, {:.4g}, {:.4g}, {:.4g}]",
      views_used, views.size(), rms_px, worst_px, camera.fx(), std.fx, camera.fy(), std.fy, camera.cx(), std.cx,
      camera.cy(), std.cy, camera.dist[0], camera.dist[1], camera.dist[2], camera.dist[3], camera.dist[4]);
  if (!k3.note.empty()) s += "\n  " + k3.note;
  for (const ViewReport& v : views)
    if (!v.used) s += fmt::format("\n  dropped {}: {}", v.name, v.reason);
  return s;
}

std::string SphereFit::describe() const {
  const Vec3 sd = centre_std_m();
  return fmt::format(
      "sphere: centre ({:.2f}, {:.2f}, {:.2f}) mm +- ({:.3f}, {:.3f}, {:.3f}) mm in the camera frame; silhouette RMS "
      "{:.3f} px over {} edge points ({:.0f} % of the outline), edge width {:.2f} px",
      centre_cam_m.x() * 1e3, centre_cam_m.y() * 1e3, centre_cam_m.z() * 1e3, sd.x() * 1e3, sd.y() * 1e3,
      sd.z() * 1e3, rms_px, edges_used, 100 * coverage, edge_width_px);
}

std::string LightCalibration::describe() const {
  std::string s = fmt::format(
      "light: {} of {} highlights, residual RMS {:.4f} deg (max {:.4f}); arm radius {:.2f} +- {:.2f} mm, height "
      "{:.2f} +- {:.2f} mm, zero {:.3f} +- {:.3f} deg, axis +- {:.3f} deg",
      used, highlights.size(), rms_deg, max_deg, model.arm_radius_m * 1e3, arm_radius_std_m * 1e3,
      model.arm_height_m * 1e3, arm_height_std_m * 1e3, model.zero_deg, zero_std_deg, axis_std_deg);
  s += fmt::format("\n  highlight blur {:.3f} px{} ({})", blur_sigma_px,
                   blur_std_px > 0 ? fmt::format(" +- {:.3f}", blur_std_px) : std::string(),
                   blur_source == "highlights" ? "fitted to the highlights"
                   : blur_source == "sphere"   ? "the silhouette's edge blur: too few highlights to fit it"
                                               : "given");
  for (const Highlight& h : highlights)
    if (!h.used) s += fmt::format("\n  not used {} ({:g} deg): {}", h.name, h.table_angle_deg, h.reason);
  return s;
}

std::string ScaleCalibration::describe() const {
  std::string s = fmt::format(
      "scale: {:.6g} DN/s per (1/sr W/m^2 per W/sr) +- {:.3f} %, images agree within {:.3f} %, LED profile cos^n "
      "with n = {:.2f} +- {:.2f}; {} pixels, {} saturated ({:.3f} %)",
      scale, 100 * uncertainty_rel, 100 * spread_rel, profile_exponent, profile_exponent_std, pixels, saturated,
      100 * saturated_frac);
  if (scale_rgb)
    s += fmt::format("\n  per camera channel R, G, B: {:.6g}, {:.6g}, {:.6g} (white balance under the LED R/G {:.4f}, "
                     "B/G {:.4f})",
                     (*scale_rgb)[0], (*scale_rgb)[1], (*scale_rgb)[2], (*scale_rgb)[0] / (*scale_rgb)[1],
                     (*scale_rgb)[2] / (*scale_rgb)[1]);
  return s;
}

std::string DarkFrame::describe() const {
  return fmt::format(
      "dark: {} frames at {} exposure(s); black level {:.2f} DN, dark current {:.3g} DN/s, read noise {}\n"
      "  hot pixels: {} ({:.4f} %)",
      frame_count, exposures_s.size(), mean_bias_dn, mean_rate_dn_per_s,
      read_noise_measured ? fmt::format("{:.3g} DN", read_noise_dn)
                          : std::string("not measured (needs >= 2 frames at one exposure)"),
      hot_count, 100.0 * hot_fraction());
}

std::string ResponseCurve::describe() const {
  double worst_nonlin = 0.0;
  for (double v : report.nonlinearity_rel) worst_nonlin = std::max(worst_nonlin, v);
  std::string s = fmt::format(
      "response: {} method, {}-bit, {} channel(s), {} knots, {} images; used range {:.0f}..{:.0f} DN (black {:.1f} "
      "DN{})\n  linearity error {} (RMS {}), nonlinearity of the camera {}",
      to_string(method), bit_depth, channels, knots_dn.size(), report.exposure_ratio.size(), window.floor_dn,
      window.u_saturation(), window.black_dn, dark_subtracted ? ", dark frame subtracted" : "",
      percent(report.linearity_error_rel), percent(report.linearity_rms_rel), percent(worst_nonlin));
  if (noise.known())
    s += fmt::format("\n  noise: read {:.3g} DN, shot {:.3g} DN/e ({})", noise.read_noise_dn, noise.gain_dn_per_e,
                     noise.source);
  return s;
}

std::string FlatField::describe() const {
  std::string s = fmt::format(
      "flat: {} frames, mean signal {:.0f} DN; darkest/brightest corner {:.3f}, darkest corner/centre {:.3f}, pixel "
      "non-uniformity {}",
      frame_count, mean_signal_dn, corner_ratio, centre_to_corner, percent(prnu_rel));
  if (cfa) s += " (colour-filter array: each filter colour normalised on its own)";
  if (noise.known()) s += fmt::format("\n  conversion gain {:.4g} DN/e ({})", noise.gain_dn_per_e, noise.source);
  return s;
}

}  // namespace paintlab::calib
