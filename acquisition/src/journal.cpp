#include "paintlab/acquisition/journal.h"

#include <fmt/format.h>

#include <cerrno>
#include <unistd.h>

#include "paintlab/core/atomic_file.h"
#include "paintlab/core/error.h"

namespace fs = std::filesystem;

namespace paintlab::acq {

Json JournalEntry::to_json() const {
  Json j{{"index", index},
              {"angle_deg", angle_deg},
              {"angle_read_deg", angle_read_deg},
              {"file", file},
              {"sha256", sha256},
              {"exposures_s", exposures_s},
              {"frame_ids", frame_ids},
              {"timestamps_ns", timestamps_ns},
              {"raw_files", raw_files},
              {"led_was_on", led_was_on},
              {"led_off_after", led_off_after},
              {"clock_start_s", clock_start_s},
              {"clock_end_s", clock_end_s},
              {"utc", utc}};
  if (!filters.empty()) {
    j["filters"] = filters;
    j["filter_slots"] = filter_slots;
  }
  return j;
}

JournalEntry JournalEntry::from_json(const Json& j, const std::string& where) {
  JournalEntry e = read_fields(j, where);
  e.filters = json_get_or<std::vector<std::string>>(j, "filters", {}, where);
  e.filter_slots = json_get_or<std::vector<int>>(j, "filter_slots", {}, where);
  if (!e.filters.empty() && (e.filters.size() != e.exposures_s.size() || e.filter_slots.size() != e.filters.size()))
    throw DataError(fmt::format("{}: {} filters and {} filter slots for {} frames", where, e.filters.size(),
                                e.filter_slots.size(), e.exposures_s.size()));
  return e;
}

JournalEntry JournalEntry::read_fields(const Json& j, const std::string& where) {
  JournalEntry e;
  e.index = json_get<int>(j, "index", where);
  e.angle_deg = json_get<double>(j, "angle_deg", where);
  e.angle_read_deg = json_get_or<double>(j, "angle_read_deg", e.angle_deg, where);
  e.file = json_get<std::string>(j, "file", where);
  e.sha256 = json_get<std::string>(j, "sha256", where);
  e.exposures_s = json_get_or<std::vector<double>>(j, "exposures_s", {}, where);
  e.frame_ids = json_get_or<std::vector<std::uint64_t>>(j, "frame_ids", {}, where);
  e.timestamps_ns = json_get_or<std::vector<std::uint64_t>>(j, "timestamps_ns", {}, where);
  e.raw_files = json_get_or<std::vector<std::string>>(j, "raw_files", {}, where);
  e.led_was_on = json_get_or<bool>(j, "led_was_on", false, where);
  e.led_off_after = json_get_or<bool>(j, "led_off_after", false, where);
  e.clock_start_s = json_get_or<double>(j, "clock_start_s", 0.0, where);
  e.clock_end_s = json_get_or<double>(j, "clock_end_s", 0.0, where);
  e.utc = json_get_or<std::string>(j, "utc", "", where);
  if (e.index < 0) throw DataError(where + ": negative index");
  if (e.file.empty() || e.file.find("..") != std::string::npos || fs::path(e.file).is_absolute())
    throw DataError(where + ": bad file name '" + e.file + "'");
  return e;
}

std::vector<JournalEntry> Journal::read(bool* torn) const {
  if (torn) *torn = false;
  if (!fs::exists(path_)) return {};
  std::vector<Json> lines = read_jsonl_file(path_, torn);
  std::vector<JournalEntry> out;
  out.reserve(lines.size());
  for (std::size_t i = 0; i < lines.size(); ++i)
    out.push_back(JournalEntry::from_json(lines[i], path_.string() + ":" + std::to_string(i + 1)));
  return out;
}

bool Journal::repair() const {
  if (!fs::exists(path_)) return false;
  std::string text = read_file(path_);
  if (text.empty() || text.back() == '\n') return false;
  std::size_t keep = text.rfind('\n');
  keep = keep == std::string::npos ? 0 : keep + 1;
  fs::path torn_path = path_;
  torn_path += ".torn";
  write_file_atomic(torn_path, text.substr(keep));
  if (::truncate(path_.c_str(), static_cast<off_t>(keep)) != 0) throw IoError(path_.string(), "cannot truncate", errno, IoOp::Write);
  fsync_path(path_);
  return true;
}

void Journal::append(const JournalEntry& entry) const { append_jsonl_line(path_, entry.to_json()); }

}  // namespace paintlab::acq
