#pragma once
// A paint library (docs/library.md): a folder of AxF-like paint files with an index.json
// that lists them (name, file, checksum, model, date, fit residual). Every change rewrites
// the index atomically (temp + fsync + rename) after the paint file is complete and
// before an old file is deleted, so a crash at any point leaves the old or the new index,
// and every file the index names is whole. Changes take an exclusive lock (flock on
// DIR/.lock), so two technicians adding at once cannot lose an entry; a lock held longer
// than the lock timeout (a hung command) is an IoError, never a hang.
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "paintlab/core/colour.h"
#include "paintlab/core/json.h"
#include "paintlab/fitting/axf_file.h"
#include "paintlab/fitting/interpolate.h"

namespace paintlab::fit {

inline constexpr const char* kLibraryIndexFile = "index.json";
inline constexpr const char* kLibraryFormat = "paintlab-library";
// Version 2 stores each paint's CIELAB at the five-angle geometries (LibraryEntry::colour);
// version 3 the instrument-style sparkle of a paint with measured flakes (LibraryEntry::sparkle).
// Version-1 and -2 indexes still read (their entries have no colour / sparkle until the paint is
// added again; `library match` computes the colour from the file meanwhile).
inline constexpr int kLibraryFormatVersion = 3;

// The sparkle numbers a technician compares with an instrument (docs/sparkle.md "Instrument-
// style numbers"): at each illumination angle (15, 45, 75 deg, viewed along the normal) the
// sparkle area in percent and the sparkle intensity (mean glint contrast); nullopt where the
// session did not measure that geometry (area) or saw no glint there (intensity).
struct LibrarySparkle {
  struct At {
    double illumination_deg = 0.0;
    std::optional<double> area_percent;
    std::optional<double> intensity;
    bool operator==(const At&) const = default;
  };
  double area_percent = 0.0;   // glints among all compared pixel samples
  double lifetime_deg = 0.0;   // the glints' angular lifetime
  std::uint64_t glints = 0;
  std::vector<At> at;
  bool operator==(const LibrarySparkle&) const = default;
};

struct LibraryEntry {
  std::string name;
  std::string file;        // relative to the library folder ("silver.3.axf.h5")
  std::string sha256;      // of the file
  std::string model;       // "cook-torrance", "axf-carpaint" or "cosine-lobes"
  std::string date;        // when the paint was measured (else exported), ISO 8601 UTC
  std::string added_utc;
  std::string sample;      // provenance sample name ("" when unknown)
  std::optional<double> log_rms;         // fit residual, when the paint is a fit
  std::optional<std::int64_t> bins_used;
  // CIELAB (D65, 2 deg observer) at each geometry of multiangle.h's default set, by geometry
  // name in the set's order; empty for a paint in camera RGB (no colour calibration) or an
  // entry of a version-1 index.
  std::vector<std::pair<std::string, colour::Lab>> colour;
  // Of a paint file with measured flakes (/flake_stats); nullopt for a paint without them or
  // an entry of an older index. A paint measured without flakes has glints 0 and area 0.
  std::optional<LibrarySparkle> sparkle;

  Json to_json() const;
  static LibraryEntry from_json(const Json& j, const std::string& where);
  bool operator==(const LibraryEntry&) const = default;
};

// The library's summary of a paint file's measured flakes (nullopt: the file has none).
std::optional<LibrarySparkle> library_sparkle(const AxfPaint& paint);

class PaintLibrary {
 public:
  // Opens the library in `dir`. With create, a missing or empty folder becomes an empty
  // library (index written); otherwise DataError when dir holds no index.json.
  static PaintLibrary open(const std::filesystem::path& dir, bool create);

  const std::filesystem::path& dir() const { return dir_; }
  // The entries of the current index, sorted by name.
  std::vector<LibraryEntry> list() const;
  // DataError "library DIR: no paint 'NAME' (paints: a, b)".
  LibraryEntry find(const std::string& name) const;
  // Reads a paint's file after checking its checksum against the index.
  AxfPaint load(const std::string& name) const;

  // Adds a paint (its file is written first, then the index); all or nothing: if the index
  // cannot be written (a full disk), the new file is removed again, and files an earlier
  // add left behind are removed first. A paint of the same name is
  // refused (DataError naming it and --replace) unless `replace`; a replaced paint's old
  // file is deleted after the new index is in place. Returns the new entry.
  LibraryEntry add(const AxfPaint& paint, bool replace);
  // Removes a paint: the index first, then its file.
  void remove(const std::string& name);

  // The whole library as one HDF5 file (/paints/<name>, see axf_file.h).
  void export_h5(const std::filesystem::path& file) const;
  // A folder of AxF-like files <name>.axf.h5. Existing files are refused (IoError naming
  // them, nothing written) unless `overwrite`.
  std::vector<std::filesystem::path> export_folder(const std::filesystem::path& folder, bool overwrite) const;

  // The interpolatable material of two of its paints (interpolate.h), computed once: the flake
  // transports are kept in transports/FILE_A+FILE_B.json (the two paint files' names, and their
  // checksums inside) and read back while both files are the same; computed and stored otherwise
  // (atomically; a cache that cannot be written is only a warning). *from_cache tells which.
  // Removing or replacing a paint removes its cached transports.
  InterpolatablePaint interpolatable(const std::string& a, const std::string& b, bool* from_cache = nullptr) const;

  // Findings a technician should know: files named by the index that are missing or
  // changed, and paint files the index does not name (left by an interrupted add).
  std::vector<std::string> check() const;

  // Test hook: called with the name of each step of add/remove ("locked", "paint-written",
  // "index-written", "old-file-removed", "file-removed") so tests can crash between them.
  void set_step_hook(std::function<void(const std::string&)> hook) { hook_ = std::move(hook); }
  // How long add/remove wait for another process's lock before an IoError (default 60 s).
  void set_lock_timeout(double seconds) { lock_timeout_s_ = seconds; }

 private:
  explicit PaintLibrary(std::filesystem::path dir) : dir_(std::move(dir)) {}
  struct Index {
    std::int64_t next_id = 1;
    std::vector<LibraryEntry> paints;
  };
  Index read_index() const;
  void write_index(const Index& index) const;
  // The second half of add: the entry of the written file into the index, then the old
  // file of a replaced paint removed.
  LibraryEntry commit_added(Index& idx, std::vector<LibraryEntry>::iterator old, const std::string& file,
                            std::int64_t id);
  // Removes the paint files (NAME.ID.axf.h5) the index does not name: what an add killed
  // before its index was written, or a replace that could not delete the old file, left.
  // Called under the lock by every change; returns how many.
  int remove_leftovers(const Index& idx) const;
  void step(const std::string& name) const;

  std::filesystem::path dir_;
  std::function<void(const std::string&)> hook_;
  double lock_timeout_s_ = 60.0;
};

}  // namespace paintlab::fit
