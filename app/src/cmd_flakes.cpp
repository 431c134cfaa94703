// paintlab flakes SESSION --out flakes.json   (docs/sparkle.md)
#include <fmt/format.h>

#include "cli.h"
#include "paintlab/core/error.h"
#include "paintlab/core/json.h"
#include "paintlab/fitting/flakes.h"
#include "paintlab/fitting/output_guard.h"

namespace paintlab::app {
namespace {

constexpr const char* kFlakesHelp =
    "Flake statistics of a measured session: every sphere pixel of every light position against the smooth model "
    "(--fit, or a Cook-Torrance fit made now); glints are pixels above the model by --threshold-sigma noise "
    "standard deviations and --threshold-ratio of the model. Per slice of the refracted (theta_F, theta_I) "
    "directions (the car-paint flake BTF's layout): sparkle area, glint contrast, colour clusters in CIELAB "
    "(octree, --clusters) and the glint lifetime from runs over the sweep; instrument-style sparkle area and "
    "intensity at 15, 45 and 75 deg illumination viewed along the normal. A paint without flakes gives an empty "
    "model. Exit 0 written, 2 bad input (nothing written). docs/sparkle.md.";

struct FlakesArgs {
  std::string session;
  std::string out;
  std::string fit;
  std::string calib;
  int lobes = 3;
  fit::FlakeOptions flakes;
  int slices = 12;
  bool json = false;
};

int run_flakes(const FlakesArgs& a) {
  fit::OutputGuard().input("SESSION", a.session).input("--fit", a.fit).output({"--out", a.out}).check();
  fit::SessionFlakeOptions o;
  o.flakes = a.flakes;
  o.flakes.num_theta_f = o.flakes.num_theta_i = a.slices;
  o.fit_file = a.fit;
  o.lobes = a.lobes;
  if (!a.calib.empty()) o.calib_dir = a.calib;
  const fit::FlakeStats s = fit::session_flakes(a.session, o);
  const Json j = fit::flakes_to_json(s);
  write_json_file(a.out, j);
  say(a.json ? j.dump(2) : fit::describe_flakes(s) + "wrote " + a.out);
  return kExitOk;
}

}  // namespace

void register_flakes_commands(CLI::App& app) {
  auto [c, fa] = add_command<FlakesArgs>(&app, "flakes", kFlakesHelp, run_flakes);
  c->add_option("SESSION", fa->session, "a finished measurement session folder")->required();
  c->add_option("--out", fa->out, "the flakes.json to write")->required();
  c->add_option("--fit", fa->fit, "the smooth model: fit.json, .axf.h5 or paint .toml (default: fit now)");
  sets_fields(c->add_option("--lobes", fa->lobes, "Without --fit: Cook-Torrance lobes of the fit"),
              {"CtFitOptions::lobes"})
      ->capture_default_str();
  c->add_option("--calib", fa->calib, "the session's calibration folder (default: the one of its rig file)");
  sets_fields(c->add_option("--ior", fa->flakes.ior, "the clear coat's index of refraction, for the slices"),
              {"FlakeOptions::ior"})
      ->capture_default_str();
  sets_fields(c->add_option("--slices", fa->slices,
                            "slices per angle (theta_F and theta_I, bins of 90/N deg; N x N below 256)"),
              {"FlakeOptions::num_theta_f", "FlakeOptions::num_theta_i", "FlakeOptions::num_theta_f x num_theta_i"})
      ->capture_default_str();
  sets_fields(c->add_option("--threshold-sigma", fa->flakes.threshold_sigma,
                            "a glint's excess over the model, in noise standard deviations"),
              {"FlakeOptions::threshold_sigma"})
      ->capture_default_str();
  sets_fields(c->add_option("--threshold-ratio", fa->flakes.threshold_ratio,
                            "a glint's excess over the model, as a part of the model"),
              {"FlakeOptions::threshold_ratio"})
      ->capture_default_str();
  sets_fields(c->add_option("--clusters", fa->flakes.clusters, "colour clusters per slice (Golla and Klein: 50)"),
              {"FlakeOptions::clusters"})
      ->capture_default_str();
  c->add_flag("--json", fa->json, "Print flakes.json instead of the summary");
}

}  // namespace paintlab::app
