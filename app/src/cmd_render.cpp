// paintlab render PAINT --out preview.png [--env ENV.exr] [--hdr FILE.exr] [...]
// paintlab render PAINT --out compare.png --compare SESSION [--angle DEG] [--calib DIR]
// (docs/axf-like.md "Previews")
#include <filesystem>
#include <fmt/format.h>
#include <optional>

#include "cli.h"
#include "paintlab/fitting/output_guard.h"
#include "paintlab/fitting/export.h"
#include "paintlab/core/error.h"
#include "paintlab/fitting/preview.h"
#include "paintlab/fitting/prefiltered_env.h"

namespace fs = std::filesystem;

namespace paintlab::app {

namespace {

// The commands' descriptions (their --help).
constexpr const char* kRenderHelp =
    "Render a preview of a paint: a sphere lit by a point light (and an HDR environment map with --env), "
    "tone-mapped to sRGB PNG (linear x exposure, clipped, sRGB curve; automatic exposure puts the 99.5th "
    "percentile at white).\nWith --compare SESSION: the measured HDR image at the light angle nearest --angle, "
    "the model rendered in the calibrated rig geometry, and their difference, side by side.\nA paint exported with "
    "its measured flakes (export --flakes) is drawn with them: glints fixed on the surface, from the measured "
    "statistics; --compare then also measures both images' sparkle per slice.";

struct RenderArgs {
  std::string paint;
  std::string out;
  std::string env;
  double env_intensity = 1.0;
  bool no_point_light = false;
  int size = 512;
  double azimuth_deg = 40;
  double elevation_deg = 25;
  double exposure = 0;
  int samples = 32;
  std::string hdr;
  std::string compare;
  double angle_deg = 60;
  std::string calib;
  int window_px = fit::CompareOptions{}.window_px;
  bool no_sparkle = false;
  std::string basis = "full";
  std::string env_cache;
  bool against_full = false;
};

int run_compare(const RenderArgs& a) {
  fit::CompareOptions o;
  o.tone.exposure = a.exposure;
  o.window_px = a.window_px;
  o.sparkle = !a.no_sparkle;
  const fit::ComparisonResult r =
      fit::render_comparison_png(a.paint, a.compare, a.angle_deg, a.out,
                            a.calib.empty() ? std::nullopt : std::optional<fs::path>(a.calib), o,
                            a.hdr.empty() ? std::nullopt : std::optional<fs::path>(a.hdr));
  const fit::Comparison& c = r.comparison;
  say(fmt::format("compared {} with {} at table angle {:.1f} deg ({})", a.paint, a.compare, r.angle_deg, r.image));
  say(fmt::format("  {} sphere pixels: RMS log ratio model/measured {:.4f}, median ratio {:.4f}", c.pixels_used,
                  c.log_rms, c.median_ratio));
  if (r.measured_sparkle && r.rendered_sparkle) {
    const fit::FlakeStats& m = *r.measured_sparkle;
    const fit::FlakeStats& d = *r.rendered_sparkle;
    say(fmt::format("  sparkle (glints against the smooth model): measured {:.3f} %, rendered {:.3f} % of {} pixels",
                    100 * m.area(), 100 * d.area(), m.pixels));
    say("  slice (theta_F, theta_I)   area measured / rendered   intensity measured / rendered");
    for (const fit::FlakeSlice& s : m.slices) {
      if (s.glints < 20) continue;
      const fit::FlakeSlice* t = d.slice(s.theta_f, s.theta_i);
      say(fmt::format("  ({:2d}, {:2d})                   {:6.3f} % / {:6.3f} %        {:6.2f} / {:6.2f}", s.theta_f,
                      s.theta_i, 100 * s.area(), t ? 100 * t->area() : 0.0, s.intensity_mean,
                      t ? t->intensity_mean : 0.0));
    }
  }
  say(fmt::format("wrote {} (measured | model | difference; exposure {:.4g})", a.out, c.exposure));
  return kExitOk;
}

int run_cosine(const RenderArgs& a, const fit::PreviewOptions& o) {
  if (!a.compare.empty()) throw UsageError("--basis cosine renders the preview scene; --compare needs the full model");
  const fs::path cache = a.env_cache.empty() ? fit::PrefilteredEnvironment::default_cache_dir() : fs::path(a.env_cache);
  const fit::CosineRenderResult r = fit::render_cosine_png(
      a.paint, a.out, o, cache, a.against_full, a.hdr.empty() ? std::nullopt : std::optional<fs::path>(a.hdr));
  if (o.environment)
    say(fmt::format("prefiltered maps: {} in {:.2f} s ({})", r.maps_from_cache ? "read from the cache" : "built",
                    r.maps_s, cache.string()));
  say(fmt::format("cosine-lobe render: {:.1f} ms ({:.0f} frames/s at {} x {})", r.render_ms, 1000.0 / r.render_ms,
                  o.size_px, o.size_px));
  if (r.log_rms)
    say(fmt::format("full model ({} samples per strategy): {:.0f} ms, {:.0f}x slower; RMS log ratio basis/full {:.4f}",
                    o.environment_samples, r.full_ms, r.full_ms / r.render_ms, *r.log_rms));
  say(fmt::format("wrote {} ({}, exposure {:.4g})", a.out, a.paint, r.preview.exposure));
  return kExitOk;
}

int run_render(const RenderArgs& a) {
  fit::OutputGuard()
      .input("PAINT", a.paint)
      .input("--env", a.env)
      .input("--compare", a.compare)
      .input("--calib", a.calib)
      .output({"--out", a.out})
      .output({"--hdr", a.hdr})
      .check();
  if (!a.compare.empty()) return run_compare(a);
  fit::PreviewOptions o;
  o.size_px = a.size;
  o.light_azimuth_deg = a.azimuth_deg;
  o.light_elevation_deg = a.elevation_deg;
  o.point_light = !a.no_point_light;
  if (!a.env.empty()) o.environment = a.env;
  o.environment_intensity = a.env_intensity;
  o.environment_samples = a.samples;
  o.tone.exposure = a.exposure;
  o.sparkle = !a.no_sparkle;
  if (!o.point_light && !o.environment) throw UsageError("--no-point-light needs --env ENV.exr (nothing would light the sphere)");
  if (a.basis == "cosine") return run_cosine(a, o);
  if (a.against_full || !a.env_cache.empty())
    throw UsageError("--against-full and --env-cache apply to --basis cosine");
  const fit::Preview p =
      fit::render_preview_png(a.paint, a.out, o, a.hdr.empty() ? std::nullopt : std::optional<fs::path>(a.hdr));
  say(fmt::format("wrote {} ({} x {} px, {}, exposure {:.4g}, peak [{:.4g}, {:.4g}, {:.4g}] at ({}, {}))", a.out,
                  o.size_px, o.size_px, a.paint, p.exposure, p.peak[0], p.peak[1], p.peak[2], p.peak_x, p.peak_y));
  return kExitOk;
}

}  // namespace

void register_render_commands(CLI::App& app) {
  auto [r, args] = add_command<RenderArgs>(&app, "render", kRenderHelp, run_render);
  r->add_option("PAINT", args->paint, "paint: .axf.h5, fit.json or paint .toml")->required();
  r->add_option("--out", args->out, "PNG to write")->required();
  r->add_option("--env", args->env, "Equirectangular HDR environment map (.exr, 2:1)");
  sets_fields(r->add_option("--env-intensity", args->env_intensity, "Multiplies the environment map"),
              {"PreviewOptions::environment_intensity"})
      ->capture_default_str();
  r->add_flag("--no-point-light", args->no_point_light, "Light by the environment map only");
  sets_fields(r->add_option("--size", args->size, "Image size in pixels (square)"), {"PreviewOptions::size_px"})
      ->capture_default_str();
  sets_fields(r->add_option("--light-azimuth", args->azimuth_deg, "Point light azimuth from the camera, deg (towards the right)"),
              {"PreviewOptions::light_azimuth_deg"})
      ->capture_default_str();
  sets_fields(r->add_option("--light-elevation", args->elevation_deg, "Point light elevation, deg (upwards)"),
              {"PreviewOptions::light_elevation_deg"})
      ->capture_default_str();
  r->add_option("--exposure", args->exposure, "Tone-mapping exposure (0 = automatic)")->capture_default_str();
  sets_fields(r->add_option("--samples", args->samples, "Environment samples per strategy and pixel"),
              {"PreviewOptions::environment_samples"})
      ->capture_default_str();
  r->add_option("--hdr", args->hdr, "Also write the linear image as EXR");
  r->add_option("--compare", args->compare, "Session folder to compare with");
  r->add_option("--angle", args->angle_deg, "--compare: table angle, deg (the nearest finished position)")
      ->capture_default_str();
  r->add_option("--calib", args->calib, "--compare: calibration folder (default: the session's rig's)");
  r->add_flag("--no-sparkle", args->no_sparkle,
              "Leave out the paint's measured flakes (drawn by default when the paint carries them, docs/sparkle.md)");
  r->add_option("--basis", args->basis,
                "full: the paint's model (environment by Monte Carlo); cosine: its cosine-lobe weights, the environment "
                "by one prefiltered map per exponent (docs/design.md \"Rendering the basis\")")
      ->check(CLI::IsMember({"full", "cosine"}))
      ->capture_default_str();
  r->add_option("--env-cache", args->env_cache,
                "--basis cosine: where the prefiltered maps are kept (default $XDG_CACHE_HOME/paintlab/prefiltered)");
  r->add_flag("--against-full", args->against_full,
              "--basis cosine: also render the full model and print the RMS log ratio and the speed-up");
  sets_fields(r->add_option("--window", args->window_px,
                            "--compare: half size of the window the difference is averaged over, px (0: pixel by pixel)"),
              {"CompareOptions::window_px"})
      ->capture_default_str();
}

}  // namespace paintlab::app
