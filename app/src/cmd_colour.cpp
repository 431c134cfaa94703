// paintlab colour INPUT [--geometries SET] [--json]
// paintlab qc STANDARD SAMPLE [--tolerances FILE] [--geometries SET] [--json]
// (docs/colour.md "Multi-angle colour" and "Quality control")
#include <fmt/format.h>

#include "cli.h"
#include "paintlab/core/error.h"
#include "paintlab/fitting/multiangle.h"

namespace paintlab::app {

namespace {

constexpr const char* kColourHelp =
    "CIELAB of a paint at the in-plane geometries of multi-angle spectrophotometers (illumination 45 deg, "
    "aspecular 15, 25, 45, 75, 110 deg by default) and its flop index.\n"
    "Aspecular angle: the viewing direction is the specular direction turned by it towards the illuminator in the "
    "plane of incidence (45as45 views along the normal, 45as110 65 deg from it on the light's side). R = pi f in "
    "linear sRGB, XYZ for D65 and the 2 deg observer (sRGB's; a 10 deg observer needs spectra). docs/colour.md.";

constexpr const char* kQcHelp =
    "Quality control: a sample paint against a standard, dL*, dC*, dH* and dE00 per geometry, each against its "
    "tolerance. Exit 0 when every geometry passes, 1 when one fails, 2 on bad input. Without --tolerances: dE00 <= "
    "1.0 at each geometry of --geometries. A session or table is fitted (3 Cook-Torrance lobes) and its model "
    "compared.";

constexpr const char* kGeometriesHelp =
    "Geometry set: astm-e2194, five-angle, six-angle, e2539, or a .toml file of [[geometry]] tables";

struct ColourArgs {
  std::string input;
  std::string fit;
  int lobes = 3;
  std::string calib;
  std::string geometries = fit::kDefaultGeometrySet;
  bool json = false;
};

struct QcArgs {
  std::string standard, sample;
  std::string library;
  std::string tolerances;
  std::string geometries = fit::kDefaultGeometrySet;
  bool json = false;
};

int run_colour(const ColourArgs& a) {
  const auto geometries = fit::geometry_set(a.geometries);
  fit::MeasuredInputOptions o;
  o.fit_file = a.fit;
  o.lobes = a.lobes;
  if (!a.calib.empty()) o.calib_dir = a.calib;
  const fit::MultiAngleColour c = fit::any_colour(a.input, geometries, o);
  say(a.json ? fit::colour_json(c).dump(2) : fit::colour_table(c));
  return kExitOk;
}

int run_qc(const QcArgs& a) {
  const auto tolerances =
      a.tolerances.empty() ? fit::default_tolerances(a.geometries) : fit::load_tolerances(a.tolerances);
  const fit::QcResult r = fit::quality_control(fit::resolve_paint_input(a.standard, a.library),
                                               fit::resolve_paint_input(a.sample, a.library), tolerances);
  say(a.json ? fit::qc_json(r).dump(2) : fit::qc_table(r));
  return r.pass ? kExitOk : kExitFailed;
}

}  // namespace

void register_colour_commands(CLI::App& app) {
  auto [c, ca] = add_command<ColourArgs>(&app, "colour", kColourHelp, run_colour);
  c->add_option("INPUT", ca->input,
                "paint: .axf.h5, fit.json or paint .toml; or measured data: a session folder or a MERL .binary "
                "table (the samples nearest each geometry beside the model)")
      ->required();
  c->add_option("--fit", ca->fit, "Measured data: the model to compare with (fit.json or .axf.h5; default: fit now)");
  sets_fields(c->add_option("--lobes", ca->lobes, "Measured data without --fit: Cook-Torrance lobes of the fit"),
              {"CtFitOptions::lobes"})
      ->capture_default_str();
  c->add_option("--geometries", ca->geometries, kGeometriesHelp)->capture_default_str();
  c->add_flag("--json", ca->json, "Print one JSON object (DESIGN.md's shape) instead of the table");
  c->add_option("--calib", ca->calib, "A session's calibration folder (default: the one of its rig file)");

  auto [q, qa] = add_command<QcArgs>(&app, "qc", kQcHelp, run_qc);
  q->add_option("STANDARD", qa->standard,
                "the standard: .axf.h5, fit.json, paint .toml, a session or .binary table (fitted), or a name in "
                "--library")
      ->required();
  q->add_option("SAMPLE", qa->sample, "the sample, as STANDARD")->required();
  q->add_option("--library", qa->library, "Paint library folder: STANDARD and SAMPLE may name its paints");
  q->add_option("--tolerances", qa->tolerances,
                "TOML tolerance set: [[tolerance]] tables with geometry and de00/dL/dC/dH limits (docs/colour.md)");
  q->add_option("--geometries", qa->geometries, "Without --tolerances: the geometry set")->capture_default_str();
  q->add_flag("--json", qa->json, "Print one JSON object instead of the table");
}

}  // namespace paintlab::app
