#pragma once
// Exporting measured and fitted paints (docs/axf-like.md "Exporting"), the library, and the
// preview and comparison images: what `paintlab export`, `paintlab library add` and
// `paintlab render` (and `paintlab demo`) do, as plain functions; the commands only parse
// their options and print the lines returned.
// Errors: UsageError (exit 2: contradictory request), DataError/IoError/ConfigError naming
// the file and field (exit 2). Nothing is written when one is thrown before the write
// (every file is written atomically). A fit that does not converge is no exception: an
// export of a session writes its files all the same, the AxF-like file and --fit-out
// record "converged" false, and ExportResult::converged tells the command to exit 1; a
// paint file whose fit did not converge is read all the same with a warning (exit 0).
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "paintlab/brdf/merl.h"
#include "paintlab/core/json.h"
#include "paintlab/fitting/axf_file.h"
#include "paintlab/fitting/paint_library.h"
#include "paintlab/fitting/pipeline.h"
#include "paintlab/fitting/preview.h"
#include "paintlab/fitting/session_binning.h"

namespace paintlab::fit {

// The table or sessions a fit.json was fitted to (its "input" paths, which export --merl
// reads); empty for anything else, or a file that cannot be read (export names its problem).
std::vector<std::filesystem::path> fitted_inputs_of(const std::filesystem::path& file);

// `paintlab export INPUT... [--axf FILE] [--merl FILE] ...`.
struct ExportRequest {
  // One session folder (binned once here, fitted when `axf` is given), or one or two paint
  // files (fit.json of either model, .axf.h5, paint .toml; two are merged into one paint).
  std::vector<std::filesystem::path> inputs;
  std::optional<std::filesystem::path> axf;      // AxF-like file to write
  std::optional<std::filesystem::path> merl;     // measured + hole-filled MERL .binary
  std::optional<std::filesystem::path> fit_out;  // session only: also the fit.json (one model)
  // Extraction and binning of a session (its calibration folder among them). For a fit.json
  // of a session with `merl`, the margin, variance and estimator its input records win.
  SessionBinOptions bin;
  // Session only (UsageError with paint files): "cook-torrance" (default), "axf-carpaint"
  // or "both", and the lobes (default 3).
  std::optional<std::string> model;
  std::optional<int> lobes;
  // The measured flakes to add as /flake_stats and /flake_btf (docs/sparkle.md): a
  // flakes.json (`--flakes FILE`), or for a session input, measured here against the first
  // fit (`--flakes auto`: session_flakes true). A paint without glints gets neither group.
  std::optional<std::filesystem::path> flakes;
  bool session_flakes = false;
  FlakeOptions flake_options;
  int flake_texture = 32;  // texels a side of each BTF slice
  // With `axf`: the paint's cosine-lobe weights for this basis (basis.json of `paintlab basis
  // fit`) added as /cosine_lobes (docs/design.md "Cosine-lobe basis").
  std::optional<std::filesystem::path> cosine_basis;
  std::string name;  // paint name (default: the session's sample name / the fit's name)
  std::uint64_t seed = 1;
  int threads = 0;  // 0 = all cores (fits and binning)
};

struct ExportResult {
  std::optional<AxfPaint> paint;   // what was written to `axf` (read back)
  std::vector<Json> fits;          // session input: the fit.json objects, one per model
  std::vector<std::string> lines;  // what was written, one line each, for people
  // Session input: every fit made here converged. When not, the files are written all the
  // same (recording it) and `not_converged` names each fit and its termination.
  bool converged = true;
  std::vector<std::string> not_converged;
  double bin_s = 0;                // wall time binning the session (0 for paint files)
  double fit_s = 0;                // wall time of the fits
  double write_s = 0;              // wall time writing the files (incl. hole filling)
  double flakes_s = 0;             // wall time measuring the flakes (session_flakes)
};
ExportResult export_paint(const ExportRequest& request);

// Writes an AxF-like file from fits made in memory: fit.json objects as fit_table returns
// them (FitOutcome::fit; two fits of one measurement, one per model, are merged), with the
// given provenance (session_provenance() for a measured paint). `name` overrides the fit's
// paint name when not empty. Returns the paint as written.
AxfPaint export_axf(const std::vector<Json>& fits, const AxfProvenance& provenance, const std::filesystem::path& out,
                    const std::string& name = "");

// `paintlab library add --dir DIR FILE [--name NAME] [--replace]`: adds a paint file
// (.axf.h5, fit.json or paint .toml) to the library in `dir`, creating the library when
// needed. A paint of the same name is refused (DataError) unless `replace`.
LibraryEntry library_add(const std::filesystem::path& dir, const std::filesystem::path& paint_file, bool replace,
                         const std::string& name = "");

// `paintlab render PAINT --out PNG --basis cosine [--env ENV.exr]`: the preview of the paint's
// cosine-lobe weights (/cosine_lobes, or a cosine-lobes paint) with the environment through the
// prefiltered maps (prefiltered_env.h; from `cache_dir`, built there once). With
// `against_full`, the paint's full model is rendered in the same scene too (the environment by
// Monte Carlo, render_preview) and compared. DataError for a paint without cosine-lobe weights.
struct CosineRenderResult {
  Preview preview;
  double render_ms = 0;          // the basis render (maps ready)
  double maps_s = 0;             // loading or building the prefiltered maps
  bool maps_from_cache = false;
  std::optional<double> log_rms;  // RMS of ln(basis / full) over the sphere (channel mean), against_full
  double full_ms = 0;            // the full model's render, against_full
};
CosineRenderResult render_cosine_png(const std::filesystem::path& paint_file, const std::filesystem::path& out_png,
                                     const PreviewOptions& options, const std::filesystem::path& cache_dir,
                                     bool against_full, const std::optional<std::filesystem::path>& hdr_out = std::nullopt);
// RMS of ln(a / b) of the channel means over the pixels of `mask` where both are above 1e-6 of
// b's largest value (the preview comparisons' measure).
double preview_log_rms(const ImageF& a, const ImageF& b, const std::vector<std::uint8_t>& mask);

// `paintlab render PAINT --out PNG [--hdr EXR]`: the preview sphere (render_preview) of a
// paint file, written as tone-mapped PNG (and linear EXR when `hdr_out` is given).
// Draws the paint's measured flakes when it has them and options.sparkle is set.
Preview render_preview_png(const std::filesystem::path& paint_file, const std::filesystem::path& out_png,
                           const PreviewOptions& options = {},
                           const std::optional<std::filesystem::path>& hdr_out = std::nullopt);

// `paintlab render PAINT --out PNG --compare SESSION --angle DEG`: the measured HDR image
// of the finished position nearest `angle_deg` | the paint rendered in the calibrated rig
// geometry | their difference (render_comparison), as PNG (and measured | model as linear
// EXR when `hdr_out` is given).
// With a paint that carries measured flakes (and options.sparkle), the model draws them and
// both images' sparkle is measured per slice (the glint test of flakes.h against the smooth
// model).
struct ComparisonResult {
  Comparison comparison;
  double angle_deg = 0;  // table angle of the position compared
  std::string image;     // its HDR file, relative to the session
  std::optional<FlakeStats> measured_sparkle, rendered_sparkle;
};
ComparisonResult render_comparison_png(const std::filesystem::path& paint_file,
                                       const std::filesystem::path& session_dir, double angle_deg,
                                       const std::filesystem::path& out_png,
                                       const std::optional<std::filesystem::path>& calib_dir = std::nullopt,
                                       const CompareOptions& options = {},
                                       const std::optional<std::filesystem::path>& hdr_out = std::nullopt);

// A paint from an AxF-like file (.h5), a fit.json (.json) or a paint file (.toml), chosen
// by the extension. DataError/ConfigError/IoError name the file and the field. A fit that
// did not converge ("converged": false) is read all the same, with a warning naming the
// file (and the solver's termination for a fit.json).
AxfPaint load_any_paint(const std::filesystem::path& file);

// Fills the holes of a measured table (fill_holes) and writes it as MERL .binary (atomic).
// Returns the line that says how many bins were measured and filled.
std::string write_filled_merl(brdf::MerlTable table, const std::filesystem::path& out);

}  // namespace paintlab::fit
