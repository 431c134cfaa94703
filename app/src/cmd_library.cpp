// paintlab library {add,list,show,remove,export,match,interpolate} --dir DIR ...   (docs/library.md,
// docs/design.md)
#include <filesystem>
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "cli.h"
#include "paintlab/fitting/output_guard.h"
#include "paintlab/fitting/export.h"
#include "paintlab/core/error.h"
#include "paintlab/fitting/interpolate.h"
#include "paintlab/fitting/multiangle.h"
#include "paintlab/fitting/paint_library.h"

namespace fs = std::filesystem;

namespace paintlab::app {

namespace {

struct LibraryArgs {
  std::string dir;
  std::string file;
  std::string name;
  bool replace = false;
  bool json = false;
  std::string h5;
  std::string folder;
  bool overwrite = false;
  std::string paint;
  std::string geometries = fit::kDefaultGeometrySet;
  double max_de = 1.0;
  std::vector<std::string> parents;
  std::vector<double> weights;
  bool free_weights = false;
  bool flakes_lightness_only = false;
  bool keep_flake_lightness = false;
  std::string out;
};

void warn_findings(const fit::PaintLibrary& lib) {
  for (const auto& f : lib.check()) spdlog::warn("library {}: {}", lib.dir().string(), f);
}

int run_add(const LibraryArgs& a) {
  OutputSpec dir("--dir", a.dir);
  dir.folder = true;
  dir.create_parents = true;
  fit::OutputGuard().input("FILE", a.file).output(dir, fs::path(a.dir)).check();
  const fit::LibraryEntry e = fit::library_add(a.dir, a.file, a.replace, a.name);
  say(fmt::format("added '{}' to {} ({}, {})", e.name, a.dir, e.model, e.file));
  return kExitOk;
}

int run_list(const LibraryArgs& a) {
  const fit::PaintLibrary lib = fit::PaintLibrary::open(a.dir, false);
  const auto entries = lib.list();
  if (a.json) {
    Json arr = Json::array();
    for (const auto& e : entries) arr.push_back(e.to_json());
    say(arr.dump(2));
    warn_findings(lib);
    return kExitOk;
  }
  std::size_t w = 4;
  for (const auto& e : entries) w = std::max(w, e.name.size());
  say(fmt::format("{:<{}}  {:<20}  {:<13}  {:>8}  {:>8}  {:<18}  {}", "NAME", w, "DATE", "MODEL", "LOG_RMS", "BINS",
                  "L* a* b* AT 45as45", "SPARKLE AREA % AT 15/45/75"));
  for (const auto& e : entries) {
    std::string lab = "-";
    for (const auto& [g, v] : e.colour)
      if (g == "45as45") lab = fmt::format("{:.1f} {:.1f} {:.1f}", v.L, v.a, v.b);
    std::string sparkle = "-";
    if (e.sparkle) {
      sparkle.clear();
      for (const fit::LibrarySparkle::At& at : e.sparkle->at)
        sparkle += (sparkle.empty() ? "" : " / ") + (at.area_percent ? fmt::format("{:.2f}", *at.area_percent) : "n/m");
    }
    say(fmt::format("{:<{}}  {:<20}  {:<13}  {:>8}  {:>8}  {:<18}  {}", e.name, w, e.date, e.model,
                    e.log_rms ? fmt::format("{:.4f}", *e.log_rms) : "-",
                    e.bins_used ? std::to_string(*e.bins_used) : "-", lab, sparkle));
  }
  say(fmt::format("{} paint{} in {}", entries.size(), entries.size() == 1 ? "" : "s", lib.dir().string()));
  warn_findings(lib);
  return kExitOk;
}

int run_show(const LibraryArgs& a) {
  const fit::PaintLibrary lib = fit::PaintLibrary::open(a.dir, false);
  const fit::LibraryEntry e = lib.find(a.name);
  say(fit::describe_axf(lib.load(a.name)));
  say(fmt::format("  library file {} (sha256 {}), added {}", e.file, e.sha256, e.added_utc));
  if (e.colour.empty()) say("  colour: none stored (a paint in camera RGB, or added by an older paintlab)");
  for (const auto& [g, v] : e.colour)
    say(fmt::format("  {:<8} L* {:6.2f}  a* {:6.2f}  b* {:6.2f}  (D65, 2 deg)", g, v.L, v.a, v.b));
  if (!e.sparkle) {
    say("  sparkle: none stored (no measured flakes in the file, or added by an older paintlab)");
  } else {
    say(fmt::format("  sparkle: {} glints, {:.2f} % of the pixel samples, lifetime {:.2f} deg", e.sparkle->glints,
                    e.sparkle->area_percent, e.sparkle->lifetime_deg));
    for (const fit::LibrarySparkle::At& at : e.sparkle->at)
      say(fmt::format("  sparkle at {:>2.0f} deg light, viewed along the normal: area {}, intensity {}",
                      at.illumination_deg, at.area_percent ? fmt::format("{:.2f} %", *at.area_percent) : "not measured",
                      at.intensity ? fmt::format("{:.2f}", *at.intensity) : "no glint"));
  }
  return kExitOk;
}

int run_match(const LibraryArgs& a) {
  const fit::PaintLibrary lib = fit::PaintLibrary::open(a.dir, false);
  const auto geometries = fit::geometry_set(a.geometries);
  const fit::MultiAngleColour target = fit::any_colour(fit::resolve_paint_input(a.paint, a.dir), geometries);
  const fit::LibraryMatchResult r = fit::library_match(lib, target, geometries);
  for (const auto& n : r.skipped) spdlog::warn("library {}: '{}' has no CIELAB (camera RGB): left out", a.dir, n);
  std::size_t within = 0;
  while (within < r.matches.size() && r.matches[within].worst_de00 <= a.max_de) ++within;
  if (a.json) {
    Json arr = Json::array();
    for (std::size_t i = 0; i < within; ++i) {
      const auto& m = r.matches[i];
      arr.push_back({{"name", m.name}, {"worst_de00", m.worst_de00}, {"worst_geometry", m.worst_geometry},
                     {"mean_de00", m.mean_de00}});
    }
    say(Json{{"paint", target.paint}, {"geometries", a.geometries}, {"max_de00", a.max_de}, {"matches", arr}}.dump(2));
    return kExitOk;
  }
  say(fmt::format("{} against {} paints of {} at {} ({} geometries; worst-geometry CIEDE2000)", target.paint,
                  r.matches.size(), lib.dir().string(), a.geometries, geometries.size()));
  if (within == 0) {
    say(r.matches.empty() ? std::string("no paint to compare with")
                          : fmt::format("no paint within dE00 {:.2f}; the closest is '{}' (worst dE00 {:.2f} at {})",
                                        a.max_de, r.matches.front().name, r.matches.front().worst_de00,
                                        r.matches.front().worst_geometry));
    return kExitOk;
  }
  say(fmt::format("{:>4}  {:<24} {:>10}  {:<9} {:>9}", "RANK", "NAME", "WORST dE00", "AT", "MEAN dE00"));
  for (std::size_t i = 0; i < within; ++i) {
    const auto& m = r.matches[i];
    say(fmt::format("{:>4}  {:<24} {:>10.2f}  {:<9} {:>9.2f}", i + 1, m.name, m.worst_de00, m.worst_geometry,
                    m.mean_de00));
  }
  say(fmt::format("{} of {} paints within dE00 {:.2f}", within, r.matches.size(), a.max_de));
  return kExitOk;
}

int run_remove(const LibraryArgs& a) {
  fit::PaintLibrary lib = fit::PaintLibrary::open(a.dir, false);
  lib.remove(a.name);
  say(fmt::format("removed '{}' from {}", a.name, lib.dir().string()));
  return kExitOk;
}

int run_export(const LibraryArgs& a) {
  if (a.h5.empty() == a.folder.empty()) throw UsageError("library export: give exactly one of --h5 FILE or --folder DIR");
  OutputSpec folder("--folder", a.folder);
  folder.folder = true;
  folder.create_parents = true;
  // The library is protected as a whole (nothing of it may be written over); the export may go
  // beside it, also into a folder that holds it.
  fit::OutputGuard().output({"--h5", a.h5}).output(folder).check();
  const fit::PaintLibrary lib = fit::PaintLibrary::open(a.dir, false);
  if (!a.h5.empty()) {
    lib.export_h5(a.h5);
    say(fmt::format("wrote {} ({} paints)", a.h5, lib.list().size()));
  } else {
    const auto files = lib.export_folder(a.folder, a.overwrite);
    say(fmt::format("wrote {} AxF-like files to {}", files.size(), a.folder));
  }
  return kExitOk;
}

int run_interpolate(const LibraryArgs& a) {
  fit::OutputGuard guard;
  guard.output({"--out", a.out});
  const fit::PaintLibrary lib = fit::PaintLibrary::open(a.dir, false);
  std::vector<fit::AxfPaint> parents;
  std::vector<bool> is_library;
  for (const std::string& p : a.parents) {
    bool in_library = false;
    for (const fit::LibraryEntry& e : lib.list()) in_library = in_library || e.name == p;
    is_library.push_back(in_library);
    if (in_library) {
      parents.push_back(lib.load(p));  // its checksum checked
    } else if (fs::exists(p)) {
      guard.input("PAINT", p);
      parents.push_back(fit::load_any_paint(p));
    } else {
      throw UsageError(fmt::format("PAINT '{}': neither a paint in library {} nor a file", p, a.dir));
    }
  }
  guard.check();
  fit::InterpolateOptions o;
  o.name = a.name;
  o.free_weights = a.free_weights;
  if (a.flakes_lightness_only) o.flake_colour = fit::FlakeColourMode::LightnessOnly;
  if (a.keep_flake_lightness) o.flake_colour = fit::FlakeColourMode::KeepLightness;
  // Two library paints first: their transports come from (or go into) the library's cache. A
  // paint counts as the library's when it is the very paint read from it (a file whose paint
  // bears a library paint's name is not).
  auto library_name = [&](const fit::AxfPaint& x) -> const std::string* {
    for (std::size_t k = 0; k < parents.size(); ++k)
      if (is_library[k] && parents[k] == x) return &a.parents[k];
    return nullptr;
  };
  o.first_pair = [&](const fit::AxfPaint& x, const fit::AxfPaint& y) {
    const std::string *nx = library_name(x), *ny = library_name(y);
    if (!nx || !ny) return fit::interpolatable_paint(x, y);
    bool cached = false;
    fit::InterpolatablePaint m = lib.interpolatable(*nx, *ny, &cached);
    spdlog::info("flake transports of '{}' and '{}': {}", x.name, y.name,
                 cached ? "read from the library's cache" : "computed and cached in the library");
    return m;
  };
  const fit::RealisedPaint r = fit::interpolate_paints(parents, a.weights, o);
  for (const std::string& n : r.notes) spdlog::warn("{}", n);
  for (const std::string& c : r.clamped)
    spdlog::warn("extrapolated outside what a paint holds, clamped: {}", c);
  fit::write_axf_file(a.out, r.paint);
  say(fit::describe_axf(fit::read_axf_file(a.out)));
  say(fmt::format("wrote {} ({}){}", a.out, r.paint.provenance.source,
                  r.clamped.empty() ? "" : fmt::format("; {} values clamped", r.clamped.size())));
  return kExitOk;
}

}  // namespace

void register_library_commands(CLI::App& app) {
  CLI::App* group = subcommand_group(
      app, "library",
      "Paint libraries: a folder of AxF-like files with index.json (docs/library.md). Changes are atomic: a crash "
      "leaves the old or the new index.");
  // Every library command works on --dir.
  auto command = [group](const char* name, const char* help, int (*run)(const LibraryArgs&)) {
    const auto added = add_command<LibraryArgs>(group, name, help, run);
    added.first->add_option("--dir", added.second->dir, "Library folder")->required();
    return added;
  };
  auto [add, a] = command(
      "add", "Add a paint (an AxF-like .axf.h5, a fit.json or a paint .toml); creates the library if needed", run_add);
  add->add_option("FILE", a->file, "paint to add")->required();
  add->add_option("--name", a->name, "Name in the library (default: the paint's name)")->check(utf8_text());
  add->add_flag("--replace", a->replace, "Replace a paint of the same name (refused otherwise)");

  auto [list, l] = command("list", "List the paints: name, date, model, fit residual", run_list);
  list->add_flag("--json", l->json, "Print the index entries as JSON");

  auto [show, s] = command("show", "Print one paint: parameters, standard deviations, fit quality, provenance", run_show);
  show->add_option("NAME", s->name, "paint name")->required();

  auto [match, m] = command(
      "match",
      "Rank the library's paints by their worst-geometry CIEDE2000 against PAINT (a paint file, a session, or a "
      "name in the library): the colour match a lab runs every day (docs/colour.md)",
      run_match);
  match->add_option("PAINT", m->paint, "the paint to match")->required();
  auto [interp, ip] = command(
      "interpolate",
      "A new paint between (or beyond) paints of the library, as Golla and Klein interpolate metallic car paints: "
      "the model's parameters linearly, the colour table in CIELAB, each flake slice's colour clusters matched by "
      "optimal transport (docs/design.md). Exit 0 written, 2 bad input (nothing written).",
      run_interpolate);
  interp->add_option("PAINTS", ip->parents, "2 to 5 paints: names in the library (or AxF-like / fit / paint files)")
      ->required()
      ->expected(2, 5);
  interp->add_option("--weights", ip->weights,
                     "One weight per paint, comma-separated, summing to 1 (0.75,0.25; outside [0, 1] extrapolates: "
                     "--weights=-0.25,1.25)")
      ->required()
      ->delimiter(',');
  interp->add_flag("--free-weights", ip->free_weights, "Allow weights that do not sum to 1");
  auto* lightness_only = interp->add_flag(
      "--flakes-lightness-only", ip->flakes_lightness_only,
      "Interpolate only the flakes' lightness; their hue (a*, b*) stays the first paint's (Golla and Klein 4.4)");
  interp->add_flag("--keep-flake-lightness", ip->keep_flake_lightness,
                   "Keep the first paint's flake lightness; their hue interpolates")
      ->excludes(lightness_only);
  interp->add_option("--name", ip->name, "Name of the new paint (default: the parents' names and weights)")
      ->check(utf8_text());
  interp->add_option("--out", ip->out, "The AxF-like file to write (outside the library; `library add` adds it)")
      ->required();
  match->add_option("--geometries", m->geometries, "Geometry set (colour's names, or a .toml file)")
      ->capture_default_str();
  match->add_option("--max-de", m->max_de, "List paints whose worst dE00 is at most this")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  match->add_flag("--json", m->json, "Print JSON");

  auto [remove, r] = command("remove", "Remove a paint (the index first, then its file)", run_remove);
  remove->add_option("NAME", r->name, "paint name")->required();

  auto [exp, e] = command(
      "export", "Write the whole library as one HDF5 file (--h5) or as a folder of AxF-like files (--folder)",
      run_export);
  exp->add_option("--h5", e->h5, "One HDF5 file with every paint under /paints/<name>");
  exp->add_option("--folder", e->folder, "A folder of <name>.axf.h5 files");
  exp->add_flag("--overwrite", e->overwrite, "--folder: replace existing files");
}

}  // namespace paintlab::app
