#pragma once
// `paintlab report INPUT --out FILE.html`: everything paintlab knows about a rig or a
// measurement on one self-contained HTML page (docs/reports.md): calibration (residuals,
// intrinsics, response, dark and flat maps, sphere, LEDs, colour chart), the rig check,
// the measurement (journal timeline, exposures, completeness), the fit (parameters with
// standard deviations, residuals per region against the noise floor, measured against
// fitted along theta_h), colour and provenance. Images and plots are inline (data: URIs),
// the page loads nothing from anywhere, and prints.
#include <filesystem>
#include <string>
#include <vector>

namespace paintlab::report {

enum class InputKind { Calibration, Session, Fit, Demo };
const char* to_string(InputKind k);  // "calibration folder", "session", "fit", "demo folder"

// What a report is made of: which folders and files it reads.
struct ReportInput {
  InputKind kind = InputKind::Fit;
  std::filesystem::path path;         // as given, made absolute
  std::filesystem::path calibration;  // calibration folder, or empty
  std::filesystem::path session;      // session folder, or empty
  std::filesystem::path fit;          // fit.json, or empty
  std::filesystem::path summary;      // demo summary.json, or empty
  std::filesystem::path flakes;       // flakes.json (a demo's, or beside a fit.json), or empty
  // The rig file, for the nominal geometry the calibration is compared with: a demo's
  // rig.toml, the file a session names, or rig.toml beside a calibration folder whose
  // `calibration` is that folder; empty when none is found (ReportOptions::rig overrides).
  std::vector<std::filesystem::path> images;  // PNG pictures to show with the fit (preview, comparison)
  std::filesystem::path rig;
};

// Recognises INPUT: a folder with summary.json (a demo), with session.json (a session), with
// any of a calibration's files (camera.json, check.json, response.json, dark.json, flat.json,
// sphere.json, light.json, scale.json, colour.json), or a fit.json file. DataError naming
// INPUT and what was looked for when it is none of them (or does not exist).
ReportInput classify_input(const std::filesystem::path& input);

struct ReportOptions {
  std::string title;  // page title; default from the input
  int max_image_px = 720;  // pictures are scaled down to at most this width
  std::filesystem::path rig;  // the rig file (paintlab report --rig); empty: ReportInput::rig
};

// A section that lacks data says what is missing; one whose checks fail says which.
struct Report {
  std::string html;
  std::vector<std::string> sections;  // ids of the sections written, in page order
  std::vector<std::string> missing;   // what the input lacks ("calibration: light.json not found")
  std::vector<std::string> failing;   // failed checks, a fit that did not converge
};

// Builds the page. DataError (naming the file) for a damaged JSON or EXR file, ConfigError for
// a rig file that does not load; missing files only leave their part out, saying so on the page.
Report make_report(const ReportInput& input, const ReportOptions& options = {});

}  // namespace paintlab::report
