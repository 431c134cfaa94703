#include "paintlab/fitting/export.h"

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <optional>

#include "paintlab/brdf/paint.h"
#include "paintlab/core/atomic_file.h"
#include "paintlab/core/error.h"
#include "paintlab/core/geometry.h"
#include "paintlab/core/hash.h"
#include "paintlab/core/image_io.h"
#include "paintlab/core/json.h"
#include "paintlab/core/log.h"
#include "paintlab/core/rig.h"
#include "paintlab/core/version.h"
#include "paintlab/acquisition/session_reader.h"
#include "paintlab/fitting/cosine_lobes.h"
#include "paintlab/fitting/hole_fill.h"
#include "paintlab/fitting/prefiltered_env.h"

namespace fs = std::filesystem;

namespace paintlab::fit {

namespace {
std::string lower_extension(const fs::path& p) {
  std::string e = p.extension().string();
  std::transform(e.begin(), e.end(), e.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return e;
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

std::vector<FitModel> models_of(const std::string& s) {
  // The AxF car paint first: it is the paint of the file (model axf-carpaint), the
  // Cook-Torrance fit rides along in /cook_torrance.
  if (s == "both") return {FitModel::AxfCarPaint, FitModel::CookTorrance};
  return {fit_model_from_string(s, "--model")};
}

std::string axf_line(const fs::path& file, const AxfPaint& p) {
  std::string quality;
  if (p.fit_quality)
    quality = fmt::format(", log RMS {:.4f} over {} bins", p.fit_quality->log_rms, p.fit_quality->bins_used);
  return fmt::format("wrote {} (AxF-like paint '{}', model {}{}{})", file.string(), p.name, p.model,
                     p.carpaint && p.cook_torrance ? " + cook-torrance" : "", quality);
}

// Adds measured flakes to a paint: their statistics and BTF, or nothing for a paint without
// glints (no invented sparkle); the line that says which.
std::string attach_flakes(AxfPaint& paint, const FlakeStats& stats, int texture) {
  if (stats.empty()) {
    paint.flake_stats.reset();
    paint.flake_btf.reset();
    return fmt::format("flakes: no glint in {} pixel observations: no flake model (a paint without sparkle)",
                       stats.pixels);
  }
  paint.flake_stats = stats;
  paint.flake_btf = make_flake_btf(stats, texture);
  return fmt::format("flakes: sparkle area {:.3f} %, lifetime {:.2f} deg; flake BTF of {} slices of {} x {} texels",
                     100.0 * stats.area(), stats.lifetime_deg, paint.flake_btf->slices(), texture, texture);
}

AxfPaint paint_of_fits(const std::vector<Json>& fits) {
  if (fits.empty()) throw UsageError("export_axf: no fit given");
  std::optional<AxfPaint> paint;
  for (std::size_t i = 0; i < fits.size(); ++i) {
    const std::string model = fits[i].is_object() ? fits[i].value("model", std::string("?")) : std::string("?");
    AxfPaint p = axf_from_fit_json(fits[i], fmt::format("the {} fit", model));
    paint = paint ? merge_axf(std::move(*paint), p) : std::move(p);
  }
  return std::move(*paint);
}

SessionBinOptions with_threads(SessionBinOptions o, int threads) {
  o.extraction.threads = threads;
  o.binning.threads = threads;
  return o;
}

// Adds the paint's cosine-lobe weights for the basis in `basis_file`; the line for people.
std::string attach_cosine_lobes(AxfPaint& paint, const fs::path& basis_file) {
  const CosineBasis basis = read_cosine_basis(basis_file);
  const CosineLobeFit fit = fit_cosine_lobes(*brdf::make_brdf(paint.paint_spec()), basis.exponents);
  paint.cosine_lobes = fit.params;
  return fmt::format("cosine lobes: {} exponents of {}, mean relative error {:.1f} % (largest {:.0f} %)",
                     basis.exponents.size(), basis_file.string(), 100 * fit.mean_error, 100 * fit.max_error);
}

// Binning + fitting of a session (export_paint's session branch).
void export_session(const ExportRequest& r, ExportResult& result) {
  if (r.inputs.size() != 1) throw UsageError("a session is exported alone (one INPUT)");
  const std::vector<FitModel> models = models_of(r.model.value_or("cook-torrance"));
  if (r.fit_out && models.size() > 1)
    throw UsageError("--fit-out writes one fit: choose --model cook-torrance or axf-carpaint");
  if (r.fit_out && !r.axf) throw UsageError("--fit-out comes with --axf (the fit is made for the AxF-like file)");
  const fs::path& dir = r.inputs[0];
  const acq::SessionDir session = acq::SessionDir::open(dir);

  auto t0 = std::chrono::steady_clock::now();
  // The Cook-Torrance fit may be made at the filter-array sites (r.bin.sites); the MERL table
  // and the car-paint model's fit take the demosaiced image, binned separately when needed.
  const bool any_other_model =
      std::any_of(models.begin(), models.end(), [](FitModel m) { return m != FitModel::CookTorrance; });
  const bool cook_torrance = std::find(models.begin(), models.end(), FitModel::CookTorrance) != models.end();
  SessionBinOptions site_options = with_threads(r.bin, r.threads);
  if (site_options.sites == SiteFit::On && !(r.axf && cook_torrance))
    throw UsageError("--cfa-sites on is for the cook-torrance fit of --axf (--model cook-torrance or both)");
  if (!r.axf || !cook_torrance) site_options.sites = SiteFit::Off;
  BinnedSession s = bin_session(session, site_options);
  std::optional<BinnedSession> demosaiced;
  auto demosaiced_table = [&]() -> BinnedTable& {
    if (!s.sites) return s.binned;
    if (!demosaiced) {
      SessionBinOptions o = site_options;
      o.sites = SiteFit::Off;
      demosaiced = bin_session(session, o);
    }
    return demosaiced->binned;
  };
  if (any_other_model || r.merl) demosaiced_table();
  result.bin_s = seconds_since(t0);

  if (r.axf) {
    t0 = std::chrono::steady_clock::now();
    SharedFitOptions shared;
    shared.lobes = r.lobes.value_or(3);
    shared.seed = r.seed;
    shared.threads = r.threads;
    for (FitModel m : models) {
      FitRequest req = FitRequest::with(m, r.name.empty() ? paint_name_from(session.manifest().sample) : r.name, shared);
      req.check();
      spdlog::info("fitting {}", to_string(m));
      FitOutcome out;
      if (s.sites && m == FitModel::CookTorrance) {
        out = fit_sites(*s.sites, req, s.input);
      } else {
        const BinnedTable& binned = demosaiced_table();
        out = fit_table(binned.table, binned.noise_variance.empty() ? nullptr : &binned.noise_variance, req,
                        demosaiced ? demosaiced->input : s.input);
      }
      if (!out.converged) {
        // Exported all the same (the AxF-like file and --fit-out record it); the command exits 1.
        result.converged = false;
        result.not_converged.push_back(fmt::format("the {} fit did not converge: {}", to_string(m), out.termination));
      }
      result.fits.push_back(std::move(out.fit));
    }
    result.fit_s = seconds_since(t0);
    t0 = std::chrono::steady_clock::now();
    AxfPaint paint = paint_of_fits(result.fits);
    paint.provenance = session_provenance(session);
    if (!r.name.empty()) paint.name = r.name;
    if (r.session_flakes) {
      // Against the first fit: the smooth model is the flakes' average.
      const auto t_flakes = std::chrono::steady_clock::now();
      const auto model = brdf::make_brdf(axf_from_fit_json(result.fits.front(), "the fit").paint_spec());
      FlakeOptions fo = r.flake_options;
      fo.threads = r.threads;
      const FlakeStats stats = session_flakes(session, *model, fo, r.bin.extraction, r.bin.calib_dir);
      result.lines.push_back(attach_flakes(paint, stats, r.flake_texture));
      result.flakes_s = seconds_since(t_flakes);
    } else if (r.flakes) {
      result.lines.push_back(attach_flakes(paint, flakes_from_json(read_json_file(*r.flakes), r.flakes->string()),
                                           r.flake_texture));
    }
    if (r.cosine_basis) result.lines.push_back(attach_cosine_lobes(paint, *r.cosine_basis));
    write_axf_file(*r.axf, paint);  // checks the paint first: nothing written when it is wrong
    result.paint = read_axf_file(*r.axf);  // as written (export date, software version)
    result.lines.push_back(axf_line(*r.axf, *result.paint));
    if (r.fit_out) {
      write_json_file(*r.fit_out, result.fits.front());
      result.lines.push_back(fmt::format("wrote {}", r.fit_out->string()));
    }
    result.write_s += seconds_since(t0);
  }
  if (r.merl) {
    t0 = std::chrono::steady_clock::now();
    result.lines.push_back(write_filled_merl(std::move(demosaiced_table().table), *r.merl));
    result.write_s += seconds_since(t0);
  }
}

// Export of one or two paint files (export_paint's other branch).
void export_paint_files(const ExportRequest& r, ExportResult& result) {
  if (r.model || r.lobes || r.fit_out)
    throw UsageError("--model, --lobes and --fit-out apply to a session; the inputs here are paint files");
  std::optional<AxfPaint> paint;
  std::optional<Json> fit_input;  // "input" of a fit.json: what was fitted
  for (const auto& in : r.inputs) {
    if (acq::is_session_dir(in)) throw UsageError(in.string() + ": a session is exported alone (one INPUT)");
    AxfPaint p = load_any_paint(in);
    if (lower_extension(in) == ".json") {
      const Json j = read_json_file(in);
      if (j.contains("input") && j["input"].is_object() && !fit_input) fit_input = j["input"];
    }
    paint = paint ? merge_axf(std::move(*paint), p) : std::move(p);
  }
  // A fit of a session: the provenance is the session's (when it is still there); of several,
  // the first one's, the source naming them all.
  const std::vector<fs::path> fitted = fit_input ? fitted_sessions(*fit_input) : std::vector<fs::path>{};
  if (!fitted.empty()) {
    const fs::path& sp = fitted.front();
    if (acq::is_session_dir(sp)) {
      const std::string source = paint->provenance.source;
      paint->provenance = session_provenance(acq::SessionDir::open(sp));
      std::vector<std::string> names;
      for (const fs::path& p : fitted) names.push_back(p.string());
      paint->provenance.source = fitted.size() == 1 ? source + " (a fit of session " + sp.string() + ")"
                                                    : fmt::format("{} (a fit of sessions {} together)", source,
                                                                  fmt::join(names, ", "));
    } else {
      spdlog::warn("the fitted session {} is not there: provenance without the measurement", sp.string());
    }
  }
  std::optional<brdf::MerlTable> merl_table;
  if (r.merl) {
    const std::string kind = fit_input ? fit_input->value("kind", "") : "";
    const fs::path path = fit_input ? fs::path(fit_input->value("path", "")) : fs::path();
    auto t0 = std::chrono::steady_clock::now();
    if (kind == "merl" && fs::exists(path)) {
      merl_table = brdf::read_merl(path);
    } else if (!fitted.empty() && std::all_of(fitted.begin(), fitted.end(), acq::is_session_dir)) {
      // Binned as the fit's table was: the margin, variance and estimator its input records.
      SessionBinOptions o = bin_options_of_input(*fit_input, with_threads(r.bin, r.threads), "fit.json");
      o.sites = SiteFit::Off;  // a MERL table is the demosaiced image's, whatever the fit was made at
      std::vector<acq::SessionDir> sessions;
      for (const fs::path& p : fitted) sessions.push_back(acq::SessionDir::open(p));
      merl_table = bin_sessions(sessions, o).binned.table;
      result.bin_s = seconds_since(t0);
    } else {
      throw UsageError(
          "--merl exports measured data: give the session folder, or a fit.json whose measured input (a session "
          "or a MERL table) still exists");
    }
  }
  if (r.session_flakes)
    throw UsageError("--flakes auto measures the flakes of a session; for paint files give a flakes.json");
  if (r.flakes)
    result.lines.push_back(attach_flakes(*paint, flakes_from_json(read_json_file(*r.flakes), r.flakes->string()),
                                         r.flake_texture));
  const auto t0 = std::chrono::steady_clock::now();
  if (r.axf) {
    if (!r.name.empty()) paint->name = r.name;
    if (r.cosine_basis) result.lines.push_back(attach_cosine_lobes(*paint, *r.cosine_basis));
    write_axf_file(*r.axf, *paint);
    result.paint = read_axf_file(*r.axf);
    result.lines.push_back(axf_line(*r.axf, *result.paint));
  }
  if (merl_table) result.lines.push_back(write_filled_merl(std::move(*merl_table), *r.merl));
  result.write_s = seconds_since(t0);
}

}  // namespace

ExportResult export_paint(const ExportRequest& r) {
  if (!r.axf && !r.merl) throw UsageError("nothing to write: give --axf FILE and/or --merl FILE");
  if (r.inputs.empty() || r.inputs.size() > 2) throw UsageError("give one session folder, or one or two paint files");
  if (r.lobes && (*r.lobes < 1 || *r.lobes > 3)) throw UsageError(fmt::format("--lobes {}: must be 1..3", *r.lobes));
  if ((r.flakes || r.session_flakes) && !r.axf)
    throw UsageError("--flakes goes into the AxF-like file: give --axf FILE");
  if (r.flakes && r.session_flakes) throw UsageError("--flakes: a flakes.json or auto, not both");
  if (r.cosine_basis && !r.axf) throw UsageError("--cosine-lobes goes into the AxF-like file: give --axf FILE");
  if (r.cosine_basis) read_cosine_basis(*r.cosine_basis);  // a bad basis stops the export before any work
  ExportResult result;
  if (acq::is_session_dir(r.inputs[0]))
    export_session(r, result);
  else
    export_paint_files(r, result);
  return result;
}

AxfPaint export_axf(const std::vector<Json>& fits, const AxfProvenance& provenance, const fs::path& out,
                         const std::string& name) {
  AxfPaint paint = paint_of_fits(fits);
  paint.provenance = provenance;
  if (!name.empty()) paint.name = name;
  write_axf_file(out, paint);
  return read_axf_file(out);
}

LibraryEntry library_add(const fs::path& dir, const fs::path& paint_file, bool replace, const std::string& name) {
  AxfPaint paint = load_any_paint(paint_file);
  if (!name.empty()) paint.name = name;
  PaintLibrary lib = PaintLibrary::open(dir, true);
  return lib.add(paint, replace);
}

Preview render_preview_png(const fs::path& paint_file, const fs::path& out_png, const PreviewOptions& options,
                                const std::optional<fs::path>& hdr_out) {
  const AxfPaint paint = load_any_paint(paint_file);
  const auto model = brdf::make_brdf(paint.paint_spec());
  std::optional<FlakeSparkle> sparkle;
  if (options.sparkle && paint.flake_stats && !paint.flake_stats->empty()) sparkle.emplace(*paint.flake_stats);
  Preview p = render_preview(*model, options, nullptr, sparkle ? &*sparkle : nullptr);
  write_png8(out_png, p.png);
  if (hdr_out) write_exr_rgb(*hdr_out, p.linear, "preview of " + paint.name + ", linear radiance");
  return p;
}

double preview_log_rms(const ImageF& a, const ImageF& b, const std::vector<std::uint8_t>& mask) {
  const int W = a.width(), H = a.height();
  double peak = 0;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x)
      if (mask[static_cast<std::size_t>(y) * W + x])
        peak = std::max(peak, (b.at(x, y, 0) + b.at(x, y, 1) + b.at(x, y, 2)) / 3.0);
  double sum = 0;
  std::size_t n = 0;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      if (!mask[static_cast<std::size_t>(y) * W + x]) continue;
      const double va = (a.at(x, y, 0) + a.at(x, y, 1) + a.at(x, y, 2)) / 3.0;
      const double vb = (b.at(x, y, 0) + b.at(x, y, 1) + b.at(x, y, 2)) / 3.0;
      if (!(va > 1e-6 * peak) || !(vb > 1e-6 * peak)) continue;
      sum += std::log(va / vb) * std::log(va / vb);
      ++n;
    }
  return n ? std::sqrt(sum / static_cast<double>(n)) : 0.0;
}

CosineRenderResult render_cosine_png(const fs::path& paint_file, const fs::path& out_png, const PreviewOptions& options,
                                     const fs::path& cache_dir, bool against_full, const std::optional<fs::path>& hdr_out) {
  const AxfPaint paint = load_any_paint(paint_file);
  if (!paint.cosine_lobes)
    throw DataError(paint_file.string() + ": the paint has no cosine-lobe weights: export it with --cosine-lobes "
                                          "--basis BASIS.json (or design one with paintlab design)");
  CosineRenderResult r;
  std::optional<PrefilteredEnvironment> maps;
  auto t0 = std::chrono::steady_clock::now();
  if (options.environment)
    maps = PrefilteredEnvironment::cached(*options.environment, options.environment_intensity,
                                          paint.cosine_lobes->exponents, cache_dir, &r.maps_from_cache);
  r.maps_s = seconds_since(t0);
  t0 = std::chrono::steady_clock::now();
  r.preview = render_preview_cosine(*paint.cosine_lobes, options, maps ? &*maps : nullptr);
  r.render_ms = 1000 * seconds_since(t0);
  if (against_full) {
    const auto model = brdf::make_brdf(paint.paint_spec());
    t0 = std::chrono::steady_clock::now();
    const Preview full = render_preview(*model, options);
    r.full_ms = 1000 * seconds_since(t0);
    r.log_rms = preview_log_rms(r.preview.linear, full.linear, r.preview.mask);
  }
  write_png8(out_png, r.preview.png);
  if (hdr_out)
    write_exr_rgb(*hdr_out, r.preview.linear, "cosine-lobe preview of " + paint.name + ", linear radiance");
  return r;
}

ComparisonResult render_comparison_png(const fs::path& paint_file, const fs::path& session_dir, double angle_deg,
                                       const fs::path& out_png, const std::optional<fs::path>& calib_dir,
                                       const CompareOptions& options, const std::optional<fs::path>& hdr_out) {
  const AxfPaint paint = load_any_paint(paint_file);
  const auto model = brdf::make_brdf(paint.paint_spec());
  const acq::SessionDir session = acq::SessionDir::open(session_dir);
  const auto entries = session.finished_entries();
  if (entries.empty()) throw DataError(session_dir.string() + ": the session has no finished light position");
  // The finished position nearest the requested angle.
  const acq::JournalEntry* best = &entries.front();
  for (const auto& e : entries)
    if (std::abs(angle_diff_deg(e.angle_deg, angle_deg)) < std::abs(angle_diff_deg(best->angle_deg, angle_deg)))
      best = &e;
  const calib::RigCalibration cal = acq::session_calibration(session, calib_dir);
  const ExrImage measured = read_exr(session.dir() / best->file);
  ComparisonResult result;
  std::optional<FlakeSparkle> sparkle;
  if (options.sparkle && paint.flake_stats && !paint.flake_stats->empty()) sparkle.emplace(*paint.flake_stats);
  result.comparison = render_comparison(*model, cal, measured, best->angle_deg, options, sparkle ? &*sparkle : nullptr);
  if (sparkle) {
    // The sparkle of both images, measured alike (the glints against the smooth model).
    ExrImage rendered;
    rendered.width = measured.width;
    rendered.height = measured.height;
    const ImageF full = render_rig(*model, cal, best->angle_deg, &*sparkle);
    const char* names[3] = {"R", "G", "B"};
    for (int c = 0; c < 3; ++c) {
      ImageF plane(full.width(), full.height());
      for (int y = 0; y < full.height(); ++y)
        for (int x = 0; x < full.width(); ++x) plane.at(x, y) = full.at(x, y, c);
      rendered.add(names[c], std::move(plane));
    }
    FlakeOptions fo = paint.flake_stats->options;
    fo.threads = 0;
    result.measured_sparkle = extract_flakes({{&measured, best->angle_deg}}, cal, *model, fo);
    result.rendered_sparkle = extract_flakes({{&rendered, best->angle_deg}}, cal, *model, fo);
  }
  result.angle_deg = best->angle_deg;
  result.image = best->file;
  const Comparison& c = result.comparison;
  write_png8(out_png, c.png);
  if (hdr_out) {
    ImageF both(2 * c.measured.width(), c.measured.height(), 3);
    for (int y = 0; y < c.measured.height(); ++y)
      for (int x = 0; x < c.measured.width(); ++x)
        for (int ch = 0; ch < 3; ++ch) {
          both.at(x, y, ch) = c.measured.at(x, y, ch);
          both.at(c.measured.width() + x, y, ch) = c.model.at(x, y, ch);
        }
    write_exr_rgb(*hdr_out, both, "measured | model, linear DN/s");
  }
  return result;
}

AxfPaint load_any_paint(const fs::path& file) {
  if (!fs::exists(file)) throw IoError(file.string(), "no such file");
  if (fs::is_directory(file)) throw UsageError(file.string() + ": a folder, expected a paint file (.axf.h5, fit.json or .toml)");
  const std::string ext = lower_extension(file);
  if (ext == ".h5" || ext == ".hdf5") {
    AxfPaint p = read_axf_file(file);
    if (p.fit_quality && !p.fit_quality->converged)
      spdlog::warn("{}: the fit of this paint did not converge (the file records it); read all the same", file.string());
    return p;
  }
  if (ext == ".json") {
    const Json j = read_json_file(file);
    AxfPaint p = axf_from_fit_json(j, file.string());
    p.provenance.source = fs::absolute(file).lexically_normal().string();
    if (p.fit_quality && !p.fit_quality->converged) {
      std::string why;
      if (j["summary"].is_object() && j["summary"].contains("termination") && j["summary"]["termination"].is_string())
        why = " (" + j["summary"]["termination"].get<std::string>() + ")";
      spdlog::warn("{}: the fit did not converge{}: \"converged\": false; read all the same, and an AxF-like file "
                   "written from it records it",
                   file.string(), why);
    }
    return p;
  }
  if (ext == ".toml") {
    AxfPaint p = axf_from_paint(brdf::load_paint_file(file));
    p.provenance.source = fs::absolute(file).lexically_normal().string();
    return p;
  }
  throw UsageError(file.string() + ": unknown kind of paint file (expected .axf.h5 / .h5, fit .json or paint .toml)");
}

std::string write_filled_merl(brdf::MerlTable table, const fs::path& out) {
  const HoleFillReport r = fill_holes(table);
  brdf::write_merl(out, table);
  return fmt::format(
      "wrote {} (MERL .binary: {} measured bins, {} filled from the phi_d mirror, {} by push-pull, {} below the "
      "horizon left empty)",
      out.string(), r.measured_bins, r.filled_mirror, r.filled_pyramid, r.invalid_empty);
}

std::vector<std::filesystem::path> fitted_inputs_of(const std::filesystem::path& file) {
  if (file.extension() != ".json" || !std::filesystem::is_regular_file(file)) return {};
  try {
    const Json j = read_json_file(file);
    if (!j.is_object() || !j.contains("input") || !j["input"].is_object()) return {};
    std::vector<std::filesystem::path> out = fitted_sessions(j["input"]);
    if (out.empty() && j["input"].contains("path") && j["input"]["path"].is_string())
      out.emplace_back(j["input"]["path"].get<std::string>());
    return out;
  } catch (const Error&) {
    // export itself names what is wrong with the file
  }
  return {};
}

}  // namespace paintlab::fit
