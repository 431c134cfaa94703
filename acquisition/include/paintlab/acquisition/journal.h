#pragma once
// The session journal (journal.jsonl): one JSON object per finished light position,
// appended and fsynced only after that position's HDR file is durably in place. It is
// the record of what is finished: resume trusts a position only when its journal entry
// exists and the file still has the recorded SHA-256.
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "paintlab/core/json.h"

namespace paintlab::acq {

struct JournalEntry {
  int index = 0;                       // position index in the plan
  double angle_deg = 0.0;              // commanded table angle
  double angle_read_deg = 0.0;         // encoder angle read back after settling
  std::string file;                    // HDR file, relative to the session folder
  std::string sha256;                  // of that file
  std::vector<double> exposures_s;     // applied exposures, as read back from the camera
  std::vector<std::uint64_t> frame_ids;
  std::vector<std::uint64_t> timestamps_ns;
  std::vector<std::string> raw_files;  // kept raw frames (--keep-raw), relative paths
  // A filter-wheel camera: per frame the filter in front ("R", "G", "B") and its wheel slot;
  // empty otherwise (and in journals written before the wheel).
  std::vector<std::string> filters;
  std::vector<int> filter_slots;
  bool led_was_on = false;             // LED read back on during the bracket
  bool led_off_after = false;          // LED read back off after the bracket
  double clock_start_s = 0.0;          // rig clock at the start and end of the position
  double clock_end_s = 0.0;
  std::string utc;                     // wall-clock time the entry was written

  Json to_json() const;
  static JournalEntry from_json(const Json& j, const std::string& where);

 private:
  static JournalEntry read_fields(const Json& j, const std::string& where);
};

class Journal {
 public:
  explicit Journal(std::filesystem::path path) : path_(std::move(path)) {}
  const std::filesystem::path& path() const { return path_; }

  // All complete entries in file order. A torn last line (a crash during an append) is
  // ignored and reported through *torn.
  std::vector<JournalEntry> read(bool* torn = nullptr) const;
  // Cuts a torn last line off (it is kept in journal.jsonl.torn), so the next append
  // starts on a fresh line. Returns whether anything was cut.
  bool repair() const;
  // Appends one entry and fsyncs it.
  void append(const JournalEntry& entry) const;

 private:
  std::filesystem::path path_;
};

}  // namespace paintlab::acq
