// paintlab fit INPUT... --model cook-torrance|axf-carpaint [--lobes N] --out fit.json
//   INPUT: a session folder (its HDR images are extracted and binned with the rig's
//   calibration first) or a MERL .binary table (public measured tables, or one `paintlab
//   bin` wrote); or several sessions of one paint, binned into one table.
// paintlab bin SESSION... --out table.merl [--coverage coverage.exr] [--fill]
//   extracts and bins a session alone: the measured table (holes written as -1, as MERL
//   readers expect) and the coverage map.
#include <algorithm>
#include <filesystem>
#include <fmt/format.h>
#include <fmt/ranges.h>
#include <optional>

#include "cli.h"
#include "extract_options.h"
#include "paintlab/fitting/output_guard.h"
#include "paintlab/acquisition/session.h"
#include "paintlab/brdf/merl.h"
#include "paintlab/calibration/rig_calibration.h"
#include "paintlab/core/error.h"
#include "paintlab/core/hash.h"
#include "paintlab/core/json.h"
#include "paintlab/core/log.h"
#include "paintlab/core/rig.h"
#include "paintlab/brdf/paint.h"
#include "paintlab/fitting/compare.h"
#include "paintlab/fitting/coverage.h"
#include "paintlab/fitting/export.h"
#include "paintlab/fitting/extraction.h"
#include "paintlab/fitting/flakes.h"
#include "paintlab/fitting/axf_file.h"
#include "paintlab/fitting/hole_fill.h"
#include "paintlab/fitting/pipeline.h"
#include "paintlab/fitting/session_binning.h"

namespace paintlab::app {

namespace {

// The commands' descriptions (their --help).
constexpr const char* kFitHelp =
    "Fit a paint model to a session (its HDR images are extracted and binned with the rig's calibration), to "
    "several sessions of one paint binned together, or to a MERL .binary table, and write fit.json (parameters, standard deviations, residuals per region, solver "
    "summary). Exit 1 when the fit does not converge (fit.json is still written, with \"converged\": false and "
    "the solver's termination), 2 on bad input (nothing is written then).";
constexpr const char* kBinHelp =
    "Extract the BRDF samples of a session's HDR images and bin them into a MERL .binary table (empty bins as "
    "-1) with a coverage map (EXR: count, state, valid, R, G, B per bin). Exit 2 on bad input; nothing is written "
    "then.";

namespace fs = std::filesystem;

struct FitArgs {
  std::vector<std::string> inputs;
  std::string model = "cook-torrance";
  int lobes = 3;
  std::string out;
  std::string name;
  std::uint64_t seed = 1;
  int max_iterations = 100;
  std::string min_samples = "auto";
  std::string residuals = "log";
  std::string log_correction = "spread";
  std::string flakes;  // the flakes.json to measure against the fit (a session only)
  ExtractArgs extract;
};

// --min-samples auto|N: 0 is auto (FitDataOptions::min_samples).
std::uint32_t parse_min_samples(const std::string& text) {
  if (text == "auto") return 0;
  try {
    std::size_t used = 0;
    const long v = std::stol(text, &used);
    if (used == text.size() && v >= 1 && v <= 100000) return static_cast<std::uint32_t>(v);
  } catch (const std::exception&) {
  }
  throw UsageError(fmt::format("--min-samples: '{}' is neither auto nor a count from 1 to 100000", text));
}

int run_fit(const FitArgs& a) {
  fit::SharedFitOptions shared;
  shared.lobes = a.lobes;
  shared.seed = a.seed;
  shared.threads = a.extract.threads;
  shared.max_iterations = a.max_iterations;
  shared.min_samples = parse_min_samples(a.min_samples);
  fit::FitRequest req = fit::FitRequest::with(fit::fit_model_from_string(a.model, "--model"), "fitted", shared);
  req.cook_torrance.data.residuals = fit::fit_residuals_from_string(a.residuals, "--residuals");
  if (a.log_correction != "spread" && a.log_correction != "scatter")
    throw UsageError(fmt::format("--log-correction: '{}' is neither spread nor scatter", a.log_correction));
  req.cook_torrance.data.point_scatter = req.axf_carpaint.data.point_scatter = a.log_correction == "scatter";
  req.check();
  std::vector<fs::path> inputs;
  for (const std::string& i : a.inputs) {
    if (!fs::exists(i)) throw IoError(i, "no such file or folder");
    inputs.emplace_back(i);
  }
  const fs::path& input = inputs.front();
  fit::OutputGuard guard;
  for (const fs::path& i : inputs) guard.input("INPUT", i);
  guard.input("--calib", a.extract.calib).output({"--out", a.out});
  if (!a.flakes.empty()) {
    if (!fs::is_directory(input))
      throw DataError(fmt::format("--flakes: {} is a table; flakes are measured from a session's images", a.inputs[0]));
    if (inputs.size() > 1)
      throw UsageError(fmt::format("--flakes measures one session's flakes; with {} sessions fitted together, run "
                                   "`paintlab flakes SESSION --fit {}` for each",
                                   inputs.size(), a.out));
    guard.output({"--flakes", a.flakes});
  }
  guard.check();
  fit::SessionBinOptions bin = bin_options(a.extract);
  if (bin.sites == fit::SiteFit::On && !fs::is_directory(input))
    throw DataError(fmt::format("--cfa-sites on: {} is a table; only a session's images show which pixel measured "
                                "which colour",
                                a.inputs[0]));
  if (req.model != fit::FitModel::CookTorrance) {
    if (bin.sites == fit::SiteFit::On)
      throw DataError(fmt::format("--cfa-sites on fits the cook-torrance model, not --model {}", a.model));
    bin.sites = fit::SiteFit::Off;
  }
  const fit::FitInput in = fit::load_fit_input(inputs, bin);
  if (in.stats) say(in.stats->describe(in.measured_bins()));
  for (const std::string& w : in.warnings) spdlog::warn("{}", w);
  req.name = fit::paint_name_from(a.name.empty() ? in.sample : a.name);
  spdlog::info("fitting {} ({} measured bins{})", fit::to_string(req.model), in.measured_bins(),
               in.sites ? ", R, G and B sites in tables of their own" : "");
  const fit::FitOutcome outcome =
      in.sites ? fit::fit_sites(*in.sites, req, in.input)
               : fit::fit_table(in.table, in.noise_variance.empty() ? nullptr : &in.noise_variance, req, in.input);
  write_json_file(a.out, outcome.fit);
  say(outcome.report);
  if (!a.flakes.empty()) {
    // The flakes against the fit just made: its smooth model is the flakes' average.
    spdlog::info("measuring the flakes against the {} fit", fit::to_string(req.model));
    const auto model = brdf::make_brdf(fit::axf_from_fit_json(outcome.fit, a.out).paint_spec());
    fit::FlakeOptions fo;
    fo.threads = a.extract.threads;
    const fit::FlakeStats stats =
        fit::session_flakes(acq::SessionDir::open(input), *model, fo, bin.extraction, bin.calib_dir);
    write_json_file(a.flakes, fit::flakes_to_json(stats));
    say(fit::describe_flakes(stats) + "wrote " + a.flakes);
  }
  if (!outcome.converged) {
    // Written anyway: the last parameters are often close, and fit.json says converged false.
    spdlog::warn("the {} fit did not converge: {}; {} is written with \"converged\": false (exit 1)",
                 fit::to_string(req.model), outcome.termination, a.out);
    say(fmt::format("wrote {} (NOT converged: {})", a.out, outcome.termination));
    return kExitFailed;
  }
  say(fmt::format("wrote {}", a.out));
  return kExitOk;
}

struct BinArgs {
  std::vector<std::string> sessions;
  std::string out;
  std::string coverage;  // default: beside --out
  bool fill = false;
  std::string against;  // a known paint to compare the table with, by grazing band
  ExtractArgs extract;
};

int run_bin(const BinArgs& a) {
  std::vector<acq::SessionDir> sessions;
  for (const std::string& s : a.sessions) sessions.push_back(acq::SessionDir::open(s));  // DataError: not a session
  const fs::path out(a.out);
  fs::path cov(a.coverage);
  OutputSpec cov_spec("--coverage", cov);
  if (cov.empty()) {
    cov = fit::coverage_map_path_for(out);
    cov_spec = OutputSpec("--out", cov);
    cov_spec.beside = out;
  }
  fit::OutputGuard guard;
  for (const std::string& s : a.sessions) guard.input("SESSION", s);
  guard.input("--calib", a.extract.calib)
      .input("--against", a.against)
      .output({"--out", out})
      .output(cov_spec)
      .check();
  std::unique_ptr<brdf::Brdf> against;
  if (!a.against.empty()) against = brdf::make_brdf(fit::load_any_paint(a.against).paint_spec());
  fit::BinnedSession s = fit::bin_sessions(sessions, bin_options(a.extract));
  say(s.stats.describe(s.binned.table.count_in_state(brdf::BinState::Measured)));
  if (s.binned.table.count_in_state(brdf::BinState::Measured) == 0)
    throw DataError(fmt::format("{}: no sample landed in the table (every pixel invalid or grazing); nothing written",
                                fmt::join(a.sessions, ", ")));
  brdf::MerlTable& table = s.binned.table;
  say(fit::coverage(table).describe());
  if (against) say(fit::grazing_band_table(fit::compare_by_grazing_band(table, *against)));
  if (a.fill) {
    const fit::HoleFillReport r = fit::fill_holes(table);
    say(fmt::format("filled {} bins from the phi_d mirror and {} by push-pull ({} below the horizon left empty)",
                    r.filled_mirror, r.filled_pyramid, r.invalid_empty));
  }
  fit::write_coverage_exr(cov, table);
  brdf::write_merl(out, table);
  say(fmt::format("wrote {} and {}", out.string(), cov.string()));
  return kExitOk;
}

}  // namespace

void register_fit_commands(CLI::App& app) {
  auto [fit, args] = add_command<FitArgs>(&app, "fit", kFitHelp, run_fit);
  fit->add_option("INPUT", args->inputs,
                  "Session folder or MERL .binary table; or several sessions of one paint (other spheres, or the "
                  "sphere turned on its stand), binned into one table and fitted together: more independent flakes "
                  "for a sparkling paint (docs/fitting.md \"Sparkle\")")
      ->required();
  fit->add_option("--model", args->model, "Model to fit: cook-torrance or axf-carpaint")->capture_default_str();
  sets_fields(fit->add_option("--lobes", args->lobes, "Lobes (Cook-Torrance, or the car paint's achromatic lobes), 1..3"),
              {"CtFitOptions::lobes", "AxfFitOptions::lobes"})
      ->capture_default_str();
  fit->add_option("--out", args->out, "fit.json to write")->required();
  fit->add_option("--name", args->name, "Paint name in fit.json (default: the session's sample, or the file name)")->check(utf8_text());
  fit->add_option("--seed", args->seed, "Seed of the random starts (the fit is deterministic for a seed)")
      ->capture_default_str();
  sets_fields(fit->add_option("--max-iterations", args->max_iterations, "Iterations of the final solve"),
              {"CtFitOptions::max_iterations", "AxfFitOptions::max_iterations"})
      ->capture_default_str();
  sets_fields(fit->add_option("--min-samples", args->min_samples,
                              "Pool neighbouring phi_d bins of a session into fit points of at least this many "
                              "samples: auto (16 when the glossy samples spread more than 20 x their noise, flake "
                              "sparkle, where a bin of a few samples is decided by a glint or its absence; 256 when "
                              "several sessions of such a paint are fitted together, docs/fitting.md \"Sparkle\"; a "
                              "point per bin otherwise), or a count (1 = a point per bin). MERL tables hold no counts "
                              "and are never pooled"),
              {"FitDataOptions::min_samples"})
      ->capture_default_str();
  fit->add_option("--residuals", args->residuals,
                  "Cook-Torrance residuals: log, or linear (weights from the neighbouring bins and the sparkle-aware "
                  "sample spread: unbiased for bin means under flake sparkle; see docs/fitting.md)")
      ->capture_default_str();
  sets_fields(fit->add_option("--log-correction", args->log_correction,
                              "Variance the log residuals' bias correction takes for a fit point: spread (its "
                              "samples' spread / n, as if independent), or scatter (at least what neighbouring fit "
                              "points' log values scatter by: under flake sparkle a glint is seen again in the same "
                              "bin; brings a flake lobe's level to the truth but moves its ks / r split; "
                              "docs/fitting.md \"Sparkle\")"),
              {"FitDataOptions::point_scatter"})
      ->capture_default_str();
  fit->add_option("--flakes", args->flakes,
                  "A session: also measure its flakes against the fit and write this flakes.json (as `paintlab "
                  "flakes SESSION --fit fit.json` with the default options; docs/sparkle.md)");
  add_extract_options(fit, args->extract, true);
  add_cfa_sites_option(fit, args->extract);

  auto [bin, bargs] = add_command<BinArgs>(&app, "bin", kBinHelp, run_bin);
  bin->add_option("SESSION", bargs->sessions, "Session folder, or several sessions of one paint binned into one table")
      ->required();
  bin->add_option("--out", bargs->out, "MERL .binary table to write")->required();
  bin->add_option("--coverage", bargs->coverage, "Coverage map to write (default: OUT's name with .coverage.exr)");
  bin->add_flag("--fill", bargs->fill,
                "Fill the holes (phi_d mirror, then push-pull) before writing; the file cannot mark filled bins, "
                "the coverage map's state channel does. Do not fit a filled table.");
  bin->add_option("--against", bargs->against,
                  "A known paint (.toml, fit.json, .axf.h5; in the session's colour space) to compare the measured "
                  "bins with: log ratio per band of max(theta_i, theta_o), where the terminator and silhouette are");
  add_extract_options(bin, bargs->extract, false);
}

}  // namespace paintlab::app
