#include "paintlab/fitting/paint_library.h"

#include "paintlab/brdf/paint.h"
#include "paintlab/fitting/multiangle.h"

#include <fcntl.h>
#include <fmt/format.h>
#include <sys/file.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <set>
#include <thread>

#include "paintlab/core/atomic_file.h"
#include "paintlab/core/error.h"
#include "paintlab/core/hash.h"
#include "paintlab/core/json.h"
#include "paintlab/core/log.h"
#include "paintlab/core/version.h"

namespace fs = std::filesystem;

namespace paintlab::fit {

namespace {

constexpr const char* kLockFile = ".lock";
constexpr const char* kPaintSuffix = ".axf.h5";
constexpr const char* kTransportsDir = "transports";  // interpolatable(): cached flake transports

// A name `add` gives a paint's file: NAME.ID.axf.h5 (a paint name, a number).
bool is_library_file_name(const std::string& n) {
  const std::string suffix = kPaintSuffix;
  if (n.empty() || n.front() == '.' || n.size() <= suffix.size() ||
      n.compare(n.size() - suffix.size(), suffix.size(), suffix) != 0)
    return false;
  const std::string stem = n.substr(0, n.size() - suffix.size());
  const auto dot = stem.rfind('.');
  if (dot == std::string::npos || dot == 0 || dot + 1 == stem.size()) return false;
  return std::all_of(stem.begin() + static_cast<std::ptrdiff_t>(dot) + 1, stem.end(),
                     [](char c) { return c >= '0' && c <= '9'; });
}

// An exclusive flock on DIR/.lock for the lifetime of the object. The kernel releases it
// when the process dies, so a crashed writer never leaves the library locked. A lock held
// longer than `timeout_s` by another process (a hung command) is an IoError, never a hang.
class DirLock {
 public:
  DirLock(const fs::path& dir, double timeout_s) {
    const fs::path p = dir / kLockFile;
    fd_ = ::open(p.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (fd_ < 0) throw IoError(p.string(), "cannot open the library lock", errno);
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    while (::flock(fd_, LOCK_EX | LOCK_NB) != 0) {
      const int e = errno;
      if (e == EINTR) continue;
      if (e == EWOULDBLOCK && std::chrono::steady_clock::now() < deadline) {
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
        continue;
      }
      ::close(fd_);
      if (e == EWOULDBLOCK)
        throw IoError(p.string(),
                      fmt::format("another process has held the library lock for {:g} s (a paintlab library command "
                                  "still running or hung); try again when it has finished",
                                  timeout_s));
      throw IoError(p.string(), "cannot lock the library", e);
    }
  }
  ~DirLock() {
    if (fd_ >= 0) ::close(fd_);  // closing releases the flock
  }
  DirLock(const DirLock&) = delete;
  DirLock& operator=(const DirLock&) = delete;

 private:
  int fd_ = -1;
};

bool ends_with(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

std::string names_of(const std::vector<LibraryEntry>& entries) {
  std::string s;
  for (const auto& e : entries) s += (s.empty() ? "" : ", ") + e.name;
  return s.empty() ? "none" : s;
}

}  // namespace

Json LibraryEntry::to_json() const {
  Json j = {{"name", name}, {"file", file},           {"sha256", sha256}, {"model", model},
            {"date", date}, {"added_utc", added_utc}, {"sample", sample}};
  if (log_rms || bins_used) {
    Json r = Json::object();
    if (log_rms) r["log_rms"] = *log_rms;
    if (bins_used) r["bins_used"] = *bins_used;
    j["residual"] = r;
  } else {
    j["residual"] = nullptr;
  }
  if (colour.empty()) {
    j["colour"] = nullptr;
  } else {
    Json values = Json::array();
    for (const auto& [geometry, lab] : colour) values.push_back({{"geometry", geometry}, {"L", lab.L}, {"a", lab.a}, {"b", lab.b}});
    j["colour"] = {{"geometries", kDefaultGeometrySet}, {"illuminant", "D65"}, {"observer_deg", 2}, {"values", values}};
  }
  if (!sparkle) {
    j["sparkle"] = nullptr;
  } else {
    Json at = Json::array();
    for (const LibrarySparkle::At& a : sparkle->at)
      at.push_back({{"illumination_deg", a.illumination_deg},
                    {"viewing_deg", 0.0},
                    {"sparkle_area_percent", a.area_percent ? Json(*a.area_percent) : Json(nullptr)},
                    {"sparkle_intensity", a.intensity ? Json(*a.intensity) : Json(nullptr)}});
    j["sparkle"] = {{"area_percent", sparkle->area_percent},
                    {"lifetime_deg", sparkle->lifetime_deg},
                    {"glints", sparkle->glints},
                    {"instrument", at}};
  }
  return j;
}

namespace {

std::optional<double> optional_number(const Json& j, const char* key, const std::string& where) {
  if (!j.contains(key) || j[key].is_null()) return std::nullopt;
  return json_get<double>(j, key, where);
}

LibrarySparkle sparkle_from_json(const Json& s, const std::string& where) {
  if (!s.is_object()) throw DataError(where + ": expected an object or null");
  LibrarySparkle out;
  out.area_percent = json_get<double>(s, "area_percent", where);
  out.lifetime_deg = json_get<double>(s, "lifetime_deg", where);
  out.glints = json_get<std::uint64_t>(s, "glints", where);
  if (!s.contains("instrument") || !s["instrument"].is_array())
    throw DataError(where + ": key 'instrument': expected an array");
  const Json& at = s["instrument"];
  for (std::size_t i = 0; i < at.size(); ++i) {
    const std::string aw = where + fmt::format(".instrument[{}]", i);
    if (!at[i].is_object()) throw DataError(aw + ": expected an object");
    out.at.push_back({json_get<double>(at[i], "illumination_deg", aw),
                      optional_number(at[i], "sparkle_area_percent", aw),
                      optional_number(at[i], "sparkle_intensity", aw)});
  }
  return out;
}

}  // namespace

// The library's summary of a file's measured flakes.
std::optional<LibrarySparkle> library_sparkle(const AxfPaint& paint) {
  if (!paint.flake_stats) return std::nullopt;
  const FlakeStats& f = *paint.flake_stats;
  LibrarySparkle s;
  s.area_percent = 100.0 * f.area();
  s.lifetime_deg = f.lifetime_deg;
  s.glints = f.glints;
  for (const InstrumentSparkle& is : f.instrument)
    s.at.push_back({is.illumination_deg, is.measured() ? std::optional<double>(is.area_percent) : std::nullopt,
                    is.glints ? std::optional<double>(is.intensity) : std::nullopt});
  return s;
}

LibraryEntry LibraryEntry::from_json(const Json& j, const std::string& where) {
  if (!j.is_object()) throw DataError(where + ": expected an object");
  LibraryEntry e;
  e.name = json_get<std::string>(j, "name", where);
  e.file = json_get<std::string>(j, "file", where);
  e.sha256 = json_get<std::string>(j, "sha256", where);
  e.model = json_get<std::string>(j, "model", where);
  e.date = json_get_or<std::string>(j, "date", "", where);
  e.added_utc = json_get_or<std::string>(j, "added_utc", "", where);
  e.sample = json_get_or<std::string>(j, "sample", "", where);
  if (j.contains("residual") && !j["residual"].is_null()) {
    const Json& r = j["residual"];
    const std::string rw = where + ".residual";
    if (!r.is_object()) throw DataError(rw + ": expected an object or null");
    if (r.contains("log_rms")) e.log_rms = json_get<double>(r, "log_rms", rw);
    if (r.contains("bins_used")) e.bins_used = json_get<std::int64_t>(r, "bins_used", rw);
  }
  if (j.contains("colour") && !j["colour"].is_null()) {
    const std::string cw = where + ".colour";
    const Json& c = j["colour"];
    if (!c.is_object() || !c.contains("values") || !c["values"].is_array())
      throw DataError(cw + ": expected an object with an array 'values'");
    const Json& values = c["values"];
    for (std::size_t i = 0; i < values.size(); ++i) {
      const std::string vw = cw + fmt::format(".values[{}]", i);
      const Json& v = values[i];
      if (!v.is_object()) throw DataError(vw + ": expected an object");
      e.colour.push_back({json_get<std::string>(v, "geometry", vw),
                          colour::Lab{json_get<double>(v, "L", vw), json_get<double>(v, "a", vw), json_get<double>(v, "b", vw)}});
    }
  }
  if (j.contains("sparkle") && !j["sparkle"].is_null()) e.sparkle = sparkle_from_json(j["sparkle"], where + ".sparkle");
  if (e.file.empty() || e.file.find('/') != std::string::npos || e.file.front() == '.')
    throw DataError(where + ": key 'file': '" + e.file + "' is not a file name inside the library folder");
  return e;
}

PaintLibrary PaintLibrary::open(const fs::path& dir, bool create) {
  std::error_code ec;
  const fs::path abs = fs::absolute(dir, ec);
  PaintLibrary lib(ec ? dir : abs.lexically_normal());
  const fs::path index = lib.dir_ / kLibraryIndexFile;
  if (fs::exists(index, ec)) {
    lib.read_index();  // validates
    return lib;
  }
  if (!create)
    throw DataError("library " + lib.dir_.string() + ": not a paint library (no " + kLibraryIndexFile +
                    "); `paintlab library add --dir DIR FILE` creates one");
  if (fs::exists(lib.dir_, ec)) {
    if (!fs::is_directory(lib.dir_, ec)) throw DataError("library " + lib.dir_.string() + ": is not a folder");
    for (const auto& e : fs::directory_iterator(lib.dir_)) {
      const std::string n = e.path().filename().string();
      if (!n.empty() && n.front() != '.')
        throw DataError("library " + lib.dir_.string() + ": the folder is not empty but holds no " +
                        kLibraryIndexFile + " (not a paint library; choose an empty or new folder)");
    }
  } else {
    fs::create_directories(lib.dir_, ec);
    if (ec) throw IoError(lib.dir_.string(), "cannot create the library folder", ec.value(), IoOp::Write);
  }
  DirLock lock(lib.dir_, lib.lock_timeout_s_);
  if (!fs::exists(index, ec)) lib.write_index(Index{});
  return lib;
}

PaintLibrary::Index PaintLibrary::read_index() const {
  const fs::path path = dir_ / kLibraryIndexFile;
  const std::string where = path.string();
  const Json j = read_json_file(path);
  if (!j.is_object()) throw DataError(where + ": expected a JSON object");
  const auto format = json_get<std::string>(j, "format", where);
  if (format != kLibraryFormat)
    throw DataError(where + ": key 'format': '" + format + "' is not '" + kLibraryFormat + "'");
  const auto version = json_get<int>(j, "format_version", where);
  if (version > kLibraryFormatVersion || version < 1)
    throw DataError(where + fmt::format(": key 'format_version': {} is not readable by this software (reads {})",
                                        version, kLibraryFormatVersion));
  Index idx;
  idx.next_id = json_get_or<std::int64_t>(j, "next_id", 1, where);
  if (!j.contains("paints")) throw DataError(where + ": missing key 'paints'");
  const Json& paints = j["paints"];  // a reference: a library's index may hold 10,000 paints
  if (!paints.is_array()) throw DataError(where + ": key 'paints': expected an array");
  std::set<std::string> names;
  for (std::size_t i = 0; i < paints.size(); ++i) {
    LibraryEntry e = LibraryEntry::from_json(paints[i], where + fmt::format(": paints[{}]", i));
    if (!names.insert(e.name).second)
      throw DataError(where + fmt::format(": paints[{}]: paint '{}' is listed twice", i, e.name));
    idx.paints.push_back(std::move(e));
  }
  std::sort(idx.paints.begin(), idx.paints.end(),
            [](const LibraryEntry& a, const LibraryEntry& b) { return a.name < b.name; });
  return idx;
}

void PaintLibrary::write_index(const Index& index) const {
  Json paints = Json::array();
  for (const auto& e : index.paints) paints.push_back(e.to_json());
  const Json j = {{"format", kLibraryFormat},
                  {"format_version", kLibraryFormatVersion},
                  {"updated_utc", utc_timestamp()},
                  {"software_version", software_version()},
                  {"next_id", index.next_id},
                  {"paints", paints}};
  write_json_file(dir_ / kLibraryIndexFile, j);
}

void PaintLibrary::step(const std::string& name) const {
  if (hook_) hook_(name);
}

std::vector<LibraryEntry> PaintLibrary::list() const { return read_index().paints; }

LibraryEntry PaintLibrary::find(const std::string& name) const {
  const Index idx = read_index();
  for (const auto& e : idx.paints)
    if (e.name == name) return e;
  throw DataError("library " + dir_.string() + ": no paint '" + name + "' (paints: " + names_of(idx.paints) + ")");
}

AxfPaint PaintLibrary::load(const std::string& name) const {
  const LibraryEntry e = find(name);
  const fs::path file = dir_ / e.file;
  if (!fs::exists(file))
    throw DataError("library " + dir_.string() + ": the file " + e.file + " of paint '" + name + "' is missing");
  const std::string sum = sha256_file(file);
  if (sum != e.sha256)
    throw DataError("library " + dir_.string() + ": the file " + e.file + " of paint '" + name +
                    "' changed since it was added (sha256 " + sum + ", index says " + e.sha256 + ")");
  return read_axf_file(file);
}

LibraryEntry PaintLibrary::add(const AxfPaint& paint, bool replace) {
  check_axf_paint(paint);  // before taking the lock or touching the folder
  DirLock lock(dir_, lock_timeout_s_);
  step("locked");
  remove_stale_temps(dir_);
  Index idx = read_index();
  remove_leftovers(idx);
  auto old = std::find_if(idx.paints.begin(), idx.paints.end(),
                          [&](const LibraryEntry& e) { return e.name == paint.name; });
  if (old != idx.paints.end() && !replace)
    throw DataError("library " + dir_.string() + ": a paint named '" + paint.name + "' is already there (added " +
                    old->added_utc + "); use --replace to replace it");

  // A new file name for every add: the old index keeps naming a whole, unchanged file
  // until the new index replaces it. Files left by an interrupted add are never reused.
  std::int64_t id = idx.next_id;
  std::string file;
  for (;; ++id) {
    file = fmt::format("{}.{}{}", paint.name, id, kPaintSuffix);
    if (!fs::exists(dir_ / file) && std::none_of(idx.paints.begin(), idx.paints.end(),
                                                 [&](const LibraryEntry& e) { return e.file == file; }))
      break;
  }
  // All or nothing: until the new index is in place, a failure (a full disk while the
  // index is written) removes the new file again, unless the index already names it.
  try {
    write_axf_file(dir_ / file, paint);
    step("paint-written");
    return commit_added(idx, old, file, id);
  } catch (...) {
    std::error_code ec;
    bool named = false;
    try {
      const Index now = read_index();
      named = std::any_of(now.paints.begin(), now.paints.end(), [&](const LibraryEntry& e) { return e.file == file; });
    } catch (const Error&) {
      named = true;  // the index cannot be read: keep what may be named by it
    }
    if (!named) fs::remove(dir_ / file, ec);
    throw;
  }
}

LibraryEntry PaintLibrary::commit_added(Index& idx, std::vector<LibraryEntry>::iterator old, const std::string& file,
                                        std::int64_t id) {
  const AxfPaint written = read_axf_file(dir_ / file);
  LibraryEntry entry;
  entry.name = written.name;
  entry.file = file;
  entry.sha256 = sha256_file(dir_ / file);
  entry.model = written.model;
  entry.date = written.provenance.measured_utc.empty() ? written.provenance.exported_utc
                                                       : written.provenance.measured_utc;
  entry.added_utc = utc_timestamp();
  entry.sample = written.provenance.sample_name;
  if (written.fit_quality) {
    entry.log_rms = written.fit_quality->log_rms;
    entry.bins_used = written.fit_quality->bins_used;
  }
  if (written.colour_space == colour::kLinearSrgb) {
    const auto model = brdf::make_brdf(written.paint_spec());
    for (const AngleColour& c : colour_at(*model, geometry_set(kDefaultGeometrySet)))
      entry.colour.push_back({c.geometry.name, c.lab});
  }
  entry.sparkle = library_sparkle(written);

  std::optional<std::string> old_file;
  if (old != idx.paints.end()) {
    old_file = old->file;
    *old = entry;
  } else {
    idx.paints.push_back(entry);
  }
  idx.next_id = id + 1;
  std::sort(idx.paints.begin(), idx.paints.end(),
            [](const LibraryEntry& a, const LibraryEntry& b) { return a.name < b.name; });
  write_index(idx);
  step("index-written");
  if (old_file) {
    std::error_code ec;
    fs::remove(dir_ / *old_file, ec);  // a leftover is reported by check() and removed by the next change
    step("old-file-removed");
    remove_leftovers(idx);  // the replaced file's cached transports
  }
  return entry;
}

int PaintLibrary::remove_leftovers(const Index& idx) const {
  std::set<std::string> named;
  for (const auto& e : idx.paints) named.insert(e.file);
  int removed = 0;
  std::error_code ec;
  for (const auto& d : fs::directory_iterator(dir_, ec)) {
    const std::string n = d.path().filename().string();
    if (!is_library_file_name(n) || named.count(n)) continue;
    if (fs::remove(d.path(), ec)) ++removed;
  }
  // Cached transports of a paint file no longer in the index (removed or replaced).
  for (const auto& d : fs::directory_iterator(dir_ / kTransportsDir, ec)) {
    const std::string n = d.path().stem().string();
    const auto plus = n.find('+');
    if (plus == std::string::npos || !named.count(n.substr(0, plus)) || !named.count(n.substr(plus + 1)))
      fs::remove(d.path(), ec);
  }
  return removed;
}

InterpolatablePaint PaintLibrary::interpolatable(const std::string& a, const std::string& b, bool* from_cache) const {
  const LibraryEntry ea = find(a), eb = find(b);
  const AxfPaint pa = load(a), pb = load(b);  // checksums checked
  const fs::path file = dir_ / kTransportsDir / (ea.file + "+" + eb.file + ".json");
  if (from_cache) *from_cache = false;
  std::error_code ec;
  if (fs::is_regular_file(file, ec)) {
    try {
      const Json j = read_json_file(file);
      if (j.value("a_sha256", "") == ea.sha256 && j.value("b_sha256", "") == eb.sha256) {
        InterpolatablePaint m = interpolatable_paint(pa, pb, j.at("transports"), file.string());
        if (from_cache) *from_cache = true;
        return m;
      }
    } catch (const std::exception& e) {
      spdlog::warn("cached transports {}: {} (computed again)", file.string(), e.what());
    }
  }
  InterpolatablePaint m = interpolatable_paint(pa, pb);
  try {
    fs::create_directories(file.parent_path());
    write_json_file(file, {{"a", ea.file},
                           {"a_sha256", ea.sha256},
                           {"b", eb.file},
                           {"b_sha256", eb.sha256},
                           {"transports", transports_to_json(m)}});
  } catch (const std::exception& e) {
    spdlog::warn("transports of '{}' and '{}' not cached: {}", a, b, e.what());
  }
  return m;
}

void PaintLibrary::remove(const std::string& name) {
  DirLock lock(dir_, lock_timeout_s_);
  step("locked");
  remove_stale_temps(dir_);
  Index idx = read_index();
  remove_leftovers(idx);
  auto it = std::find_if(idx.paints.begin(), idx.paints.end(), [&](const LibraryEntry& e) { return e.name == name; });
  if (it == idx.paints.end())
    throw DataError("library " + dir_.string() + ": no paint '" + name + "' (paints: " + names_of(idx.paints) + ")");
  const std::string file = it->file;
  idx.paints.erase(it);
  write_index(idx);
  step("index-written");
  std::error_code ec;
  fs::remove(dir_ / file, ec);
  step("file-removed");
  remove_leftovers(idx);  // its cached transports
}

void PaintLibrary::export_h5(const fs::path& file) const {
  std::vector<AxfPaint> paints;
  for (const auto& e : list()) paints.push_back(load(e.name));
  write_axf_library_file(file, paints);
}

std::vector<fs::path> PaintLibrary::export_folder(const fs::path& folder, bool overwrite) const {
  const auto entries = list();
  std::vector<AxfPaint> paints;
  for (const auto& e : entries) paints.push_back(load(e.name));  // every checksum before writing anything
  std::vector<fs::path> out;
  std::string existing;
  for (const auto& e : entries) {
    out.push_back(folder / (e.name + kPaintSuffix));
    if (fs::exists(out.back())) existing += (existing.empty() ? "" : ", ") + out.back().filename().string();
  }
  if (!existing.empty() && !overwrite)
    throw IoError(folder.string(), "would overwrite " + existing + " (use --overwrite to replace them)");
  std::error_code ec;
  fs::create_directories(folder, ec);
  if (ec) throw IoError(folder.string(), "cannot create the folder", ec.value(), IoOp::Write);
  for (std::size_t i = 0; i < paints.size(); ++i) write_axf_file(out[i], paints[i]);
  return out;
}

std::vector<std::string> PaintLibrary::check() const {
  std::vector<std::string> findings;
  const Index idx = read_index();
  std::set<std::string> named;
  for (const auto& e : idx.paints) {
    named.insert(e.file);
    const fs::path file = dir_ / e.file;
    if (!fs::exists(file)) {
      findings.push_back("paint '" + e.name + "': file " + e.file + " is missing");
      continue;
    }
    if (sha256_file(file) != e.sha256)
      findings.push_back("paint '" + e.name + "': file " + e.file + " changed since it was added (checksum)");
  }
  for (const auto& d : fs::directory_iterator(dir_)) {
    const std::string n = d.path().filename().string();
    if (ends_with(n, kPaintSuffix) && n.front() != '.' && !named.count(n))
      findings.push_back("file " + n + " is not in the index (left by an interrupted add or replace)");
  }
  return findings;
}

}  // namespace paintlab::fit
