#pragma once
// AxF-like paint files (HDF5, docs/axf-like.md): a versioned layout that mirrors X-Rite's
// AxF car-paint representation (clear-coat ior, diffuse, per-lobe coefficient / spread /
// F0, the colour table over (theta_hbar, theta_ibar), flake statistics) and also holds the
// Cook-Torrance fit with its standard deviations, the fit quality and the provenance.
// Every convention (where each 1/pi is, Beckmann normalisation, linear values, colour-table
// indexing and the domain it is filled over) is written into the file as attributes of
// /conventions, and the validator checks them word for word.
//
// A paint that is only a Cook-Torrance fit exports without /carpaint (the AxF car-paint
// form has achromatic lobes under one colour table, which an RGB Cook-Torrance fit does
// not reduce to exactly); /cook_torrance then is the paint. Likewise a cosine-lobe paint
// (`paintlab design`) is /cosine_lobes alone; beside a car-paint or Cook-Torrance form the
// same group holds that paint's cosine-lobe weights, a fast approximation.
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "paintlab/brdf/paint.h"
#include "paintlab/core/colour.h"
#include "paintlab/core/json.h"
#include "paintlab/fitting/ct_fit.h"
#include "paintlab/fitting/flakes.h"

namespace paintlab::fit {

inline constexpr const char* kAxfFormat = "paintlab-axf-like";
// The version written. Version 2 (issue 13) adds checksums: HDF5's checksummed metadata,
// Fletcher-32 on every array, fixed-length strings and the SHA-256 of the content
// (attribute content_sha256). Version 3 (issue 14) states the colour space of the values in
// /conventions "values": "linear sRGB (D65)" (a colour measurement, a paint file) or "linear
// camera RGB" (a monochrome or uncalibrated camera; all that versions 1 and 2 could say).
// Files of versions 1 and 2 are still read (as linear camera RGB). Version 4 (issue 16) adds
// the flakes' colour to /flakes (tint_sd, interference, interference_chroma,
// interference_shift_deg: all four or none), /flake_stats (the measured flake statistics, the
// flakes.json text) and /flake_btf (their CPA2-style flake BTF). Version 5 adds /cosine_lobes
// (the cosine-lobe weights of brdf/cosine_lobes.h: exponents, kd, kg, kdd), model
// "cosine-lobes" (a paint that is only those weights) and the convention "cosine_lobes" that
// states their formula (required from version 5 on; files of versions 1 to 4 read as before).
inline constexpr int kAxfFormatVersion = 5;
// The file holding a whole library (`paintlab library export --h5`): /paints/<name> groups,
// each with the layout of one AxF-like file.
inline constexpr const char* kAxfLibraryFormat = "paintlab-axf-library";

// The Cook-Torrance form of the paint (a fit, or a Cook-Torrance paint file).
struct AxfCookTorrance {
  brdf::CookTorranceParams params;
  std::optional<CookTorranceStddev> stddev;  // per-parameter standard deviations of a fit
  bool operator==(const AxfCookTorrance& o) const;
};

// Standard deviations of an AxF car-paint fit (the shape of AxfCarPaintParams' scalars and
// lobes; the colour table has none).
struct AxfCarPaintStddev {
  double ior = 0;
  double diffuse = 0;
  std::vector<brdf::AxfLobe> lobes;  // coefficient, spread, f0 hold standard deviations
  bool operator==(const AxfCarPaintStddev&) const = default;
};

// How well the fit matches the measurement (fit.json "residual").
struct AxfFitQuality {
  double log_rms = 0;            // RMS of the log residuals over the bins used, >= 0
  std::int64_t bins_used = 0;    // >= 0
  bool converged = true;         // the solver reported convergence
  Json residual = Json::object();  // the whole "residual" object as the fit reported it
  bool operator==(const AxfFitQuality& o) const;
};

// Where the paint comes from. Empty strings mean "unknown" (a paint written by hand).
struct AxfProvenance {
  std::string sample_name;       // the measured sample
  std::string measured_utc;      // when it was measured (ISO 8601 UTC)
  std::string exported_utc;      // when this file was written (filled by the writer if empty)
  std::string rig_name;
  // Calibration files used for the measurement: (file name, SHA-256 hex).
  std::vector<std::pair<std::string, std::string>> calibration_sha256;
  std::string session_sha256;    // SHA-256 of session.json followed by journal.jsonl
  std::string software_version;  // of the software that wrote the file (filled if empty)
  std::string source;            // what was exported: session folder, fit.json, paint file
  bool operator==(const AxfProvenance&) const = default;
};

struct AxfPaint {
  std::string name;    // [a-z0-9._-]+
  // What the RGB values are: colour::kLinearSrgb or colour::kCameraRgb (/conventions "values").
  std::string colour_space = colour::kCameraRgb;
  std::string model;   // the paint's model: "axf-carpaint", "cook-torrance" or "cosine-lobes"
  std::optional<brdf::AxfCarPaintParams> carpaint;   // required when model == "axf-carpaint"
  std::optional<AxfCarPaintStddev> carpaint_stddev;  // only with carpaint
  std::optional<AxfCookTorrance> cook_torrance;      // required when model == "cook-torrance"
  // The paint's cosine-lobe weights (version 5): the paint itself when model == "cosine-lobes"
  // (`paintlab design`), else a fast approximation of the carpaint / cook-torrance form
  // (`paintlab export --cosine-lobes`).
  std::optional<brdf::CosineLobeParams> cosine_lobes;
  std::optional<brdf::FlakeSpec> flakes;             // the simulator's flake model (a paint file's)
  std::optional<FlakeStats> flake_stats;              // measured flakes (version 4; docs/sparkle.md)
  std::optional<FlakeBtf> flake_btf;                  // their CPA2-style flake BTF (version 4)
  std::optional<AxfFitQuality> fit_quality;
  AxfProvenance provenance;

  // The paint itself (model chooses /carpaint, /cook_torrance or /cosine_lobes), ready for
  // make_brdf().
  brdf::PaintSpec paint_spec() const;
  bool operator==(const AxfPaint&) const = default;
};

// The AxF-like form of a paint file's paint (linear sRGB: the convention of paint files).
// Cook-torrance, axf-carpaint and cosine-lobes paints only;
// DataError for the others ("layered-pearlescent paints have no AxF-like form: fit it").
AxfPaint axf_from_paint(const brdf::PaintSpec& spec);
// The AxF-like form of a fit.json object (DESIGN.md "fit" plus "stddev", "summary") of
// either model; its colour space is input.colour_space (a session's; camera RGB when absent).
// DataError naming `where` and the key.
AxfPaint axf_from_fit_json(const Json& fit, const std::string& where);
// Adds the paint form of `other` that `base` lacks (a Cook-Torrance fit beside an AxF
// car-paint fit of the same measurement, or the other way round; cosine-lobe weights beside
// either). DataError when both hold the same form.
AxfPaint merge_axf(AxfPaint base, const AxfPaint& other);

// Writes the file atomically (temp file + rename: never a partial file). Checks the paint
// first (DataError naming the field, nothing written). Fills exported_utc and
// software_version when empty. The file is built in memory and written as bytes: a full
// disk is an IoError that leaves the old file (or none) and no HDF5 object open.
void write_axf_file(const std::filesystem::path& path, const AxfPaint& paint);
// Reads and validates. Throws IoError (cannot open) or DataError naming the file and the
// first wrong field ("FILE: /carpaint/ct_spreads: value 1.3 at index 1 out of range (0, 1)").
// A damaged file is a DataError whose message says "damaged" (a content checksum that does
// not match, an HDF5 checksum that fails, a size no paint has); never a crash.
AxfPaint read_axf_file(const std::filesystem::path& path);

// Every problem found, each naming the HDF5 path of the field.
struct AxfValidation {
  std::string format;                 // kAxfFormat or kAxfLibraryFormat (when readable)
  int format_version = 0;             // as the file states it (0 when unreadable)
  std::vector<std::string> paints;    // names of the paints found
  std::vector<std::string> problems;  // empty: valid
  bool ok() const { return problems.empty(); }
};
// Checks every field, shape, range and convention of an AxF-like file or a library file.
// Never throws for bad content; a file that is not HDF5 (or truncated) is one problem.
AxfValidation validate_axf_file(const std::filesystem::path& path);

// A library file: every paint under /paints/<name> (atomic write).
void write_axf_library_file(const std::filesystem::path& path, const std::vector<AxfPaint>& paints);
std::vector<AxfPaint> read_axf_library_file(const std::filesystem::path& path);

// Checks an AxfPaint built in code (DataError naming the field as the file would).
void check_axf_paint(const AxfPaint& paint);

// Lines a technician reads: model, parameters (with standard deviations), fit quality,
// provenance.
std::string describe_axf(const AxfPaint& paint);

// The convention attributes of /conventions (name, text), exactly as written and checked;
// "values" as versions 1 and 2 state it (camera RGB), axf_values_convention() for version 3.
// Each is required from axf_convention_since(name) on ("cosine_lobes": 5; the others: 1).
const std::vector<std::pair<std::string, std::string>>& axf_conventions();
int axf_convention_since(const std::string& name);
std::string axf_values_convention(const std::string& colour_space);

}  // namespace paintlab::fit
