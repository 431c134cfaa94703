#include "paintlab/sim/builtin.h"

#include <fmt/format.h>
#include <toml++/toml.h>

#include <sstream>
#include <stdexcept>

#include "paintlab/core/atomic_file.h"
#include "paintlab/core/config.h"
#include "paintlab/core/error.h"
#include "paintlab/core/rig.h"
#include "paintlab/sim/config.h"

namespace paintlab::sim {

namespace embedded {
const char* rig_sim_toml();           // generated from examples/rig-sim.toml (cmake/EmbedText.cmake)
const char* paint_silver_metallic_toml();  // generated from paints/silver-metallic.toml
}  // namespace embedded

const char* builtin_rig_toml() { return embedded::rig_sim_toml(); }
const char* builtin_paint_toml() { return embedded::paint_silver_metallic_toml(); }

brdf::PaintSpec builtin_paint() {
  return brdf::parse_paint(ConfigTable::parse_string(builtin_paint_toml(), "silver-metallic.toml"));
}

SimulatedPaint simulated_paint(const std::string& file, const std::string& option) {
  SimulatedPaint p;
  p.spec = file.empty() ? builtin_paint() : brdf::load_paint_file(file);
  p.toml_text = file.empty() ? builtin_paint_toml() : read_file(file);
  if (p.spec.merl()) throw UsageError(option + ": a MERL table cannot be simulated; give an analytic paint");
  return p;
}

namespace {

// Sets `path` (e.g. "geometry.image_width_px") of the built-in rig to `value`. The key must
// exist (the embedded rig is ours: a miss is a programming error, said plainly).
template <class T>
void set_key(toml::table& rig, std::string_view path, T value) {
  const auto dot = path.rfind('.');
  toml::table* parent = dot == std::string_view::npos ? &rig : rig.at_path(path.substr(0, dot)).as_table();
  const std::string_view key = dot == std::string_view::npos ? path : path.substr(dot + 1);
  if (!parent || !parent->contains(key))
    throw std::logic_error(fmt::format("the built-in rig has no key {}", path));
  parent->insert_or_assign(key, value);
}

}  // namespace

const char* to_string(DemoCamera c) {
  return c == DemoCamera::Mono ? "mono" : c == DemoCamera::Bayer ? "bayer" : "wheel";
}

DemoCamera demo_camera_from_string(const std::string& s, const std::string& option) {
  for (DemoCamera c : {DemoCamera::Mono, DemoCamera::Bayer, DemoCamera::Wheel})
    if (s == to_string(c)) return c;
  throw UsageError(
      fmt::format("{} {}: one of bayer (a colour camera), wheel (monochrome behind a filter wheel), mono", option, s));
}

std::string demo_rig_toml(bool quick, DemoCamera camera) {
  const std::string text = builtin_rig_toml();
  toml::table rig = toml::parse(std::string_view(text), std::string_view("rig-sim.toml"));
  set_key(rig, "calibration", std::string("calib"));
  if (camera == DemoCamera::Bayer) {
    set_key(rig, "devices.camera.pixel_format", std::string("BayerRG16"));
    // Camera RGB = diag(gain) M sRGB: dyes that see into the neighbouring primaries, a green
    // channel twice as sensitive as red, and an LED warmer than D65.
    rig.at_path("sim.camera").as_table()->insert_or_assign(
        "rgb_matrix", toml::array{0.82, 0.22, -0.04, 0.08, 0.86, 0.06, 0.03, 0.17, 0.80});
    rig.at_path("sim.camera").as_table()->insert_or_assign("rgb_gain", toml::array{0.55, 1.0, 0.75});
  }
  if (camera == DemoCamera::Wheel)
    rig.at_path("devices").as_table()->insert_or_assign(
        "filter_wheel", toml::table{{"kind", "sim"}, {"slot_r", 1}, {"slot_g", 2}, {"slot_b", 3}, {"settle_ms", 50}});
  if (camera != DemoCamera::Mono)
    rig.at_path("sim.led").as_table()->insert_or_assign("color", toml::array{1.0, 0.96, 0.86});
  if (quick) {
    const RigConfig full = RigConfig::parse(ConfigTable::parse_string(text, "rig-sim.toml"), "rig-sim.toml");
    const SimConfig truth = SimConfig::from_rig(full);
    const double s = 0.5;
    auto num = [](double v) { return std::stod(fmt::format("{:.6g}", v)); };
    set_key(rig, "geometry.image_width_px", std::int64_t{full.geometry.image_width_px / 2});
    set_key(rig, "geometry.image_height_px", std::int64_t{full.geometry.image_height_px / 2});
    set_key(rig, "geometry.pixel_size_um", num(full.geometry.pixel_size_um * 2));
    const Mat3 K = truth.camera.K();
    set_key(rig, "sim.camera.fx_px", num(K(0, 0) * s));
    set_key(rig, "sim.camera.fy_px", num(K(1, 1) * s));
    // Pixel centres: x' + 0.5 = (x + 0.5) / 2.
    set_key(rig, "sim.camera.cx_px", num((K(0, 2) + 0.5) * s - 0.5));
    set_key(rig, "sim.camera.cy_px", num((K(1, 2) + 0.5) * s - 0.5));
    set_key(rig, "sim.camera.psf_sigma_px", num(truth.camera.psf_sigma_px * s));
    set_key(rig, "plan.angle_step_deg", std::int64_t{10});
    set_key(rig, "plan.bracket.count", std::int64_t{8});
  }
  std::ostringstream out;
  out << (quick ? "# paintlab demo --quick: the built-in simulated rig (examples/rig-sim.toml) at half resolution,\n"
                  "# light every 10 deg, 8 exposures; the keys are described in docs/rig.md.\n"
                : "# paintlab demo: the built-in simulated rig (examples/rig-sim.toml); the keys are described in "
                  "docs/rig.md.\n")
      << (camera == DemoCamera::Bayer ? "# The camera: a BayerRG16 colour camera with its own channel mix, under a warm "
                                        "LED (paintlab demo --camera bayer).\n"
          : camera == DemoCamera::Wheel ? "# The camera: the monochrome camera behind a simulated filter wheel, under a "
                                          "warm LED (paintlab demo --camera wheel).\n"
                                        : "")
      // Shortest round-tripping numbers (0.6, not 0.59999999999999998), strings in double quotes.
      << toml::toml_formatter(rig, (toml::toml_formatter::default_flags & ~toml::format_flags::allow_literal_strings) |
                                       toml::format_flags::relaxed_float_precision)
      << "\n";
  return out.str();
}

}  // namespace paintlab::sim
