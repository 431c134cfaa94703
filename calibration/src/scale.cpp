#include "paintlab/calibration/scale.h"

#include <algorithm>
#include <cmath>
#include <fmt/format.h>

#include "paintlab/core/error.h"
#include "paintlab/core/robust.h"

namespace paintlab::calib {

void ScaleOptions::check() const {
  if (!(albedo > 0.0 && albedo <= 1.0))
    throw UsageError("scale: the reference albedo must be in (0, 1] (got " + std::to_string(albedo) + ")");
  if (!(min_cos > 0.0 && min_cos < 1.0)) throw UsageError("scale: min_cos must be in (0, 1)");
  if (!(profile_exponent >= 0.0)) throw UsageError("scale: profile_exponent must be >= 0");
}

namespace {

struct Sample {
  double log_ratio;  // log(V / (albedo/pi cos_i / d^2)) = log s + n log cos(alpha)
  double log_cos_alpha;
  int image;
};

}  // namespace

ScaleCalibration calibrate_scale(const std::vector<ReferenceImage>& images, const CameraModel& camera,
                                 const SphereFit& sphere, const LightModel& light, const ScaleOptions& options) {
  options.check();
  if (images.empty()) throw UsageError("scale: no reference images given");
  ScaleCalibration cal;
  cal.albedo = options.albedo;
  const Vec3 C = sphere.centre_cam_m;
  const double R = sphere.radius_m;
  LightModel geo = light;
  geo.profile_exponent = 0.0;  // irradiance without the profile: the profile is fitted here
  const double rho_px = camera.fx() * R / C.norm();
  const Vec2 cpx = camera.project(C);
  std::vector<Sample> samples;
  for (std::size_t k = 0; k < images.size(); ++k) {
    const ReferenceImage& im = images[k];
    if (im.rate.width() != camera.width_px || im.rate.height() != camera.height_px || im.rate.channels() != 1)
      throw DataError(fmt::format("scale: image '{}' must be one channel of {}x{}", im.name, camera.width_px,
                                  camera.height_px));
    const bool has_sat = !im.saturated.empty();
    if (has_sat && (im.saturated.width() != im.rate.width() || im.saturated.height() != im.rate.height()))
      throw DataError("scale: the saturation mask of '" + im.name + "' has another size");
    ScaleImageReport rep;
    rep.table_angle_deg = im.table_angle_deg;
    rep.name = im.name;
    const Vec3 L = geo.led_position_cam(im.table_angle_deg);
    const Vec3 led_axis = geo.led_axis_cam(im.table_angle_deg);
    const int x0 = std::max(0, static_cast<int>(cpx.x() - rho_px - 3)), x1 = std::min(camera.width_px - 1, static_cast<int>(cpx.x() + rho_px + 3));
    const int y0 = std::max(0, static_cast<int>(cpx.y() - rho_px - 3)), y1 = std::min(camera.height_px - 1, static_cast<int>(cpx.y() + rho_px + 3));
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) {
        auto X = intersect_sphere(camera.ray(Vec2(x, y)), C, R);
        if (!X) continue;
        const Vec3 n = (*X - C) / R;
        const Vec3 wo = (-*X).normalized();
        const Vec3 to_led = L - *X;
        const double d2 = to_led.squaredNorm();
        const Vec3 wi = to_led / std::sqrt(d2);
        const double cos_i = n.dot(wi), cos_o = n.dot(wo);
        if (cos_i < options.min_cos || cos_o < options.min_cos) continue;
        if (has_sat && im.saturated.at(x, y)) {
          ++rep.saturated;
          continue;
        }
        const double v = im.rate.at(x, y);
        if (!(v > 0) || !std::isfinite(v)) continue;
        const double cos_alpha = std::clamp(led_axis.dot(-wi), 1e-6, 1.0);
        samples.push_back({std::log(v / (options.albedo / kPi * cos_i / d2)), std::log(cos_alpha), static_cast<int>(k)});
        ++rep.pixels;
      }
    cal.saturated += rep.saturated;
    cal.images.push_back(rep);
  }
  if (samples.size() < 100) {
    std::string why;
    for (const auto& r : cal.images)
      why += fmt::format("\n  {} ({:g} deg): {} usable pixels, {} saturated", r.name, r.table_angle_deg, r.pixels, r.saturated);
    throw CalibrationError(fmt::format("scale: only {} usable reference pixels (is the LED on, the reference sphere in "
                                       "place, the exposure short enough?){}",
                                       samples.size(), why));
  }
  // Robust line fit: a median-based outlier cut (hot pixels, dust), then least squares.
  std::vector<double> lr;
  for (const auto& s : samples) lr.push_back(s.log_ratio);
  const double med = upper_median(lr);
  const double cut = 6.0 * kMadToSigma * std::max(upper_mad(lr, med), 1e-6);
  double n_exp = options.fit_profile ? 0.0 : options.profile_exponent;
  double log_s = med;
  double var_res = 0, sxx = 0;
  long long used = 0;
  for (int pass = 0; pass < 2; ++pass) {
    double S = 0, Sx = 0, Sy = 0, Sxx = 0, Sxy = 0;
    for (const auto& s : samples) {
      const double pred = log_s + n_exp * s.log_cos_alpha;
      if (std::abs(s.log_ratio - pred) > cut) continue;
      S += 1;
      Sx += s.log_cos_alpha;
      Sy += s.log_ratio;
      Sxx += s.log_cos_alpha * s.log_cos_alpha;
      Sxy += s.log_cos_alpha * s.log_ratio;
    }
    const double det = S * Sxx - Sx * Sx;
    if (options.fit_profile && det > 1e-18 * S * S) {
      n_exp = (S * Sxy - Sx * Sy) / det;
      log_s = (Sy - n_exp * Sx) / S;
    } else {
      log_s = (Sy - n_exp * Sx) / S;
    }
    used = static_cast<long long>(S);
    sxx = Sxx - Sx * Sx / S;
  }
  std::vector<double> per_image_sum(images.size(), 0.0), per_image_n(images.size(), 0.0);
  for (const auto& s : samples) {
    const double r = s.log_ratio - (log_s + n_exp * s.log_cos_alpha);
    if (std::abs(r) > cut) continue;
    var_res += r * r;
    per_image_sum[static_cast<std::size_t>(s.image)] += r;
    per_image_n[static_cast<std::size_t>(s.image)] += 1;
  }
  var_res /= std::max<long long>(1, used - 2);
  cal.scale = std::exp(log_s);
  cal.profile_exponent = n_exp;
  cal.profile_exponent_std = options.fit_profile && sxx > 0 ? std::sqrt(var_res / sxx) : 0.0;
  cal.pixels = used;
  cal.residual_rel = std::sqrt(var_res);
  cal.saturated_frac = static_cast<double>(cal.saturated) / static_cast<double>(cal.saturated + used);
  // Per-image scales and their spread.
  std::vector<double> scales;
  for (std::size_t k = 0; k < images.size(); ++k) {
    if (per_image_n[k] > 0) {
      cal.images[k].scale = cal.scale * std::exp(per_image_sum[k] / per_image_n[k]);
      scales.push_back(cal.images[k].scale);
    }
  }
  double mean = 0, var = 0;
  for (double s : scales) mean += s / static_cast<double>(scales.size());
  for (double s : scales) var += (s - mean) * (s - mean);
  cal.spread_rel = scales.size() > 1 ? std::sqrt(var / static_cast<double>(scales.size() - 1)) / mean : 0.0;
  const double stat = cal.residual_rel / std::sqrt(static_cast<double>(std::max<long long>(1, used)));
  const double between = scales.size() > 1 ? cal.spread_rel / std::sqrt(static_cast<double>(scales.size())) : 0.0;
  cal.uncertainty_rel = std::sqrt(stat * stat + between * between);
  cal.provenance = Provenance::make("scale", {});
  return cal;
}

std::optional<std::array<double, 3>> ScaleCalibration::white_balance() const {
  if (!scale_rgb) return std::nullopt;
  std::array<double, 3> b{};
  for (std::size_t c = 0; c < 3; ++c) b[c] = scale / (*scale_rgb)[c];
  return b;
}

Json ScaleCalibration::to_json() const {
  Json im = Json::array();
  for (const auto& r : images)
    im.push_back({{"table_angle_deg", r.table_angle_deg},
                  {"name", r.name},
                  {"pixels", r.pixels},
                  {"saturated", r.saturated},
                  {"scale", r.scale}});
  return {{"scale", scale},
          {"units", "linear DN/s per (1/sr x W/m^2 per W/sr of LED intensity)"},
          {"uncertainty_rel", uncertainty_rel},
          {"spread_rel", spread_rel},
          {"profile_exponent", profile_exponent},
          {"profile_exponent_std", profile_exponent_std},
          {"albedo", albedo},
          {"pixels", pixels},
          {"saturated", saturated},
          {"saturated_frac", saturated_frac},
          {"residual_rel", residual_rel},
          {"images", im},
          {"scale_rgb", scale_rgb ? Json(*scale_rgb) : Json()},
          {"provenance", provenance.to_json()}};
}

ScaleCalibration ScaleCalibration::from_json(const Json& j, const std::string& where) {
  ScaleCalibration c;
  c.scale = json_get<double>(j, "scale", where);
  if (!(c.scale > 0)) throw DataError(where + ": key 'scale' must be > 0");
  c.uncertainty_rel = json_get_or<double>(j, "uncertainty_rel", 0.0, where);
  c.spread_rel = json_get_or<double>(j, "spread_rel", 0.0, where);
  c.profile_exponent = json_get_or<double>(j, "profile_exponent", 0.0, where);
  c.profile_exponent_std = json_get_or<double>(j, "profile_exponent_std", 0.0, where);
  c.albedo = json_get_or<double>(j, "albedo", 0.0, where);
  c.pixels = json_get_or<long long>(j, "pixels", 0, where);
  c.saturated = json_get_or<long long>(j, "saturated", 0, where);
  c.saturated_frac = json_get_or<double>(j, "saturated_frac", 0.0, where);
  c.residual_rel = json_get_or<double>(j, "residual_rel", 0.0, where);
  if (j.contains("images"))
    for (const Json& o : j.at("images"))
      c.images.push_back({json_get<double>(o, "table_angle_deg", where), json_get_or<std::string>(o, "name", "", where),
                          json_get_or<long long>(o, "pixels", 0, where), json_get_or<long long>(o, "saturated", 0, where),
                          json_get_or<double>(o, "scale", 0.0, where)});
  if (j.contains("scale_rgb") && !j.at("scale_rgb").is_null()) {
    const std::vector<double> rgb = json_get<std::vector<double>>(j, "scale_rgb", where);
    if (rgb.size() != 3 || !(rgb[0] > 0 && rgb[1] > 0 && rgb[2] > 0))
      throw DataError(where + ": key 'scale_rgb' must hold three scales > 0 (R, G, B)");
    c.scale_rgb = std::array<double, 3>{rgb[0], rgb[1], rgb[2]};
  }
  if (j.contains("provenance")) c.provenance = Provenance::from_json(j.at("provenance"), where);
  return c;
}

void ScaleCalibration::save(const std::filesystem::path& path) const { write_json_file(path, to_json()); }

ScaleCalibration ScaleCalibration::load(const std::filesystem::path& path) {
  return from_json(read_json_file(path), path.string());
}

}  // namespace paintlab::calib
