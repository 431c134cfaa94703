// paintlab fit INPUT --model cook-torrance|axf-carpaint [--lobes N] --out fit.json
// INPUT: a MERL .binary table (public measured tables, or one `paintlab bin` wrote).
#include <filesystem>
#include <fmt/format.h>

#include "cli.h"
#include "paintlab/brdf/merl.h"
#include "paintlab/core/error.h"
#include "paintlab/core/json.h"
#include "paintlab/core/log.h"
#include "paintlab/fitting/coverage.h"
#include "paintlab/fitting/pipeline.h"

namespace paintlab::app {

namespace {

struct FitArgs {
  std::string input;
  std::string model = "cook-torrance";
  int lobes = 3;
  std::string out;
  std::string name;
  std::uint64_t seed = 1;
  int threads = 0;
  int max_iterations = 100;
};

int run_fit(const FitArgs& a) {
  namespace fs = std::filesystem;
  fit::FitRequest req;
  req.model = fit::fit_model_from_string(a.model, "--model");
  req.cook_torrance.lobes = a.lobes;
  req.cook_torrance.seed = a.seed;
  req.cook_torrance.threads = a.threads;
  req.cook_torrance.max_iterations = a.max_iterations;
  req.cook_torrance.check();
  req.axf_carpaint.lobes = a.lobes;
  req.axf_carpaint.seed = a.seed;
  req.axf_carpaint.threads = a.threads;
  req.axf_carpaint.max_iterations = a.max_iterations;
  req.axf_carpaint.check();
  const fs::path input(a.input);
  if (!fs::exists(input)) throw IoError(a.input, "no such file or folder");
  if (fs::is_directory(input))
    throw UsageError(fmt::format("{}: a folder; paintlab fit reads a MERL .binary table", a.input));
  req.name = a.name.empty() ? fit::paint_name_from(input.stem().string()) : a.name;
  spdlog::info("reading {}", a.input);
  const brdf::MerlTable table = brdf::read_merl(input);
  const Json in = {{"kind", "merl"}, {"path", fs::absolute(input).string()}};
  spdlog::info("fitting {} ({} measured bins)", fit::to_string(req.model),
               table.count_in_state(brdf::BinState::Measured));
  const fit::FitOutcome outcome = fit::fit_table(table, nullptr, req, in);
  write_json_file(a.out, outcome.fit);
  std::string report = outcome.report;
  while (!report.empty() && report.back() == '\n') report.pop_back();
  say(report);
  say(fmt::format("wrote {}", a.out));
  return kExitOk;
}

}  // namespace

void register_fit_commands(CLI::App& app) {
  auto args = std::make_shared<FitArgs>();
  CLI::App* fit = app.add_subcommand(
      "fit",
      "Fit a paint model to a measured BRDF table and write fit.json (parameters, standard deviations, residuals "
      "per region, solver summary). Exit 1 when the fit does not converge; nothing is written then.");
  fit->add_option("INPUT", args->input, "MERL .binary table")->required();
  fit->add_option("--model", args->model, "Model to fit: cook-torrance or axf-carpaint")->capture_default_str();
  fit->add_option("--lobes", args->lobes, "Lobes (Cook-Torrance, or the car paint's achromatic lobes), 1..3")->capture_default_str();
  fit->add_option("--out", args->out, "fit.json to write")->required();
  fit->add_option("--name", args->name, "Paint name in fit.json (default: from the input)");
  fit->add_option("--seed", args->seed, "Seed of the random starts (the fit is deterministic for a seed)")
      ->capture_default_str();
  fit->add_option("--threads", args->threads, "Worker threads, 0 = all cores")->capture_default_str();
  fit->add_option("--max-iterations", args->max_iterations, "Iterations of the final solve")->capture_default_str();
  on_run(fit, [args] { return run_fit(*args); });
}

}  // namespace paintlab::app
