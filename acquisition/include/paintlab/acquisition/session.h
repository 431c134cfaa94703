#pragma once
// A measurement session folder (DESIGN.md "Data flow and files"):
//   session.json   what was measured: sample, rig, plan, calibration checksums, devices
//   journal.jsonl  one line per finished light position (see journal.h)
//   hdr/pos_XXX.exr  merged HDR image of position XXX (plan index, zero-padded)
//   raw/pos_XXX/   raw frames when kept (--keep-raw)
// The folder is append-only while measuring: a finished position is never overwritten;
// a file that fails its checksum or has no journal entry is moved to hdr/rejected/.
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "paintlab/acquisition/journal.h"
#include "paintlab/core/json.h"

namespace paintlab::acq {

// Version 2 adds options.colour_space and options.demosaic (colour cameras); version 1
// sessions (monochrome) still read.
inline constexpr int kSessionFormatVersion = 2;

// How a session is measured (session.json "options"): what `paintlab measure --resume` keeps.
// Reading refuses a key it does not know and a value of the wrong type, naming both, so that a
// mistyped key cannot silently read as false.
struct SessionOptions {
  bool keep_raw = false;      // the raw frames are kept in raw/pos_XXX/
  bool adaptive = false;      // adaptive bracketing (exposures chosen per position)
  bool uncalibrated = false;  // measured without response/dark: the HDR values are raw DN/s
  std::string pixel_format;   // the camera's ("Mono16", ...); empty when not recorded
  // A colour camera's: what the R, G, B of hdr/*.exr are (colour::kLinearSrgb after the
  // colour calibration, colour::kCameraRgb when --uncalibrated) and how the mosaic was
  // demosaiced; empty for a monochrome camera (the images hold Y).
  std::string colour_space;
  std::string demosaic;
  Json sim_paint;             // simulated rigs: the paint the simulator showed (paint JSON); null otherwise

  Json to_json() const;
  static SessionOptions from_json(const Json& j, const std::string& where);
};

struct SessionManifest {
  int format_version = kSessionFormatVersion;
  std::string sample;
  std::string notes;
  std::string operator_name;
  std::string created_utc;
  std::string software_version;
  std::string rig_name;
  std::string rig_file;                  // absolute path of the rig.toml used
  std::string rig_sha256;
  std::vector<double> angles_deg;        // the plan: one entry per position index
  std::vector<double> exposures_s;       // requested bracket
  double settle_s = 0.0;
  double gain_db = 0.0;
  Json calibration = Json::object();     // calibration file name -> sha256
  Json devices = Json::object();         // role -> {"id":..., "serial":...}
  SessionOptions options;

  Json to_json() const;
  static SessionManifest from_json(const Json& j, const std::string& where);
};

// What a session folder holds right now, checked against the journal.
struct SessionState {
  std::vector<std::optional<JournalEntry>> finished;  // per position index: its valid entry
  std::vector<int> todo;                              // indices still to measure, ascending
  std::vector<std::string> problems;                  // human-readable findings
  std::vector<std::filesystem::path> rejected;        // files with bad or no journal entries
  bool torn_journal = false;

  int finished_count() const;
};

class SessionDir {
 public:
  // Creates a session in `dir` (created if absent; must be empty otherwise). When `dir`
  // already holds a session, the error says whose and how to resume it; nothing is touched.
  static SessionDir create(const std::filesystem::path& dir, SessionManifest manifest);
  // Opens an existing session (for resume, bin, fit, export). DataError when it is not one.
  static SessionDir open(const std::filesystem::path& dir);

  const std::filesystem::path& dir() const { return dir_; }
  const SessionManifest& manifest() const { return manifest_; }
  const Journal& journal() const { return journal_; }
  int position_count() const { return static_cast<int>(manifest_.angles_deg.size()); }

  // "hdr/pos_012.exr" for index 12 (relative) and its absolute path.
  static std::string hdr_name(int index);
  std::filesystem::path hdr_path(int index) const { return dir_ / hdr_name(index); }
  std::filesystem::path raw_dir(int index) const;

  // Reads the journal and verifies every finished position's file and checksum. Changes
  // nothing on disk.
  SessionState inspect() const;
  // Prepares a resume: cuts a torn journal line, removes stale temporaries, and moves
  // files that fail their checksum or have no journal entry to hdr/rejected/ (never
  // deleting them). Returns the state after that.
  SessionState prepare_resume() const;

  // The journal entries of all finished positions, in index order (for extraction).
  std::vector<JournalEntry> finished_entries() const;

 private:
  SessionDir(std::filesystem::path dir, SessionManifest manifest);
  std::filesystem::path dir_;
  SessionManifest manifest_;
  Journal journal_;
};

}  // namespace paintlab::acq
