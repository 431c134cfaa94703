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
    "1.0 at each geometry of --geometries.";

constexpr const char* kGeometriesHelp =
    "Geometry set: astm-e2194, five-angle, six-angle, e2539, or a .toml file of [[geometry]] tables";

struct ColourArgs {
  std::string input;
  std::string geometries = fit::kDefaultGeometrySet;
  bool json = false;
};

struct QcArgs {
  std::string standard, sample;
  std::string tolerances;
  std::string geometries = fit::kDefaultGeometrySet;
  bool json = false;
};

int run_colour(const ColourArgs& a) {
  const auto geometries = fit::geometry_set(a.geometries);
  const fit::MultiAngleColour c = fit::paint_colour(a.input, geometries);
  say(a.json ? fit::colour_json(c).dump(2) : fit::colour_table(c));
  return kExitOk;
}

int run_qc(const QcArgs& a) {
  const auto tolerances =
      a.tolerances.empty() ? fit::default_tolerances(a.geometries) : fit::load_tolerances(a.tolerances);
  const fit::QcResult r = fit::quality_control(a.standard, a.sample, tolerances);
  say(a.json ? fit::qc_json(r).dump(2) : fit::qc_table(r));
  return r.pass ? kExitOk : kExitFailed;
}

}  // namespace

void register_colour_commands(CLI::App& app) {
  auto [c, ca] = add_command<ColourArgs>(&app, "colour", kColourHelp, run_colour);
  c->add_option("INPUT", ca->input, "paint: .axf.h5, fit.json or paint .toml")->required();
  c->add_option("--geometries", ca->geometries, kGeometriesHelp)->capture_default_str();
  c->add_flag("--json", ca->json, "Print one JSON object (DESIGN.md's shape) instead of the table");

  auto [q, qa] = add_command<QcArgs>(&app, "qc", kQcHelp, run_qc);
  q->add_option("STANDARD", qa->standard, "the standard paint: .axf.h5, fit.json or paint .toml")->required();
  q->add_option("SAMPLE", qa->sample, "the sample paint: .axf.h5, fit.json or paint .toml")->required();
  q->add_option("--tolerances", qa->tolerances,
                "TOML tolerance set: [[tolerance]] tables with geometry and de00/dL/dC/dH limits (docs/colour.md)");
  q->add_option("--geometries", qa->geometries, "Without --tolerances: the geometry set")->capture_default_str();
  q->add_flag("--json", qa->json, "Print one JSON object instead of the table");
}

}  // namespace paintlab::app
