#pragma once
// The pieces `paintlab export`, `paintlab library`, `paintlab render` (and the demo) share:
// reading a paint from any of the files a technician has, and what a session contributes
// to an export (its frames, its calibration, its provenance).
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "paintlab/acquisition/session.h"
#include "paintlab/brdf/merl.h"
#include "paintlab/calibration/rig_calibration.h"
#include "paintlab/fitting/axf_file.h"
#include "paintlab/fitting/extraction.h"

namespace paintlab::app {

// A paint from an AxF-like file (.h5), a fit.json (.json) or a paint file (.toml), chosen
// by the extension. DataError/ConfigError/IoError name the file and the field.
fit::AxfPaint load_any_paint(const std::filesystem::path& file);

// Whether `path` is a session folder (holds session.json).
bool is_session_dir(const std::filesystem::path& path);

// The finished positions of a session as HDR frames (file and table angle), index order.
// DataError when none is finished.
std::vector<fit::HdrFrame> session_frames(const acq::SessionDir& session);

// The calibration of a session: `calib_dir` when given, else the calibration folder of the
// rig file the session names. Logs a warning for every calibration file whose checksum
// differs from the one the session recorded. IoError/DataError when it cannot be found.
calib::RigCalibration session_calibration(const acq::SessionDir& session,
                                          const std::optional<std::filesystem::path>& calib_dir);

// Provenance of a paint measured in `session`: sample, measurement date, rig, calibration
// checksums (as recorded by the session), session checksum (SHA-256 of session.json's bytes
// followed by journal.jsonl's), source = the session folder.
fit::AxfProvenance session_provenance(const acq::SessionDir& session);

// Fills the holes of a measured table (fit::fill_holes) and writes it as MERL .binary
// (atomic). Returns the line that says how many bins were measured and filled.
std::string write_filled_merl(brdf::MerlTable table, const std::filesystem::path& out);

// SHA-256 of session.json followed by journal.jsonl (docs/axf-like.md).
std::string session_sha256(const std::filesystem::path& session_dir);

}  // namespace paintlab::app
