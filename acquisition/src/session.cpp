#include "paintlab/acquisition/session.h"

#include <algorithm>
#include <fmt/format.h>
#include <map>

#include "paintlab/core/atomic_file.h"
#include "paintlab/core/colour.h"
#include "paintlab/core/error.h"
#include "paintlab/core/hash.h"

namespace fs = std::filesystem;

namespace paintlab::acq {

namespace {
constexpr const char* kManifestFile = "session.json";
constexpr const char* kJournalFile = "journal.jsonl";
}  // namespace

Json SessionOptions::to_json() const {
  Json j{{"keep_raw", keep_raw}, {"adaptive", adaptive}, {"uncalibrated", uncalibrated}};
  if (!pixel_format.empty()) j["pixel_format"] = pixel_format;
  if (!colour_space.empty()) j["colour_space"] = colour_space;
  if (!demosaic.empty()) j["demosaic"] = demosaic;
  if (!sim_paint.is_null()) j["sim_paint"] = sim_paint;
  return j;
}

SessionOptions SessionOptions::from_json(const Json& j, const std::string& where) {
  const std::string at = where + ": options";
  if (!j.is_object()) throw DataError(at + " is not an object");
  static constexpr const char* kKeys[] = {"keep_raw",    "adaptive",     "uncalibrated", "pixel_format",
                                          "colour_space", "demosaic", "sim_paint"};
  for (auto it = j.begin(); it != j.end(); ++it)
    if (std::find(std::begin(kKeys), std::end(kKeys), it.key()) == std::end(kKeys))
      throw DataError(fmt::format("{}: unknown key '{}' (known: keep_raw, adaptive, uncalibrated, pixel_format, "
                                  "colour_space, demosaic, sim_paint)",
                                  at, it.key()));
  SessionOptions o;
  o.keep_raw = json_get_or<bool>(j, "keep_raw", false, at);
  o.adaptive = json_get_or<bool>(j, "adaptive", false, at);
  o.uncalibrated = json_get_or<bool>(j, "uncalibrated", false, at);
  o.pixel_format = json_get_or<std::string>(j, "pixel_format", "", at);
  o.colour_space = json_get_or<std::string>(j, "colour_space", "", at);
  o.demosaic = json_get_or<std::string>(j, "demosaic", "", at);
  if (!o.colour_space.empty() && o.colour_space != colour::kLinearSrgb && o.colour_space != colour::kCameraRgb)
    throw DataError(fmt::format("{}: colour_space '{}' is none of '{}', '{}'", at, o.colour_space,
                                colour::kLinearSrgb, colour::kCameraRgb));
  if (j.contains("sim_paint")) {
    o.sim_paint = j.at("sim_paint");
    if (!o.sim_paint.is_object() && !o.sim_paint.is_null()) throw DataError(at + ": sim_paint is not an object");
  }
  return o;
}

Json SessionManifest::to_json() const {
  return Json{{"format_version", format_version},
              {"sample", sample},
              {"notes", notes},
              {"operator", operator_name},
              {"created_utc", created_utc},
              {"software_version", software_version},
              {"rig", {{"name", rig_name}, {"file", rig_file}, {"sha256", rig_sha256}}},
              {"plan", {{"angles_deg", angles_deg}, {"exposures_s", exposures_s}, {"settle_s", settle_s}, {"gain_db", gain_db}}},
              {"calibration", calibration},
              {"devices", devices},
              {"options", options.to_json()}};
}

SessionManifest SessionManifest::from_json(const Json& j, const std::string& where) {
  SessionManifest m;
  m.format_version = json_get<int>(j, "format_version", where);
  if (m.format_version < 1 || m.format_version > kSessionFormatVersion)
    throw DataError(where + ": session format version " + std::to_string(m.format_version) +
                    " is not supported (this paintlab reads versions 1 to " + std::to_string(kSessionFormatVersion) + ")");
  m.sample = json_get<std::string>(j, "sample", where);
  m.notes = json_get_or<std::string>(j, "notes", "", where);
  m.operator_name = json_get_or<std::string>(j, "operator", "", where);
  m.created_utc = json_get_or<std::string>(j, "created_utc", "", where);
  m.software_version = json_get_or<std::string>(j, "software_version", "", where);
  const Json rig = json_get<Json>(j, "rig", where);
  m.rig_name = json_get<std::string>(rig, "name", where + ": rig");
  m.rig_file = json_get<std::string>(rig, "file", where + ": rig");
  m.rig_sha256 = json_get_or<std::string>(rig, "sha256", "", where + ": rig");
  const Json plan = json_get<Json>(j, "plan", where);
  m.angles_deg = json_get<std::vector<double>>(plan, "angles_deg", where + ": plan");
  m.exposures_s = json_get<std::vector<double>>(plan, "exposures_s", where + ": plan");
  m.settle_s = json_get_or<double>(plan, "settle_s", 0.0, where + ": plan");
  m.gain_db = json_get_or<double>(plan, "gain_db", 0.0, where + ": plan");
  if (m.angles_deg.empty()) throw DataError(where + ": plan has no angles");
  m.calibration = j.value("calibration", Json::object());
  m.devices = j.value("devices", Json::object());
  if (j.contains("options")) m.options = SessionOptions::from_json(j.at("options"), where);
  return m;
}

int SessionState::finished_count() const {
  return static_cast<int>(std::count_if(finished.begin(), finished.end(), [](const auto& e) { return e.has_value(); }));
}

SessionDir::SessionDir(fs::path dir, SessionManifest manifest)
    : dir_(std::move(dir)), manifest_(std::move(manifest)), journal_(dir_ / kJournalFile) {}

SessionDir SessionDir::create(const fs::path& dir_in, SessionManifest manifest) {
  if (manifest.angles_deg.empty()) throw DataError("the measurement plan has no light angles");
  if (manifest.exposures_s.empty()) throw DataError("the measurement plan has no exposures");
  fs::path dir = fs::absolute(dir_in);
  std::error_code ec;
  if (fs::exists(dir / kManifestFile)) {
    std::string whose = "another session";
    try {
      Json j = read_json_file(dir / kManifestFile);
      whose = "a session of sample '" + j.value("sample", std::string("?")) + "'";
    } catch (const Error&) {
    }
    throw DataError(dir.string() + " already holds " + whose +
                    "; nothing was changed. Continue it with `paintlab measure --resume " + dir.string() +
                    "` or choose another --out folder");
  }
  if (fs::exists(dir)) {
    if (!fs::is_directory(dir)) throw DataError(dir.string() + " exists and is not a folder");
    if (!fs::is_empty(dir, ec))
      throw DataError(dir.string() + " is not empty and holds no session; choose an empty or new --out folder");
  }
  fs::create_directories(dir / "hdr", ec);
  if (ec) throw IoError(dir.string(), "cannot create the session folder", ec.value(), IoOp::Write);
  write_json_file(dir / kManifestFile, manifest.to_json());
  fsync_path(dir);
  return SessionDir(dir, std::move(manifest));
}

SessionDir SessionDir::open(const fs::path& dir_in) {
  fs::path dir = fs::absolute(dir_in);
  if (!fs::exists(dir / kManifestFile))
    throw DataError(dir.string() + ": not a session folder (no " + kManifestFile + ")");
  SessionManifest m = SessionManifest::from_json(read_json_file(dir / kManifestFile), (dir / kManifestFile).string());
  return SessionDir(dir, std::move(m));
}

std::string SessionDir::hdr_name(int index) { return fmt::format("hdr/pos_{:03d}.exr", index); }

fs::path SessionDir::raw_dir(int index) const { return dir_ / fmt::format("raw/pos_{:03d}", index); }

SessionState SessionDir::inspect() const {
  SessionState st;
  const int n = position_count();
  st.finished.assign(n, std::nullopt);
  std::vector<JournalEntry> entries = journal_.read(&st.torn_journal);
  if (st.torn_journal) st.problems.push_back("journal.jsonl ends in a torn line (a crash during an append)");
  // The last entry of an index wins (a re-measured position appends a new entry).
  std::map<int, JournalEntry> last;
  for (auto& e : entries) {
    if (e.index >= n) {
      st.problems.push_back(fmt::format("journal entry for index {} is outside the plan of {} positions", e.index, n));
      continue;
    }
    last[e.index] = std::move(e);
  }
  for (auto& [index, e] : last) {
    fs::path file = dir_ / e.file;
    if (!fs::exists(file)) {
      st.problems.push_back(fmt::format("{}: missing; position {} will be measured again", e.file, index));
      continue;
    }
    std::string sum = sha256_file(file);
    if (sum != e.sha256) {
      st.problems.push_back(fmt::format("{}: checksum does not match the journal; position {} will be measured again",
                                        e.file, index));
      st.rejected.push_back(file);
      continue;
    }
    st.finished[index] = std::move(e);
  }
  for (int i = 0; i < n; ++i) {
    if (st.finished[i]) continue;
    st.todo.push_back(i);
    fs::path file = hdr_path(i);
    bool already_rejected = std::find(st.rejected.begin(), st.rejected.end(), file) != st.rejected.end();
    if (fs::exists(file) && !already_rejected) {
      st.problems.push_back(fmt::format("{}: has no journal entry (interrupted before it was journaled)", hdr_name(i)));
      st.rejected.push_back(file);
    }
  }
  return st;
}

SessionState SessionDir::prepare_resume() const {
  journal_.repair();
  remove_stale_temps(dir_ / "hdr");
  remove_stale_temps(dir_);
  SessionState st = inspect();
  if (!st.rejected.empty()) {
    fs::path rej = dir_ / "hdr" / "rejected";
    fs::create_directories(rej);
    for (const auto& f : st.rejected) {
      fs::path target;
      for (int k = 1;; ++k) {
        target = rej / fmt::format("{}.{}", f.filename().string(), k);
        if (!fs::exists(target)) break;
      }
      fs::rename(f, target);
    }
    fsync_path(rej);
    fsync_path(dir_ / "hdr");
    st.rejected.clear();
  }
  return st;
}

std::vector<JournalEntry> SessionDir::finished_entries() const {
  SessionState st = inspect();
  std::vector<JournalEntry> out;
  for (auto& e : st.finished)
    if (e) out.push_back(*e);
  return out;
}

}  // namespace paintlab::acq
