#pragma once
// A finished session as the fits see it (docs/fitting.md "Extraction", "Binning"): its HDR
// images, extracted with the session's calibration and binned into a MERL table, and what
// a fit.json and an AxF-like file record about it. `paintlab fit`, `bin` and `export` all
// bin a session through bin_session(), with the same options and the same "input" object.
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "paintlab/acquisition/session.h"
#include "paintlab/core/json.h"
#include "paintlab/fitting/axf_file.h"
#include "paintlab/fitting/binning.h"
#include "paintlab/fitting/extraction.h"

namespace paintlab::fit {

// Whether a session is binned at its colour-filter-array sites for a fit
// (ExtractionOptions::cfa_sites, docs/fitting.md "Fitting a Bayer camera at its sites").
enum class SiteFit {
  Off,   // the demosaiced colour image (a table for `paintlab bin`, the MERL export, CIELAB)
  On,    // at the sites; DataError when the session cannot be (site_fit_refusal says why)
  Auto,  // at the sites when the session can be: a Bayer camera, colours the calibration maps back
};
const char* to_string(SiteFit s);  // "off", "on", "auto"
// DataError naming `where` for other names.
SiteFit site_fit_from_string(std::string_view s, std::string_view where);

// How a session is extracted and binned.
struct SessionBinOptions {
  ExtractionOptions extraction;
  BinningOptions binning;
  SiteFit sites = SiteFit::Off;  // decides extraction.cfa_sites for the session
  // The calibration folder; default: the one of the rig file the session names.
  std::optional<std::filesystem::path> calib_dir;
  void check() const;  // DataError naming the first violated rule
};

struct BinnedSession {
  BinnedTable binned;                // empty with extraction.cfa_sites
  std::optional<SiteTables> sites;   // extraction.cfa_sites: one table per filter colour
  ExtractionStats stats;
  // fit.json's "input": {"kind": "session", "path", "sample", "positions", "session_sha256",
  // "extraction" (ExtractionStats), "margin_px", "blur_sigma_px" (the lens blur
  // corrected, 0: none), "valid_margin_px", "variance", "estimator", and with cfa_sites
  // "cfa_sites": true and "site_to_colour_space" (3x3 row-major)}. Several sessions binned
  // together: "kind": "sessions", "path" and "sample" the first's, "positions" and
  // "extraction" their sums, "blur_sigma_px" -1 when their calibrations' differ, and
  // "sessions": [{"path", "sample", "positions", "session_sha256", "blur_sigma_px",
  // "extraction"}] (no top-level "session_sha256").
  Json input;
};

// The finished positions of a session as HDR frames (file and table angle), index order.
// DataError when none is finished.
std::vector<HdrFrame> session_frames(const acq::SessionDir& session);

// Why `session` cannot be binned at its filter-array sites with `extraction` and `calibration`
// (not a Bayer camera, a root-polynomial colour calibration, the local variance model asked
// for), or nullopt when it can.
std::optional<std::string> site_fit_refusal(const acq::SessionDir& session, const calib::RigCalibration& calibration,
                                            const ExtractionOptions& extraction);

// Extracts and bins every HDR image of a complete session (acq::require_complete_session:
// DataError naming the missing positions and `paintlab measure --resume` otherwise).
BinnedSession bin_session(const acq::SessionDir& session, const SessionBinOptions& options);

// Several sessions of one paint (other spheres of it, or the sphere turned on its stand)
// binned into one table: each extracted with its own calibration (a calibration folder
// `calib_dir` overrides them all), every sample into the same bins, so a bin holds the mean
// of all the sessions' samples. For sparkling paints this is how a fit gets more
// independent flakes at grazing angles (docs/fitting.md "Sparkle"). At the filter-array sites
// only when every session can be (SiteFit::On: DataError naming the one that cannot).
// DataError for a session given twice (a path or checksum seen before), for sessions in
// different colour spaces, or whose sites map to the colour space differently; a warning
// when their samples' names differ.
BinnedSession bin_sessions(const std::vector<acq::SessionDir>& sessions, const SessionBinOptions& options);

// The session folders a fit.json's "input" was binned from ("session": its path;
// "sessions": each one's), empty for a table.
std::vector<std::filesystem::path> fitted_sessions(const Json& input);

// What a fit reads: a session folder (extracted and binned with `options`) or a MERL .binary
// table. For a table, the coverage map `paintlab bin` wrote beside it (coverage_map_path_for)
// marks the bins `--fill` filled, which are left out (filled bins are not measurements); a
// nearly full table without a map is warned about. DataError/IoError naming `path` when it
// is neither.
struct FitInput {
  brdf::MerlTable table;                 // empty when `sites` holds the data
  std::optional<SiteTables> sites;       // a session binned at its filter-array sites (cfa_sites)
  std::vector<float> noise_variance;     // 3 per bin (sessions); empty for tables
  Json input;                            // fit.json's "input"
  std::string sample;                    // the session's sample, or the table file's stem
  std::optional<ExtractionStats> stats;  // sessions: what extraction found
  std::vector<std::string> warnings;     // for people: bins left out, or a table that looks filled
  std::size_t measured_bins() const;     // of the table, or of the three site tables together
};
FitInput load_fit_input(const std::filesystem::path& path, const SessionBinOptions& options);
// Several inputs: sessions only, binned together (bin_sessions); DataError naming a table
// among them (a table's samples are gone: only sessions can be binned together).
FitInput load_fit_input(const std::vector<std::filesystem::path>& paths, const SessionBinOptions& options);

// A Cook-Torrance fit of `lobes` lobes made now of `in` (what `paintlab colour` and
// `paintlab flakes` do when given no fit): logged as such, with a warning when it does not
// converge; `what` names the data. The paint's AxF-like form (its name the sample's).
AxfPaint fit_cook_torrance_now(const FitInput& in, int lobes, const std::string& what);

// The options a fit.json's "input" records (margin_px; blur_sigma_px and valid_margin_px:
// 0 when absent, as fits made before them were binned; variance, estimator), on top of
// `base`: a table binned again from the same session is the one that was fitted. Fields
// the input does not name keep `base`'s value; a bad value is a DataError naming `where`.
SessionBinOptions bin_options_of_input(const Json& input, SessionBinOptions base, const std::string& where);

// Provenance of a paint measured in `session`: sample, measurement date, rig, calibration
// checksums (as recorded by the session), session checksum (acq::session_sha256), source =
// the session folder.
AxfProvenance session_provenance(const acq::SessionDir& session);

}  // namespace paintlab::fit
