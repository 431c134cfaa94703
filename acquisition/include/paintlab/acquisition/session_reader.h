#pragma once
// The read side of a session folder: what the commands that use a finished measurement
// (bin, fit, export, render) need of it besides SessionDir itself. Nothing here changes
// the folder.
#include <filesystem>
#include <optional>
#include <string>

#include "paintlab/acquisition/session.h"
#include "paintlab/calibration/rig_calibration.h"

namespace paintlab::acq {

// Whether `path` is a session folder (a folder holding session.json).
bool is_session_dir(const std::filesystem::path& path);

// Throws DataError naming the missing light positions (at most 8, then "..."), what
// inspection found, and the `paintlab measure --resume DIR` command, when the session is
// not complete.
void require_complete_session(const SessionDir& session);

// The calibration a session is used with: `calib_dir` when given, else the calibration
// folder of the rig file the session names. Logs a warning for every calibration file whose
// checksum differs from the one the session recorded. IoError when the rig file or the
// folder cannot be found (naming it, and --calib when the rig file is gone).
calib::RigCalibration session_calibration(const SessionDir& session,
                                          const std::optional<std::filesystem::path>& calib_dir);

// SHA-256 (hex) of session.json's bytes followed by journal.jsonl's (docs/axf-like.md): the
// identity of a measurement that fits and exports record.
std::string session_sha256(const std::filesystem::path& session_dir);

}  // namespace paintlab::acq
