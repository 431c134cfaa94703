#include "paintlab/sim/config.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <set>
#include <string>

#include "paintlab/core/error.h"

namespace paintlab::sim {

Rigid3 CameraTruth::cam_from_rig() const {
  Rigid3 cam_from_rig = look_at(position_rig_m, look_at_rig_m, Vec3::UnitZ());
  if (roll_deg != 0.0) {
    Rigid3 roll;
    roll.rotation = Eigen::Quaterniond(Eigen::AngleAxisd(deg_to_rad(roll_deg), Vec3::UnitZ()));
    cam_from_rig = roll * cam_from_rig;
  }
  return cam_from_rig;
}

Mat3 CameraTruth::K() const {
  Mat3 k;
  k << fx_px, 0.0, cx_px, 0.0, fy_px, cy_px, 0.0, 0.0, 1.0;
  return k;
}

double SensorParams::gain0_dn_per_e() const {
  if (conversion_gain_dn_per_e > 0) return conversion_gain_dn_per_e;
  return (adc_max_dn() - black_level_dn) / full_well_e;
}

namespace {

Vec3 to_vec(const std::array<double, 3>& a) { return {a[0], a[1], a[2]}; }

Vec3 vec_or(const ConfigTable& t, const char* key, const Vec3& fallback, Bounds b = {}) {
  if (!t.has(key)) return fallback;
  return to_vec(t.triple(key, b));
}

// The response curve must start at 0, end at 1 and rise in between.
void check_response(const std::vector<double>& c, const std::function<void(const std::string&)>& fail) {
  double sum = 0;
  for (double v : c) sum += v;
  if (std::abs(sum - 1.0) > 1e-6)
    fail(fmt::format("the coefficients must sum to 1 so that R(1) = 1 (they sum to {:g})", sum));
  for (int i = 0; i <= 1000; ++i) {
    double x = i / 1000.0, d = 0, p = 1;
    for (std::size_t k = 0; k < c.size(); ++k) {
      d += static_cast<double>(k + 1) * c[k] * p;
      p *= x;
    }
    if (!(d > 0)) fail(fmt::format("R(x) must increase on [0, 1]; its slope is {:g} at x = {:g}", d, x));
  }
}

void check_geometry(const SimConfig& c, const std::function<void(const char* section, const char* key,
                                                                 const std::string&)>& fail) {
  const auto& s = c.sphere;
  const auto& l = c.led;
  const auto& sc = c.scene;
  double centre_xy = s.centre_rig_m.head<2>().norm();
  if (l.arm_radius_m - centre_xy <= s.radius_m + sc.arm_post_radius_m)
    fail("led", "arm_radius_m", "the LED arm must pass outside the sphere (arm radius > sphere radius + offset + post)");
  if ((c.camera.position_rig_m - s.centre_rig_m).norm() <= s.radius_m * 1.5)
    fail("camera", "position_m", "the camera must be outside the sphere (more than 1.5 radii from its centre)");
  if (s.centre_rig_m.z() - s.radius_m <= -sc.table_depth_m)
    fail("scene", "table_depth_m", "the table top must lie below the sphere's bottom");
  if (l.arm_height_m <= -sc.table_depth_m) fail("led", "arm_height_m", "the LED must be above the table top");
  if (sc.backdrop_distance_m <= l.arm_radius_m + sc.arm_post_radius_m)
    fail("scene", "backdrop_distance_m", "the backdrop must lie beyond the LED arm");
  if (l.aim_rig_m.head<2>().norm() >= 0.9 * l.arm_radius_m)
    fail("led", "aim_m", "the LED must aim at a point well inside its circle (|xy| < 0.9 arm radius)");
  if ((c.camera.look_at_rig_m - c.camera.position_rig_m).norm() < 1e-6)
    fail("camera", "look_at_m", "the camera cannot look at its own centre");
}

const std::set<std::string>& top_level_keys() {
  static const std::set<std::string> keys{"seed", "flake_seed", "clock_speed", "camera", "sensor", "led", "sphere", "scene", "render", "filters"};
  return keys;
}

}  // namespace

SimConfig SimConfig::defaults(const RigGeometry& g) {
  SimConfig c;
  c.nominal = g;
  auto& cam = c.camera;
  cam.width_px = g.image_width_px;
  cam.height_px = g.image_height_px;
  cam.pixel_size_m = g.pixel_size_um * 1e-6;
  cam.fx_px = cam.fy_px = g.focal_length_mm * 1e-3 / cam.pixel_size_m;
  cam.cx_px = (cam.width_px - 1) / 2.0;
  cam.cy_px = (cam.height_px - 1) / 2.0;
  double h = std::clamp(g.camera_height_m, -0.99 * g.camera_distance_m, 0.99 * g.camera_distance_m);
  cam.position_rig_m = Vec3(std::sqrt(g.camera_distance_m * g.camera_distance_m - h * h), 0.0, h);
  cam.look_at_rig_m = Vec3::Zero();
  c.led.arm_radius_m = g.arm_radius_m;
  c.led.arm_height_m = g.arm_height_m;
  c.led.zero_deg = g.arm_zero_deg;
  c.sphere.radius_m = g.sphere_radius_m;
  c.scene.table_depth_m = std::max(c.scene.table_depth_m, 1.5 * g.sphere_radius_m);
  c.scene.backdrop_distance_m = std::max(c.scene.backdrop_distance_m, 1.5 * g.arm_radius_m);
  return c;
}

SimConfig SimConfig::from_rig(const RigConfig& rig) {
  if (rig.sim) return parse(*rig.sim, rig.geometry);
  SimConfig c = defaults(rig.geometry);
  c.check();
  return c;
}

SimConfig SimConfig::parse(const ConfigTable& sim, const RigGeometry& nominal) {
  SimConfig c = defaults(nominal);
  // RigConfig marks the [sim] keys as read (they belong to us), so finish() cannot catch
  // a misspelt top-level key here: check those against our list.
  for (const auto& k : sim.keys())
    if (!top_level_keys().count(k)) sim.fail(k, "unknown key in [" + sim.path("") + "]");
  c.seed = static_cast<std::uint64_t>(sim.integer("seed", 1, Bounds::closed(0, 9.0e15)));
  if (sim.has("flake_seed"))
    c.flake_seed = static_cast<std::uint64_t>(sim.integer("flake_seed", 1, Bounds::closed(0, 9.0e15)));
  c.clock_speed = sim.number("clock_speed", 0.0, Bounds::closed(0.0, 1e9));

  if (auto t = sim.maybe_table("camera")) {
    auto& cam = c.camera;
    cam.fx_px = t->number("fx_px", cam.fx_px, Bounds::open(1.0, 1e6));
    cam.fy_px = t->number("fy_px", cam.fy_px, Bounds::open(1.0, 1e6));
    cam.cx_px = t->number("cx_px", cam.cx_px, Bounds::closed(-0.5, cam.width_px - 0.5));
    cam.cy_px = t->number("cy_px", cam.cy_px, Bounds::closed(-0.5, cam.height_px - 0.5));
    if (t->has("dist")) {
      auto d = t->numbers("dist", 5, 5, Bounds::closed(-10.0, 10.0));
      std::copy(d.begin(), d.end(), cam.dist.begin());
    }
    cam.position_rig_m = vec_or(*t, "position_m", cam.position_rig_m, Bounds::closed(-100, 100));
    cam.look_at_rig_m = vec_or(*t, "look_at_m", cam.look_at_rig_m, Bounds::closed(-100, 100));
    cam.roll_deg = t->number("roll_deg", cam.roll_deg, Bounds::closed(-180.0, 180.0));
    cam.f_number = t->number("f_number", cam.f_number, Bounds::closed(0.5, 64.0));
    cam.psf_sigma_px = t->number("psf_sigma_px", cam.psf_sigma_px, Bounds::closed(0.0, 10.0));
    if (t->has("vignetting")) {
      auto v = t->numbers("vignetting", 2, 2, Bounds::closed(-1.0, 1.0));
      cam.vignetting = {v[0], v[1]};
      for (int i = 0; i <= 100; ++i) {
        double r2 = i / 100.0;
        if (1.0 + v[0] * r2 + v[1] * r2 * r2 <= 0.05)
          t->fail("vignetting", "the factor 1 + v0 rho^2 + v1 rho^4 must stay above 0.05 inside the image");
      }
    }
    if (t->has("mono_weights")) {
      auto w = t->triple("mono_weights", Bounds::closed(0.0, 1.0));
      if (std::abs(w[0] + w[1] + w[2] - 1.0) > 1e-6) t->fail("mono_weights", "the weights must sum to 1");
      cam.mono_weights = w;
    }
    if (t->has("rgb_matrix")) {
      auto m = t->numbers("rgb_matrix", 9, 9, Bounds::closed(-10.0, 10.0));
      const double det = m[0] * (m[4] * m[8] - m[5] * m[7]) - m[1] * (m[3] * m[8] - m[5] * m[6]) +
                         m[2] * (m[3] * m[7] - m[4] * m[6]);
      if (!(std::abs(det) > 1e-6))
        t->fail("rgb_matrix", "the channel mix must be invertible (a camera that cannot tell colours apart)");
      std::copy(m.begin(), m.end(), cam.rgb_matrix.begin());
    }
    if (t->has("rgb_gain")) cam.rgb_gain = t->triple("rgb_gain", Bounds{0.0, 10.0, true, false});
    // A mis-centred camera still has to see the sphere: checked by SimWorld (it needs the projection).
    t->finish();
  }

  if (auto t = sim.maybe_table("sensor")) {
    auto& s = c.sensor;
    s.qe = t->number("qe", s.qe, Bounds{0.0, 1.0, true, false});
    s.wavelength_nm = t->number("wavelength_nm", s.wavelength_nm, Bounds::closed(200.0, 2000.0));
    s.full_well_e = t->number("full_well_e", s.full_well_e, Bounds::closed(100.0, 1e7));
    s.adc_bits = static_cast<int>(t->integer("adc_bits", s.adc_bits, Bounds::closed(8, 16)));
    s.black_level_dn = t->number("black_level_dn", s.black_level_dn, Bounds::closed(0.0, s.adc_max_dn() / 4));
    s.conversion_gain_dn_per_e = t->number("conversion_gain_dn_per_e", s.conversion_gain_dn_per_e,
                                           Bounds::closed(0.0, 1000.0));
    s.read_noise_e = t->number("read_noise_e", s.read_noise_e, Bounds::closed(0.0, 1000.0));
    s.dark_current_e_per_s = t->number("dark_current_e_per_s", s.dark_current_e_per_s, Bounds::closed(0.0, 1e6));
    s.hot_pixel_frac = t->number("hot_pixel_frac", s.hot_pixel_frac, Bounds::closed(0.0, 0.1));
    s.hot_pixel_dark_e_per_s = t->number("hot_pixel_dark_e_per_s", s.hot_pixel_dark_e_per_s, Bounds::closed(0.0, 1e8));
    s.prnu_rel = t->number("prnu_rel", s.prnu_rel, Bounds::closed(0.0, 0.2));
    if (t->has("response")) {
      s.response_poly = t->numbers("response", 1, 8, Bounds::closed(-10.0, 10.0));
      check_response(s.response_poly, [&](const std::string& m) { t->fail("response", m); });
    }
    s.readout_s = t->number("readout_s", s.readout_s, Bounds::closed(0.0, 10.0));
    t->finish();
  }

  if (auto t = sim.maybe_table("led")) {
    auto& l = c.led;
    l.arm_radius_m = t->number("arm_radius_m", l.arm_radius_m, Bounds::open(0.01, 10.0));
    l.arm_height_m = t->number("arm_height_m", l.arm_height_m, Bounds::closed(-5.0, 5.0));
    l.zero_deg = t->number("zero_deg", l.zero_deg, Bounds::closed(-360.0, 360.0));
    l.intensity_w_sr = t->number("intensity_w_sr", l.intensity_w_sr, Bounds::open(0.0, 1e6));
    if (t->has("color")) l.color = t->triple("color", Bounds::closed(0.0, 100.0));
    l.profile_exponent = t->number("profile_exponent", l.profile_exponent, Bounds::closed(0.0, 1000.0));
    l.aim_rig_m = vec_or(*t, "aim_m", l.aim_rig_m, Bounds::closed(-100, 100));
    t->finish();
  }

  if (auto t = sim.maybe_table("sphere")) {
    auto& s = c.sphere;
    s.radius_m = t->number("radius_m", s.radius_m, Bounds::open(0.001, 1.0));
    s.centre_rig_m = vec_or(*t, "centre_m", s.centre_rig_m, Bounds::closed(-0.5, 0.5));
    t->finish();
  }

  if (auto t = sim.maybe_table("scene")) {
    auto& s = c.scene;
    s.felt_albedo = t->number("felt_albedo", s.felt_albedo, Bounds::closed(0.0, 1.0));
    s.table_depth_m = t->number("table_depth_m", s.table_depth_m, Bounds::open(0.0, 10.0));
    s.table_radius_m = t->number("table_radius_m", s.table_radius_m, Bounds::closed(0.0, 10.0));
    s.pedestal_radius_m = t->number("pedestal_radius_m", s.pedestal_radius_m, Bounds::closed(0.0, 1.0));
    s.arm_post_radius_m = t->number("arm_post_radius_m", s.arm_post_radius_m, Bounds::closed(0.0, 1.0));
    s.backdrop_distance_m = t->number("backdrop_distance_m", s.backdrop_distance_m, Bounds::open(0.0, 100.0));
    if (s.pedestal_radius_m >= c.sphere.radius_m)
      t->fail("pedestal_radius_m", "must be smaller than the sphere radius");
    t->finish();
  }

  if (auto t = sim.maybe_table("render")) {
    auto& r = c.render;
    r.edge_samples = static_cast<int>(t->integer("edge_samples", r.edge_samples, Bounds::closed(1, 64)));
    r.edge_shading_samples =
        static_cast<int>(t->integer("edge_shading_samples", r.edge_shading_samples, Bounds::closed(1, 16)));
    r.interior_samples = static_cast<int>(t->integer("interior_samples", r.interior_samples, Bounds::closed(1, 16)));
    r.interior_tolerance = t->number("interior_tolerance", r.interior_tolerance, Bounds{0.0, 1.0, true, false});
    r.sparkle_floor = t->number("sparkle_floor", r.sparkle_floor, Bounds{0.0, 1e6, true, false});
    t->finish();
  }

  if (auto t = sim.maybe_table("filters")) {
    auto& f = c.filters;
    for (auto [key, value] : {std::pair{"red", &f.red}, {"green", &f.green}, {"blue", &f.blue}})
      if (t->has(key)) *value = t->triple(key, Bounds::closed(0.0, 1.0));
    t->finish();
  }

  check_geometry(c, [&](const char* section, const char* key, const std::string& message) {
    if (auto t = sim.maybe_table(section); t && t->has(key)) t->fail(key, message);
    sim.fail(section, std::string(key) + ": " + message);
  });
  return c;
}

void SimConfig::check() const {
  auto fail = [](const std::string& what, const std::string& message) {
    throw DataError("simulator configuration: " + what + ": " + message);
  };
  if (camera.width_px < 2 || camera.height_px < 2) fail("camera size", "must be at least 2 x 2 pixels");
  if (!(camera.fx_px > 0 && camera.fy_px > 0)) fail("camera.fx_px/fy_px", "must be > 0");
  if (!(camera.pixel_size_m > 0)) fail("camera.pixel_size_m", "must be > 0");
  if (!(camera.f_number > 0)) fail("camera.f_number", "must be > 0");
  if (!(camera.psf_sigma_px >= 0 && camera.psf_sigma_px <= 10)) fail("camera.psf_sigma_px", "must be in [0, 10]");
  if (sensor.adc_bits < 8 || sensor.adc_bits > 16) fail("sensor.adc_bits", "must be in [8, 16]");
  if (!(sensor.qe > 0 && sensor.qe <= 1)) fail("sensor.qe", "must be in (0, 1]");
  if (!(sensor.full_well_e > 0)) fail("sensor.full_well_e", "must be > 0");
  if (!(sensor.black_level_dn >= 0 && sensor.black_level_dn < sensor.adc_max_dn()))
    fail("sensor.black_level_dn", "must be in [0, ADC maximum)");
  if (sensor.response_poly.empty()) fail("sensor.response", "needs at least one coefficient");
  check_response(sensor.response_poly, [&](const std::string& m) { fail("sensor.response", m); });
  if (!(sphere.radius_m > 0)) fail("sphere.radius_m", "must be > 0");
  if (!(led.intensity_w_sr > 0)) fail("led.intensity_w_sr", "must be > 0");
  if (render.edge_samples < 1 || render.edge_shading_samples < 1) fail("render samples", "must be >= 1");
  if (render.interior_samples < 1) fail("render.interior_samples", "must be >= 1");
  if (!(render.interior_tolerance > 0 && render.interior_tolerance <= 1))
    fail("render.interior_tolerance", "must be in (0, 1]");
  if (!(render.sparkle_floor > 0)) fail("render.sparkle_floor", "must be > 0");
  if (!(clock_speed >= 0)) fail("clock_speed", "must be >= 0");
  check_geometry(*this, [&](const char* section, const char* key, const std::string& message) {
    fail(std::string(section) + "." + key, message);
  });
}

Json SimConfig::to_json() const {
  auto v3 = [](const Vec3& v) { return Json::array({v.x(), v.y(), v.z()}); };
  const auto& cam = camera;
  const auto& s = sensor;
  Json j{
      {"seed", seed},
      {"clock_speed", clock_speed},
      {"camera",
       {{"width_px", cam.width_px},
        {"height_px", cam.height_px},
        {"fx_px", cam.fx_px},
        {"fy_px", cam.fy_px},
        {"cx_px", cam.cx_px},
        {"cy_px", cam.cy_px},
        {"dist", cam.dist},
        {"pixel_size_m", cam.pixel_size_m},
        {"position_m", v3(cam.position_rig_m)},
        {"look_at_m", v3(cam.look_at_rig_m)},
        {"roll_deg", cam.roll_deg},
        {"f_number", cam.f_number},
        {"psf_sigma_px", cam.psf_sigma_px},
        {"vignetting", cam.vignetting},
        {"mono_weights", cam.mono_weights},
        {"rgb_matrix", cam.rgb_matrix},
        {"rgb_gain", cam.rgb_gain}}},
      {"sensor",
       {{"qe", s.qe},
        {"wavelength_nm", s.wavelength_nm},
        {"full_well_e", s.full_well_e},
        {"adc_bits", s.adc_bits},
        {"black_level_dn", s.black_level_dn},
        {"conversion_gain_dn_per_e", s.gain0_dn_per_e()},
        {"read_noise_e", s.read_noise_e},
        {"dark_current_e_per_s", s.dark_current_e_per_s},
        {"hot_pixel_frac", s.hot_pixel_frac},
        {"hot_pixel_dark_e_per_s", s.hot_pixel_dark_e_per_s},
        {"prnu_rel", s.prnu_rel},
        {"response", s.response_poly},
        {"readout_s", s.readout_s}}},
      {"led",
       {{"arm_radius_m", led.arm_radius_m},
        {"arm_height_m", led.arm_height_m},
        {"zero_deg", led.zero_deg},
        {"intensity_w_sr", led.intensity_w_sr},
        {"color", led.color},
        {"profile_exponent", led.profile_exponent},
        {"aim_m", v3(led.aim_rig_m)}}},
      {"sphere", {{"radius_m", sphere.radius_m}, {"centre_m", v3(sphere.centre_rig_m)}}},
      {"scene",
       {{"felt_albedo", scene.felt_albedo},
        {"table_depth_m", scene.table_depth_m},
        {"table_radius_m", scene.table_radius_m},
        {"pedestal_radius_m", scene.pedestal_radius_m},
        {"arm_post_radius_m", scene.arm_post_radius_m},
        {"backdrop_distance_m", scene.backdrop_distance_m}}},
      {"render",
       {{"edge_samples", render.edge_samples},
        {"edge_shading_samples", render.edge_shading_samples},
        {"interior_samples", render.interior_samples},
        {"interior_tolerance", render.interior_tolerance},
        {"sparkle_floor", render.sparkle_floor}}},
      {"filters", {{"red", filters.red}, {"green", filters.green}, {"blue", filters.blue}}}};
  if (flake_seed) j["flake_seed"] = *flake_seed;
  return j;
}

}  // namespace paintlab::sim
