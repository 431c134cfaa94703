// paintlab sim render: what the simulated rig's camera sees (docs/simulator.md).
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <memory>

#include "rig_devices.h"
#include "cli.h"
#include "paintlab/fitting/output_guard.h"
#include "paintlab/calibration/colour.h"
#include "paintlab/core/error.h"
#include "paintlab/core/image_io.h"
#include "paintlab/core/rig.h"
#include "paintlab/sim/paint.h"
#include "paintlab/sim/scene_render.h"
#include "paintlab/sim/world.h"

namespace paintlab::app {

namespace {

// The commands' descriptions (their --help).
constexpr const char* kRenderHelp =
    "Render the simulated camera's view: scene radiance as EXR, or one exposure as a 16-bit PNG of raw values";

struct RenderArgs {
  std::string rig;
  std::string paint;
  std::string out;
  std::string scene = "sphere";
  double angle_deg = 0.0;
  double exposure_ms = 10.0;
  double gain_db = 0.0;
  double albedo = 0.99;
  int view = 0;
  int threads = 0;
  std::uint64_t frame = 0;
  bool rgb = false;
  bool no_sparkle = false;
  bool led_off = false;
};

std::string lower_extension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext;
}

int run_render(const RenderArgs& a) {
  const std::string ext = lower_extension(a.out);
  if (ext != ".exr" && ext != ".png") throw UsageError("--out must end in .exr (radiance) or .png (16-bit raw): " + a.out);
  if (!(a.exposure_ms > 0) || !std::isfinite(a.exposure_ms)) throw UsageError("--exposure must be > 0 ms");
  if (!std::isfinite(a.angle_deg)) throw UsageError("--angle must be a finite number of degrees");
  if (a.threads < 0) throw UsageError("--threads must be >= 0 (0 = all cores)");
  if (!(a.gain_db >= 0 && a.gain_db <= 48)) throw UsageError("--gain-db must be in [0, 48]");
  if (a.scene == "sphere" && a.paint.empty()) throw UsageError("--paint is required for the sphere scene");
  fit::OutputGuard().input("--rig", a.rig).input("--paint", a.paint).output({"--out", a.out}).check();

  const RigConfig rig = load_rig(a.rig);
  sim::SimWorld world(sim::SimConfig::from_rig(rig));
  const double exposure_s = a.exposure_ms * 1e-3;
  sim::SceneRequest q;
  q.kind = sim::scene_kind_from_string(a.scene, "--scene");
  q.angle_deg = a.angle_deg;
  q.led_on = !a.led_off;
  q.albedo = a.albedo;
  q.view = a.view;
  q.exposure_s = exposure_s;
  q.channels = a.rgb ? 3 : 1;
  q.sparkle = !a.no_sparkle;
  q.threads = a.threads;
  if (q.kind == sim::SceneKind::Sphere) {
    world.set_paint(sim::load_sim_paint(a.paint));
    q.paint_name = std::filesystem::path(a.paint).stem().string();
  }
  if (q.kind == sim::SceneKind::ColourChart)  // the ColorChecker's reference colours in linear sRGB
    q.chart.patch_rgb = calib::ChartReference::load(calib::kColorCheckerReference).srgb_reflectances();
  const sim::SceneRender scene = sim::render_scene(world, q);
  const ImageF& radiance = scene.radiance;
  const std::string& what = scene.description;
  if (ext == ".exr") {
    write_exr(a.out, sim::scene_exr(scene, rig.file.string()));
    const float peak = radiance.empty() ? 0.0f : *std::max_element(radiance.values().begin(), radiance.values().end());
    say(fmt::format("wrote {}: {} ({}x{}, {}), radiance up to {:.4g} W sr^-1 m^-2", a.out, what, radiance.width(),
                    radiance.height(), q.channels == 1 ? "Y" : "RGB", peak));
    return 0;
  }
  sim::ExposureSettings e;
  e.exposure_s = exposure_s;
  e.gain_db = a.gain_db;
  e.frame_index = a.frame;
  const sim::SceneFrame frame = sim::expose_scene(world, scene, e, a.threads);
  write_png(a.out, frame.raw, 16);
  say(fmt::format("wrote {}: {} exposed {:g} ms at {:g} dB ({}x{}, 16-bit, {}-bit ADC MSB aligned), {} saturated values",
                  a.out, what, a.exposure_ms, a.gain_db, frame.raw.width(), frame.raw.height(),
                  world.config().sensor.adc_bits, frame.saturated));
  return 0;
}

}  // namespace

void register_sim_commands(CLI::App& app) {
  CLI::App* sim = subcommand_group(app, "sim", "The simulated rig: render what its camera sees, serve simulated devices");
  auto [render, args] = add_command<RenderArgs>(sim, "render", kRenderHelp, run_render);
  render->add_option("--rig", args->rig, "rig.toml with the simulated world ([geometry] and [sim])")->required();
  render->add_option("--paint", args->paint, "paint .toml on the sphere (scene sphere)");
  render->add_option("--angle", args->angle_deg, "table angle, deg (the LED position)");
  render->add_option("--exposure", args->exposure_ms, "exposure time, ms (PNG output; sets the target lighting)");
  render->add_option("--gain-db", args->gain_db, "camera gain, dB (PNG output)");
  render->add_option("--out", args->out, "output file: .exr (radiance) or .png (raw)")->required();
  render->add_option("--scene", args->scene, "sphere, white (reference sphere), chessboard, charuco, colour-chart, flat, dark")
      ->check(CLI::IsMember({"sphere", "white", "chessboard", "charuco", "colour-chart", "flat", "dark"}));
  render->add_option("--albedo", args->albedo, "albedo of the white reference sphere")->check(CLI::Range(0.0, 1.0));
  render->add_option("--view", args->view, "which generated board or chart pose (0, 1, ...)")->check(CLI::Range(0, 99));
  render->add_option("--frame", args->frame, "noise realisation (frame index) of the PNG");
  render->add_option("--threads", args->threads, "threads, 0 = all cores");
  render->add_flag("--rgb", args->rgb, "colour output (default: the monochrome camera's mix)");
  render->add_flag("--no-sparkle", args->no_sparkle, "the smooth BRDF without flake glints");
  render->add_flag("--led-off", args->led_off, "LED switched off");
}

}  // namespace paintlab::app
