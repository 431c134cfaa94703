// paintlab basis fit --dir LIBRARY [--lobes N] [--max-lobes N] [--out basis.json] [--json]
// paintlab design --targets targets.toml --out paint.axf.h5 [--basis FILE | --dir LIBRARY] [--name] [--json]
// (docs/design.md "Cosine-lobe basis")
#include <fmt/format.h>

#include "cli.h"
#include "paintlab/core/error.h"
#include "paintlab/core/log.h"
#include "paintlab/brdf/paint.h"
#include "paintlab/fitting/axf_file.h"
#include "paintlab/fitting/export.h"
#include "paintlab/fitting/multiangle.h"
#include "paintlab/fitting/cosine_lobes.h"
#include "paintlab/fitting/output_guard.h"
#include "paintlab/fitting/paint_library.h"

namespace fs = std::filesystem;

namespace paintlab::app {

namespace {

constexpr const char* kBasisFitHelp =
    "Choose the exponents of the cosine-lobe basis for a paint library: for 1 to 11 lobes the set whose L1 fits "
    "have the least average-plus-worst mean relative error over the library's paints, as a table; the kept set "
    "(the fewest lobes within 10 % of the best criterion, or --lobes) is written to LIBRARY/basis.json (or --out). "
    "docs/design.md \"Cosine-lobe basis\".";

constexpr const char* kDesignHelp =
    "Design a paint from multi-angle colour targets: the non-negative cosine-lobe weights whose CIELAB at the "
    "targets' geometries (45as15, 45as45, 45as110, ...) comes closest (an L1 linear programme per channel), "
    "written as an AxF-like paint of model cosine-lobes. Prints each target against the design with dE00; a "
    "target counts as reached within dE00 0.5, and one that is not says why.\nExit 0 every target reached, 1 the "
    "paint is written but a target is out of reach, 2 bad input (nothing written).";

struct BasisFitArgs {
  std::string dir;
  std::string out;
  int lobes = 0;
  int max_lobes = brdf::kMaxCosineLobes;
  bool json = false;
};

struct DesignArgs {
  std::string targets;
  std::string out;
  std::string basis;
  std::string dir;
  std::string name;
  std::string like;
  bool json = false;
};

int run_basis_fit(const BasisFitArgs& a) {
  const fs::path out = a.out.empty() ? fs::path(a.dir) / "basis.json" : fs::path(a.out);
  const fit::PaintLibrary library = fit::PaintLibrary::open(a.dir, false);  // "no library here" before anything else
  // The library's basis.json is the library's own: basis fit may write it (as library add its paints).
  fit::OutputGuard().output({"--out", out}, fs::path(a.dir)).check();
  std::vector<std::pair<std::string, std::shared_ptr<const brdf::Brdf>>> paints;
  for (const fit::LibraryEntry& e : library.list())
    paints.emplace_back(e.name, brdf::make_brdf(library.load(e.name).paint_spec()));
  if (paints.empty()) throw UsageError(fmt::format("--dir {}: the library holds no paints", a.dir));
  fit::CosineBasisOptions o;
  o.max_lobes = a.max_lobes;
  if (a.lobes > 0) o.lobes = a.lobes;
  o.progress = [&](const fit::CosineBasisRow& r) {
    spdlog::info("{} lobe{}: mean relative error {:.1f} %, worst paint {:.1f} % ({}), {} exponent sets tried", r.lobes,
                 r.lobes == 1 ? "" : "s", 100 * r.mean_error, 100 * r.max_error, r.worst_paint, r.evaluations);
  };
  fit::CosineBasis basis = fit::fit_cosine_basis(paints, o);
  basis.library = a.dir;
  fit::write_cosine_basis(out, basis);
  if (a.json) {
    say(basis.to_json().dump(2));
  } else {
    say(fmt::format("{} paints of {}:", paints.size(), a.dir));
    say(fit::cosine_basis_table(basis));
    say(fmt::format("wrote {} ({} lobes)", out.string(), basis.lobes));
  }
  return kExitOk;
}

int run_design(const DesignArgs& a) {
  fit::OutputGuard guard;
  guard.input("--targets", a.targets).input("--basis", a.basis);
  guard.output({"--out", a.out}).check();
  const fit::DesignTargets targets = fit::load_design_targets(a.targets);
  fs::path basis_file;
  if (!a.basis.empty()) basis_file = a.basis;
  else if (!a.dir.empty()) basis_file = fs::path(a.dir) / "basis.json";
  else if (targets.basis) basis_file = *targets.basis;
  else
    throw UsageError("no cosine-lobe basis: give --basis FILE or --dir LIBRARY (its basis.json; make it with paintlab "
                     "basis fit --dir LIBRARY), or basis = \"FILE\" in " + a.targets);
  if (!fs::exists(basis_file))
    throw UsageError(fmt::format("basis {} does not exist (make it with paintlab basis fit --dir LIBRARY)",
                                 basis_file.string()));
  const fit::CosineBasis basis = fit::read_cosine_basis(basis_file);
  // --like: the lobes no target sees take this paint's weights (its own cosine-lobe form when it
  // has one for these exponents, else fitted now).
  std::optional<brdf::CosineLobeParams> like;
  if (!a.like.empty()) {
    const fit::AxfPaint p = fit::load_any_paint(fit::resolve_paint_input(a.like, a.dir));
    if (p.cosine_lobes && p.cosine_lobes->exponents == basis.exponents)
      like = *p.cosine_lobes;
    else
      like = fit::fit_cosine_lobes(*brdf::make_brdf(p.paint_spec()), basis.exponents).params;
  }
  const fit::DesignResult r = fit::design_paint(basis.exponents, targets.targets, like ? &*like : nullptr);

  fit::AxfPaint paint;
  paint.name = a.name.empty() ? targets.name : a.name;
  paint.model = "cosine-lobes";
  paint.colour_space = colour::kLinearSrgb;
  paint.cosine_lobes = r.params;
  paint.provenance.source = fmt::format("paintlab design --targets {} (basis {}{})", a.targets, basis_file.string(),
                                        a.like.empty() ? "" : ", unseen lobes like " + a.like);
  fit::write_axf_file(a.out, paint);
  if (a.json) {
    Json j = fit::design_json(r);
    j["paint"] = a.out;
    j["basis"] = basis_file.string();
    say(j.dump(2));
  } else {
    say(fit::design_table(r));
    say(fmt::format("wrote {} (paint '{}', {} lobes of {})", a.out, paint.name, basis.exponents.size(),
                    basis_file.string()));
  }
  if (!r.all_reached()) {
    spdlog::warn("a target is out of reach of the basis (see NOT REACHED above): the paint written is the closest");
    return kExitFailed;
  }
  return kExitOk;
}

}  // namespace

void register_design_commands(CLI::App& app) {
  CLI::App* basis = subcommand_group(app, "basis", "The cosine-lobe basis of a paint library (paint design)");
  auto [bf, ba] = add_command<BasisFitArgs>(basis, "fit", kBasisFitHelp, run_basis_fit);
  bf->add_option("--dir", ba->dir, "The paint library (a folder with index.json)")->required();
  bf->add_option("--out", ba->out, "Where to write the basis (default: LIBRARY/basis.json)");
  sets_fields(bf->add_option("--lobes", ba->lobes, "Keep this many lobes (default: the fewest within 10 % of the best)"),
              {"CosineBasisOptions::lobes"})
      ->check(CLI::Range(1, brdf::kMaxCosineLobes));
  sets_fields(bf->add_option("--max-lobes", ba->max_lobes, "Try 1 to this many lobes"), {"CosineBasisOptions::max_lobes"})
      ->check(CLI::Range(1, brdf::kMaxCosineLobes))
      ->capture_default_str();
  bf->add_flag("--json", ba->json, "Print the basis (basis.json's object) instead of the table");

  auto [d, da] = add_command<DesignArgs>(&app, "design", kDesignHelp, run_design);
  d->add_option("--targets", da->targets,
                "targets.toml: [[target]] tables of geometry = \"45as15\" and lab = [L, a, b]; optional name and basis")
      ->required();
  d->add_option("--out", da->out, "The designed paint (.axf.h5)")->required();
  d->add_option("--basis", da->basis, "The cosine-lobe basis (basis.json)");
  d->add_option("--dir", da->dir, "A paint library whose basis.json to use");
  d->add_option("--like", da->like,
                "A paint (library name or file) whose lobes the targets do not see (its clear coat) the design keeps");
  d->add_option("--name", da->name, "Paint name (default: the targets file's name, else 'designed')")->check(utf8_text());
  d->add_flag("--json", da->json, "Print the result as JSON");
}

}  // namespace paintlab::app
