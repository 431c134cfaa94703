#include "paintlab/core/rig.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "paintlab/core/error.h"

namespace fs = std::filesystem;

namespace paintlab {

std::vector<double> MeasurementPlan::angles_deg() const {
  std::vector<double> out;
  if (angle_step_deg <= 0) return out;
  long n = static_cast<long>(std::floor((angle_stop_deg - angle_start_deg) / angle_step_deg + 1e-9));
  for (long i = 0; i <= n; ++i) out.push_back(angle_start_deg + static_cast<double>(i) * angle_step_deg);
  return out;
}

std::vector<double> geometric_bracket(double min_s, double max_s, int count) {
  std::vector<double> out;
  if (count == 1) return {min_s};
  double ratio = std::pow(max_s / min_s, 1.0 / (count - 1));
  for (int i = 0; i < count; ++i) out.push_back(min_s * std::pow(ratio, i));
  out.back() = max_s;
  return out;
}

namespace {

const std::vector<std::string>& kinds_for(const std::string& role) {
  static const std::vector<std::string> turntable{"modbus-tcp", "modbus-rtu", "sim"};
  static const std::vector<std::string> light{"gpiod", "sim"};
  static const std::vector<std::string> camera{"aravis", "sim"};
  static const std::vector<std::string> filter_wheel{"serial", "sim"};
  if (role == "turntable") return turntable;
  if (role == "light") return light;
  if (role == "filter_wheel") return filter_wheel;
  return camera;
}

DeviceSection parse_device(const ConfigTable& devices, const std::string& role) {
  DeviceSection d;
  d.role = role;
  ConfigTable t = devices.table(role);
  d.kind = t.choice("kind", kinds_for(role));
  d.table = t;
  // The remaining keys of the section depend on the kind; the devices module reads and
  // checks them (paintlab rig validate runs that check too).
  for (const auto& k : t.keys()) t.accept(k);
  return d;
}

RigGeometry parse_geometry(const ConfigTable& t) {
  RigGeometry g;
  g.sphere_radius_m = t.number("sphere_radius_m", Bounds::open(0.001, 1.0));
  g.arm_radius_m = t.number("arm_radius_m", Bounds::open(0.01, 10.0));
  g.arm_height_m = t.number("arm_height_m", g.arm_height_m, Bounds::closed(-5.0, 5.0));
  g.arm_zero_deg = t.number("arm_zero_deg", g.arm_zero_deg, Bounds::closed(-360.0, 360.0));
  g.camera_distance_m = t.number("camera_distance_m", Bounds::open(0.01, 100.0));
  g.camera_height_m = t.number("camera_height_m", g.camera_height_m, Bounds::closed(-10.0, 10.0));
  g.focal_length_mm = t.number("focal_length_mm", g.focal_length_mm, Bounds::open(1.0, 2000.0));
  g.pixel_size_um = t.number("pixel_size_um", g.pixel_size_um, Bounds::open(0.1, 100.0));
  g.image_width_px = static_cast<int>(t.integer("image_width_px", g.image_width_px, Bounds::closed(16, 20000)));
  g.image_height_px = static_cast<int>(t.integer("image_height_px", g.image_height_px, Bounds::closed(16, 20000)));
  if (g.sphere_radius_m >= g.arm_radius_m) t.fail("arm_radius_m", "must be larger than sphere_radius_m");
  if (g.sphere_radius_m >= g.camera_distance_m) t.fail("camera_distance_m", "must be larger than sphere_radius_m");
  t.finish();
  return g;
}

MeasurementPlan parse_plan(const ConfigTable& t) {
  MeasurementPlan p;
  p.angle_start_deg = t.number("angle_start_deg", p.angle_start_deg, Bounds::closed(-360.0, 360.0));
  p.angle_stop_deg = t.number("angle_stop_deg", p.angle_stop_deg, Bounds::closed(-360.0, 360.0));
  p.angle_step_deg = t.number("angle_step_deg", p.angle_step_deg, Bounds::open(0.0, 360.0));
  if (p.angle_stop_deg < p.angle_start_deg)
    t.fail("angle_stop_deg", "must not be smaller than angle_start_deg (" + std::to_string(p.angle_start_deg) + ")");
  bool has_list = t.has("exposures_ms");
  bool has_range = t.has("bracket");
  if (has_list == has_range)
    t.fail(has_list ? "bracket" : "exposures_ms",
           "give the exposure bracket either as exposures_ms = [...] or as a [plan.bracket] table "
           "(min_ms, max_ms, count), exactly one of the two");
  if (has_list) {
    auto ms = t.numbers("exposures_ms", 1, 64, Bounds::open(0.0, 1e6));
    for (std::size_t i = 1; i < ms.size(); ++i)
      if (!(ms[i] > ms[i - 1])) t.fail("exposures_ms", "exposures must be strictly ascending");
    for (double v : ms) p.exposures_s.push_back(v * 1e-3);
  } else {
    ConfigTable b = t.table("bracket");
    double lo = b.number("min_ms", Bounds::open(0.0, 1e6));
    double hi = b.number("max_ms", Bounds::open(0.0, 1e6));
    int n = static_cast<int>(b.integer("count", Bounds::closed(1, 64)));
    if (hi < lo) b.fail("max_ms", "must not be smaller than min_ms");
    if (n > 1 && hi == lo) b.fail("max_ms", "must be larger than min_ms when count > 1");
    b.finish();
    for (double v : geometric_bracket(lo, hi, n)) p.exposures_s.push_back(v * 1e-3);
  }
  p.settle_s = t.number("settle_s", p.settle_s, Bounds::closed(0.0, 600.0));
  p.dark_frames = static_cast<int>(t.integer("dark_frames", p.dark_frames, Bounds::closed(0, 1000)));
  p.gain_db = t.number("gain_db", p.gain_db, Bounds::closed(0.0, 48.0));
  // What a sweep may be: each position is a journal entry, an HDR map and a turntable move,
  // so a step of 1e-7 deg (1.8 billion positions) is a typing error, not a plan.
  const double span = p.angle_stop_deg - p.angle_start_deg;
  const double positions = std::floor(span / p.angle_step_deg + 1e-9) + 1.0;
  if (p.angle_step_deg < kMinAngleStepDeg)
    t.fail("angle_step_deg", fmt::format("must be at least {:g} deg (a turntable's resolution; got {:g})",
                                         kMinAngleStepDeg, p.angle_step_deg));
  if (positions > kMaxPlanPositions)
    t.fail("angle_step_deg", fmt::format("gives {:.0f} light positions from {:g} to {:g} deg; a plan holds at most {} "
                                         "(a step of at least {:.3g} deg over this span)",
                                         positions, p.angle_start_deg, p.angle_stop_deg, kMaxPlanPositions,
                                         span / (kMaxPlanPositions - 1)));
  double bracket_s = 0.0;
  for (double e : p.exposures_s) bracket_s += e;
  const double sweep_h = (positions * (p.settle_s + bracket_s) + p.dark_frames * bracket_s) / 3600.0;
  if (sweep_h > kMaxPlanHours)
    t.fail(has_list ? "exposures_ms" : "bracket",
           fmt::format("the sweep would take at least {:.0f} h ({:.0f} positions x ({:g} s settle + {:g} s of "
                       "exposures), plus {} dark frames per exposure); a plan may take at most {:g} h",
                       sweep_h, positions, p.settle_s, bracket_s, p.dark_frames, kMaxPlanHours));
  t.finish();
  return p;
}

Tolerances parse_tolerances(const ConfigTable& t) {
  Tolerances x;
  x.reprojection_rms_px = t.number("reprojection_rms_px", x.reprojection_rms_px, Bounds::positive());
  x.min_views = static_cast<int>(t.integer("min_views", x.min_views, Bounds::closed(3, 1000)));
  x.response_error_rel = t.number("response_error_rel", x.response_error_rel, Bounds::positive());
  x.hot_pixel_frac = t.number("hot_pixel_frac", x.hot_pixel_frac, Bounds::closed(0.0, 1.0));
  x.dark_level_frac = t.number("dark_level_frac", x.dark_level_frac, Bounds::closed(0.0, 1.0));
  x.flat_min_ratio = t.number("flat_min_ratio", x.flat_min_ratio, Bounds::closed(0.0, 1.0));
  x.sphere_shift_mm = t.number("sphere_shift_mm", x.sphere_shift_mm, Bounds::positive());
  x.sphere_fit_rms_px = t.number("sphere_fit_rms_px", x.sphere_fit_rms_px, Bounds::positive());
  x.edge_width_px = t.number("edge_width_px", x.edge_width_px, Bounds::positive());
  x.light_angle_deg = t.number("light_angle_deg", x.light_angle_deg, Bounds::positive());
  x.light_drift_rel = t.number("light_drift_rel", x.light_drift_rel, Bounds::positive());
  x.scale_error_rel = t.number("scale_error_rel", x.scale_error_rel, Bounds::positive());
  x.saturated_frac = t.number("saturated_frac", x.saturated_frac, Bounds::closed(0.0, 1.0));
  x.calibration_max_age_days = t.number("calibration_max_age_days", x.calibration_max_age_days, Bounds::positive());
  x.colour_mean_de00 = t.number("colour_mean_de00", x.colour_mean_de00, Bounds::positive());
  x.colour_max_de00 = t.number("colour_max_de00", x.colour_max_de00, Bounds::positive());
  t.finish();
  return x;
}

}  // namespace

RigConfig RigConfig::load(const fs::path& path) {
  ConfigTable root = ConfigTable::parse_file(path);
  return parse(root, fs::absolute(path));
}

RigConfig RigConfig::parse(const ConfigTable& root, const fs::path& file) {
  RigConfig rig;
  rig.file = file;
  rig.name = root.string("name");
  if (rig.name.empty() || rig.name.find_first_not_of("abcdefghijklmnopqrstuvwxyz0123456789._-") != std::string::npos)
    root.fail("name", "must be non-empty and use only a-z 0-9 . _ -");
  std::string calib = root.string("calibration", "calib");
  if (calib.empty()) root.fail("calibration", "must name a folder");
  rig.calibration_dir = fs::path(calib).is_absolute() ? fs::path(calib) : file.parent_path() / calib;
  ConfigTable devices = root.table("devices");
  rig.turntable = parse_device(devices, "turntable");
  rig.light = parse_device(devices, "light");
  rig.camera = parse_device(devices, "camera");
  if (devices.has("filter_wheel")) rig.filter_wheel = parse_device(devices, "filter_wheel");
  devices.finish();
  rig.geometry = parse_geometry(root.table("geometry"));
  rig.plan = parse_plan(root.table("plan"));
  if (auto t = root.maybe_table("tolerances")) rig.tolerances = parse_tolerances(*t);
  rig.sim = root.maybe_table("sim");
  if (rig.sim) {
    for (const auto& k : rig.sim->keys()) rig.sim->accept(k);
  }
  root.finish();
  return rig;
}

bool RigConfig::all_simulated() const {
  return turntable.kind == "sim" && light.kind == "sim" && camera.kind == "sim" &&
         (!filter_wheel || filter_wheel->kind == "sim");
}

std::string RigConfig::describe() const {
  const auto& g = geometry;
  const auto& p = plan;
  std::string s = fmt::format("rig '{}' ({}): valid\n", name, file.string());
  s += fmt::format("  calibration folder  {}\n", calibration_dir.string());
  s += fmt::format("  turntable           {}\n  light               {}\n  camera              {}\n", turntable.kind,
                   light.kind, camera.kind);
  if (filter_wheel) s += fmt::format("  filter wheel        {}\n", filter_wheel->kind);
  s += fmt::format("  sphere radius       {:.2f} mm\n", g.sphere_radius_m * 1e3);
  s += fmt::format("  arm                 radius {:.1f} mm, height {:.1f} mm, zero {:.2f} deg\n", g.arm_radius_m * 1e3,
                   g.arm_height_m * 1e3, g.arm_zero_deg);
  s += fmt::format("  camera              {:.1f} mm away, {:.1f} mm up, f {:.1f} mm, {}x{} px of {:.2f} um\n",
                   g.camera_distance_m * 1e3, g.camera_height_m * 1e3, g.focal_length_mm, g.image_width_px,
                   g.image_height_px, g.pixel_size_um);
  s += fmt::format("  light angles        {} positions, {:g} to {:g} deg in {:g} deg steps\n", p.angles_deg().size(),
                   p.angle_start_deg, p.angle_stop_deg, p.angle_step_deg);
  s += fmt::format("  exposure bracket    {} exposures, {:.4g} ms to {:.4g} ms\n", p.exposures_s.size(),
                   p.exposures_s.front() * 1e3, p.exposures_s.back() * 1e3);
  if (sim) s += "  simulator           [sim] valid\n";
  return s;
}

Json RigConfig::to_json() const {
  const auto& g = geometry;
  const auto& p = plan;
  const auto& t = tolerances;
  Json exposures_ms = Json::array();
  for (double e : p.exposures_s) exposures_ms.push_back(e * 1e3);
  Json j{
      {"name", name},
      {"file", file.string()},
      {"calibration", calibration_dir.string()},
      {"devices",
       {{"turntable", {{"kind", turntable.kind}}}, {"light", {{"kind", light.kind}}}, {"camera", {{"kind", camera.kind}}}}},
      {"geometry",
       {{"sphere_radius_m", g.sphere_radius_m},
        {"arm_radius_m", g.arm_radius_m},
        {"arm_height_m", g.arm_height_m},
        {"arm_zero_deg", g.arm_zero_deg},
        {"camera_distance_m", g.camera_distance_m},
        {"camera_height_m", g.camera_height_m},
        {"focal_length_mm", g.focal_length_mm},
        {"pixel_size_um", g.pixel_size_um},
        {"image_width_px", g.image_width_px},
        {"image_height_px", g.image_height_px}}},
      {"plan",
       {{"angle_start_deg", p.angle_start_deg},
        {"angle_stop_deg", p.angle_stop_deg},
        {"angle_step_deg", p.angle_step_deg},
        {"positions", p.angles_deg().size()},
        {"exposures_ms", exposures_ms},
        {"settle_s", p.settle_s},
        {"dark_frames", p.dark_frames},
        {"gain_db", p.gain_db}}},
      {"tolerances",
       {{"reprojection_rms_px", t.reprojection_rms_px},
        {"min_views", t.min_views},
        {"response_error_rel", t.response_error_rel},
        {"hot_pixel_frac", t.hot_pixel_frac},
        {"dark_level_frac", t.dark_level_frac},
        {"flat_min_ratio", t.flat_min_ratio},
        {"sphere_shift_mm", t.sphere_shift_mm},
        {"sphere_fit_rms_px", t.sphere_fit_rms_px},
        {"edge_width_px", t.edge_width_px},
        {"light_angle_deg", t.light_angle_deg},
        {"light_drift_rel", t.light_drift_rel},
        {"scale_error_rel", t.scale_error_rel},
        {"saturated_frac", t.saturated_frac},
        {"calibration_max_age_days", t.calibration_max_age_days},
        {"colour_mean_de00", t.colour_mean_de00},
        {"colour_max_de00", t.colour_max_de00}}},
      {"simulated", all_simulated()}};
  if (filter_wheel) j["devices"]["filter_wheel"] = {{"kind", filter_wheel->kind}};
  return j;
}

}  // namespace paintlab
