// paintlab export INPUT [INPUT2] (--axf FILE | --merl FILE ...)   (docs/axf-like.md)
// paintlab axf validate FILE...                                  exit 0 valid, 1 invalid
// paintlab axf show FILE
// INPUT: a session folder (binned and fitted here), or one or two paint files (fit.json of
// either model, AxF-like .axf.h5, paint .toml).
#include <filesystem>
#include <fmt/format.h>
#include <optional>
#include <spdlog/spdlog.h>

#include "cli.h"
#include "export_support.h"
#include "paintlab/acquisition/session.h"
#include "paintlab/brdf/merl.h"
#include "paintlab/core/error.h"
#include "paintlab/core/json.h"
#include "paintlab/fitting/axf_file.h"
#include "paintlab/fitting/extraction.h"
#include "paintlab/fitting/pipeline.h"

namespace fs = std::filesystem;

namespace paintlab::app {

namespace {

struct ExportArgs {
  std::vector<std::string> inputs;
  std::string axf;
  std::string merl;
  std::string model = "cook-torrance";
  int lobes = 3;
  std::string name;
  std::string calib;
  std::string fit_out;
  std::uint64_t seed = 1;
  int threads = 0;
  bool model_given = false;
};

// The measured table of a session, binned with the standard options.
fit::BinnedTable bin_session(const acq::SessionDir& session, const std::optional<fs::path>& calib_dir, int threads) {
  const auto frames = session_frames(session);
  const calib::RigCalibration cal = session_calibration(session, calib_dir);
  fit::ExtractionOptions eo;
  eo.threads = threads;
  fit::BinningOptions bo;
  bo.threads = threads;
  spdlog::info("binning {} HDR images of {}", frames.size(), session.dir().string());
  fit::ExtractionStats stats;
  fit::BinnedTable t = fit::bin_frames(frames, cal, eo, bo, &stats);
  spdlog::info("{} samples in {} bins", stats.samples, t.table.count_in_state(brdf::BinState::Measured));
  return t;
}

std::vector<fit::FitModel> models_of(const std::string& s) {
  if (s == "both") return {fit::FitModel::CookTorrance, fit::FitModel::AxfCarPaint};
  return {fit::fit_model_from_string(s, "--model")};
}

int run_export(const ExportArgs& a) {
  if (a.axf.empty() && a.merl.empty()) throw UsageError("nothing to write: give --axf FILE and/or --merl FILE");
  if (a.inputs.empty() || a.inputs.size() > 2) throw UsageError("give one session folder, or one or two paint files");
  const std::optional<fs::path> calib_dir = a.calib.empty() ? std::nullopt : std::optional<fs::path>(a.calib);
  const fs::path first(a.inputs[0]);

  std::optional<fit::AxfPaint> paint;
  std::optional<brdf::MerlTable> merl_table;

  if (is_session_dir(first)) {
    if (a.inputs.size() != 1) throw UsageError("a session is exported alone (one INPUT)");
    const acq::SessionDir session = acq::SessionDir::open(first);
    fit::BinnedTable binned = bin_session(session, calib_dir, a.threads);
    if (!a.axf.empty()) {
      const auto models = models_of(a.model);
      if (!a.fit_out.empty() && models.size() > 1)
        throw UsageError("--fit-out writes one fit: choose --model cook-torrance or axf-carpaint");
      const Json input = {{"kind", "session"}, {"path", fs::absolute(first).lexically_normal().string()},
                          {"session_sha256", session_sha256(first)}};
      for (fit::FitModel m : models) {
        fit::FitRequest req;
        req.model = m;
        req.name = a.name.empty() ? fit::paint_name_from(session.manifest().sample) : a.name;
        req.cook_torrance.lobes = a.lobes;
        req.cook_torrance.seed = a.seed;
        req.cook_torrance.threads = a.threads;
        req.axf_carpaint.lobes = a.lobes;
        req.axf_carpaint.seed = a.seed;
        req.axf_carpaint.threads = a.threads;
        spdlog::info("fitting {}", fit::to_string(m));
        const fit::FitOutcome out = fit::fit_table(
            binned.table, binned.noise_variance.empty() ? nullptr : &binned.noise_variance, req, input);
        if (!a.fit_out.empty()) {
          write_json_file(a.fit_out, out.fit);
          say(fmt::format("wrote {}", a.fit_out));
        }
        fit::AxfPaint p = fit::axf_from_fit_json(out.fit, std::string("the ") + fit::to_string(m) + " fit");
        paint = paint ? fit::merge_axf(std::move(*paint), p) : p;
      }
      paint->provenance = session_provenance(session);
    }
    if (!a.merl.empty()) merl_table = std::move(binned.table);
  } else {
    if (a.model_given || !a.fit_out.empty())
      throw UsageError("--model, --lobes and --fit-out apply to a session; the inputs here are paint files");
    std::optional<Json> fit_input;  // "input" of a fit.json: what was fitted
    for (const auto& in : a.inputs) {
      fit::AxfPaint p = load_any_paint(in);
      if (fs::path(in).extension() == ".json") {
        const Json j = read_json_file(in);
        if (j.contains("input") && j["input"].is_object() && !fit_input) fit_input = j["input"];
      }
      paint = paint ? fit::merge_axf(std::move(*paint), p) : p;
    }
    // A fit of a session: the provenance is the session's (when it is still there).
    if (fit_input && fit_input->value("kind", "") == "session") {
      const fs::path sp = fit_input->value("path", "");
      if (is_session_dir(sp)) {
        const std::string source = paint->provenance.source;
        paint->provenance = session_provenance(acq::SessionDir::open(sp));
        paint->provenance.source = source + " (a fit of session " + sp.string() + ")";
      } else {
        spdlog::warn("the fitted session {} is not there: provenance without the measurement", sp.string());
      }
    }
    if (!a.merl.empty()) {
      const std::string kind = fit_input ? fit_input->value("kind", "") : "";
      const fs::path path = fit_input ? fs::path(fit_input->value("path", "")) : fs::path();
      if (kind == "merl" && fs::exists(path)) {
        merl_table = brdf::read_merl(path);
      } else if (kind == "session" && is_session_dir(path)) {
        merl_table = bin_session(acq::SessionDir::open(path), calib_dir, a.threads).table;
      } else {
        throw UsageError(
            "--merl exports measured data: give the session folder, or a fit.json whose measured input (a session "
            "or a MERL table) still exists");
      }
    }
  }

  if (paint) {
    if (!a.name.empty()) paint->name = a.name;
    fit::write_axf_file(a.axf, *paint);
    std::string quality;
    if (paint->fit_quality)
      quality = fmt::format(", log RMS {:.4f} over {} bins", paint->fit_quality->log_rms, paint->fit_quality->bins_used);
    say(fmt::format("wrote {} (AxF-like paint '{}', model {}{}{})", a.axf, paint->name, paint->model,
                    paint->carpaint && paint->cook_torrance ? " + cook-torrance" : "", quality));
  }
  if (merl_table) say(write_filled_merl(std::move(*merl_table), a.merl));
  return kExitOk;
}

int run_validate(const std::vector<std::string>& files) {
  int invalid = 0;
  for (const auto& f : files) {
    if (!fs::exists(f)) throw IoError(f, "no such file");
    const fit::AxfValidation v = fit::validate_axf_file(f);
    if (v.ok()) {
      std::string what = v.format == fit::kAxfLibraryFormat
                             ? fmt::format("paint library file, {} paints", v.paints.size())
                             : fmt::format("AxF-like paint '{}'", v.paints.empty() ? "" : v.paints[0]);
      say(fmt::format("{}: valid ({}, format version {})", f, what, fit::kAxfFormatVersion));
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
  auto args = std::make_shared<ExportArgs>();
  CLI::App* exp = app.add_subcommand(
      "export",
      "Export a measured paint: an AxF-like HDF5 file (docs/axf-like.md) and/or the measured, hole-filled MERL "
      ".binary table.\nINPUT is a session folder (binned and fitted here), or one or two paint files: fit.json "
      "(either model; two fits of one measurement are merged), .axf.h5 or paint .toml.\nExit 0 written, 1 the fit "
      "did not converge (nothing written), 2 bad input.");
  exp->add_option("INPUT", args->inputs, "session folder, or fit.json / .axf.h5 / .toml (one or two)")->required();
  exp->add_option("--axf", args->axf, "AxF-like paint file to write (.axf.h5)");
  exp->add_option("--merl", args->merl, "MERL .binary to write (measured bins + hole filling)");
  exp->add_option("--model", args->model, "Session only: model to fit: cook-torrance, axf-carpaint or both")
      ->capture_default_str()
      ->each([args](const std::string&) { args->model_given = true; });
  exp->add_option("--lobes", args->lobes, "Session only: lobes of the fit, 1..3")
      ->capture_default_str()
      ->each([args](const std::string&) { args->model_given = true; });
  exp->add_option("--name", args->name, "Paint name (default: the sample name or the fit's name)");
  exp->add_option("--calib", args->calib, "Calibration folder (default: the one of the session's rig file)");
  exp->add_option("--fit-out", args->fit_out, "Session only: also write the fit as fit.json");
  exp->add_option("--seed", args->seed, "Seed of the fit's random starts")->capture_default_str();
  exp->add_option("--threads", args->threads, "Worker threads, 0 = all cores")->capture_default_str();
  on_run(exp, [args] { return run_export(*args); });

  CLI::App* axf = subcommand_group(app, "axf", "AxF-like paint files (HDF5): check and inspect");
  auto files = std::make_shared<std::vector<std::string>>();
  CLI::App* validate = axf->add_subcommand(
      "validate",
      "Check every field, shape, range and convention of AxF-like files (or library files); every problem names "
      "its field.\nExit 0 all valid, 1 a file is invalid (damaged, truncated, out of range), 2 bad usage.");
  validate->add_option("FILE", *files, "AxF-like .axf.h5 or library .h5 files")->required();
  on_run(validate, [files] { return run_validate(*files); });

  auto show_file = std::make_shared<std::string>();
  CLI::App* show = axf->add_subcommand("show", "Print what an AxF-like file holds: parameters, fit quality, provenance");
  show->add_option("FILE", *show_file, "AxF-like .axf.h5")->required();
  on_run(show, [show_file] {
    std::string text = fit::describe_axf(fit::read_axf_file(*show_file));
    while (!text.empty() && text.back() == '\n') text.pop_back();
    say(text);
    return kExitOk;
  });
}

}  // namespace paintlab::app
