// paintlab export INPUT [INPUT2] (--axf FILE | --merl FILE ...)   (docs/axf-like.md)
// paintlab axf validate FILE...                                  exit 0 valid, 1 invalid
// paintlab axf show FILE
// INPUT: a session folder (binned and fitted here), or one or two paint files (fit.json of
// either model, AxF-like .axf.h5, paint .toml).
#include <filesystem>
#include <fmt/format.h>

#include "cli.h"
#include "extract_options.h"
#include "paintlab/fitting/output_guard.h"
#include "paintlab/core/error.h"
#include "paintlab/core/input_files.h"
#include "paintlab/core/json.h"
#include "paintlab/core/log.h"
#include "paintlab/fitting/axf_file.h"
#include "paintlab/fitting/export.h"

namespace fs = std::filesystem;

namespace paintlab::app {

namespace {

// The commands' descriptions (their --help).
constexpr const char* kExportHelp =
    "Export a measured paint: an AxF-like HDF5 file (docs/axf-like.md) and/or the measured, hole-filled MERL "
    ".binary table.\nINPUT is a session folder (binned and fitted here), or one or two paint files: fit.json "
    "(either model; two fits of one measurement are merged), .axf.h5 or paint .toml.\nExit 0 written, 1 the fit "
    "made here did not converge (the files are written all the same and record it; a paint file whose fit did "
    "not converge is exported with a warning, exit 0), 2 bad input (nothing written).";

struct ExportArgs {
  std::vector<std::string> inputs;
  std::string axf;
  std::string merl;
  std::string model = "cook-torrance";
  int lobes = 3;
  std::string name;
  std::string fit_out;
  std::uint64_t seed = 1;
  std::string flakes;   // a flakes.json, or "auto" (a session's, measured here)
  int flake_texture = 32;
  bool cosine_lobes = false;
  std::string basis;
  ExtractArgs extract;  // --calib, --margin-px, --variance, --estimator; --threads for all
  CLI::Option* model_option = nullptr;
  CLI::Option* lobes_option = nullptr;
};

int run_export(const ExportArgs& a) {
  fit::OutputGuard guard;
  for (const auto& in : a.inputs) {
    guard.input("INPUT", in);
    for (const auto& f : fit::fitted_inputs_of(in)) guard.input("what " + in + " was fitted to", f);
  }
  guard.input("--calib", a.extract.calib).input("--basis", a.basis);
  if (a.cosine_lobes && a.basis.empty())
    throw UsageError("--cosine-lobes needs --basis BASIS.json (made by paintlab basis fit --dir LIBRARY)");
  if (!a.cosine_lobes && !a.basis.empty()) throw UsageError("--basis gives the exponents of --cosine-lobes: add it");
  if (a.flakes != "auto") guard.input("--flakes", a.flakes);
  guard.output({"--axf", a.axf}).output({"--merl", a.merl}).output({"--fit-out", a.fit_out}).check();
  fit::ExportRequest r;
  for (const auto& in : a.inputs) r.inputs.emplace_back(in);
  if (!a.axf.empty()) r.axf = a.axf;
  if (!a.merl.empty()) r.merl = a.merl;
  if (!a.fit_out.empty()) r.fit_out = a.fit_out;
  r.bin = bin_options(a.extract);
  if (a.model_option->count() > 0) r.model = a.model;
  if (a.lobes_option->count() > 0) r.lobes = a.lobes;
  r.name = a.name;
  r.seed = a.seed;
  r.threads = a.extract.threads;
  if (a.flakes == "auto") r.session_flakes = true;
  else if (!a.flakes.empty()) r.flakes = a.flakes;
  r.flake_texture = a.flake_texture;
  if (a.cosine_lobes) r.cosine_basis = a.basis;
  const fit::ExportResult result = fit::export_paint(r);
  for (const auto& line : result.lines) say(line);
  if (!result.converged) {
    for (const auto& line : result.not_converged)
      spdlog::warn("{}; the files are written all the same and record \"converged\": false (exit 1)", line);
    return kExitFailed;
  }
  return kExitOk;
}

int run_validate(const std::vector<std::string>& files) {
  int invalid = 0;
  for (const auto& f : files) {
    require_readable_file(f);  // a missing file, a folder, an unreadable one: exit 2
    const fit::AxfValidation v = fit::validate_axf_file(f);
    if (v.ok()) {
      std::string what = v.format == fit::kAxfLibraryFormat
                             ? fmt::format("paint library file, {} paints", v.paints.size())
                             : fmt::format("AxF-like paint '{}'", v.paints.empty() ? "" : v.paints[0]);
      say(fmt::format("{}: valid ({}, format version {})", f, what, v.format_version));
      continue;
    }
    ++invalid;
    say(fmt::format("{}: invalid ({} problem{})", f, v.problems.size(), v.problems.size() == 1 ? "" : "s"));
    for (const auto& p : v.problems) say("  " + p);
  }
  return invalid ? kExitFailed : kExitOk;
}

}  // namespace

void register_export_commands(CLI::App& app) {
  auto [exp, args] = add_command<ExportArgs>(&app, "export", kExportHelp, run_export);
  exp->add_option("INPUT", args->inputs, "session folder, or fit.json / .axf.h5 / .toml (one or two)")->required();
  exp->add_option("--axf", args->axf, "AxF-like paint file to write (.axf.h5)");
  exp->add_option("--merl", args->merl, "MERL .binary to write (measured bins + hole filling)");
  args->model_option =
      exp->add_option("--model", args->model, "Session only: model to fit: cook-torrance, axf-carpaint or both")
          ->capture_default_str();
  args->lobes_option = sets_fields(exp->add_option("--lobes", args->lobes, "Session only: lobes of the fit, 1..3"),
                                   {"CtFitOptions::lobes", "AxfFitOptions::lobes"})
                           ->capture_default_str();
  exp->add_option("--name", args->name, "Paint name (default: the sample name or the fit's name)")->check(utf8_text());
  exp->add_option("--fit-out", args->fit_out, "Session only, with --axf: also write the fit as fit.json");
  exp->add_option("--seed", args->seed, "Seed of the fit's random starts")->capture_default_str();
  exp->add_option("--flakes", args->flakes,
                  "With --axf: the measured flakes (statistics and CPA2-style flake BTF, docs/sparkle.md): a "
                  "flakes.json from `paintlab flakes`, or auto (a session: measured here against the fit)");
  exp->add_option("--flake-texture", args->flake_texture, "Texels a side of each flake BTF slice, 1..1024")
      ->check(CLI::Range(1, 1024))
      ->capture_default_str();
  exp->add_flag("--cosine-lobes", args->cosine_lobes,
               "With --axf: add the paint's cosine-lobe weights (per channel) for the exponents of --basis "
               "(docs/design.md \"Cosine-lobe basis\")");
  exp->add_option("--basis", args->basis, "The cosine-lobe basis (basis.json of paintlab basis fit)");
  add_extract_options(exp, args->extract, true);
  add_cfa_sites_option(exp, args->extract);

  CLI::App* axf = subcommand_group(app, "axf", "AxF-like paint files (HDF5): check and inspect");
  auto [validate, files] = add_command<std::vector<std::string>>(
      axf, "validate",
      "Check every field, shape, range and convention of AxF-like files (or library files); every problem names "
      "its field.\nExit 0 all valid, 1 a file is invalid (damaged, truncated, out of range), 2 bad usage.",
      run_validate);
  validate->add_option("FILE", *files, "AxF-like .axf.h5 or library .h5 files")->required();
  auto [show, show_file] = add_command<std::string>(
      axf, "show", "Print what an AxF-like file holds: parameters, fit quality, provenance", [](const std::string& f) {
        say(fit::describe_axf(fit::read_axf_file(f)));
        return kExitOk;
      });
  show->add_option("FILE", *show_file, "AxF-like .axf.h5")->required();
}

}  // namespace paintlab::app
