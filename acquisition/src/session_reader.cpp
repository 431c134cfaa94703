#include "paintlab/acquisition/session_reader.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "paintlab/core/atomic_file.h"
#include "paintlab/core/error.h"
#include "paintlab/core/hash.h"
#include "paintlab/core/rig.h"

namespace fs = std::filesystem;

namespace paintlab::acq {

bool is_session_dir(const fs::path& path) {
  std::error_code ec;
  return fs::is_directory(path, ec) && fs::is_regular_file(path / "session.json", ec);
}

void require_complete_session(const SessionDir& session) {
  const SessionState state = session.inspect();
  if (state.todo.empty()) return;
  std::string which;
  for (std::size_t k = 0; k < state.todo.size() && k < 8; ++k)
    which += fmt::format("{}{}", k ? ", " : "", state.todo[k]);
  if (state.todo.size() > 8) which += ", ...";
  std::string why;
  for (const std::string& p : state.problems) why += "; " + p;
  throw DataError(fmt::format(
      "{}: {} of {} light positions are missing (index {}){}; finish the session with "
      "`paintlab measure --resume {}`",
      session.dir().string(), state.todo.size(), session.position_count(), which, why, session.dir().string()));
}

calib::RigCalibration session_calibration(const SessionDir& session, const std::optional<fs::path>& calib_dir) {
  fs::path dir;
  if (calib_dir) {
    dir = *calib_dir;
  } else {
    const std::string& rig_file = session.manifest().rig_file;
    if (rig_file.empty() || !fs::exists(rig_file))
      throw IoError(rig_file.empty() ? (session.dir() / "session.json").string() : rig_file,
                    "the session's rig file cannot be found; give the calibration folder with --calib DIR");
    dir = RigConfig::load(rig_file).calibration_dir;
  }
  if (!fs::is_directory(dir)) throw IoError(dir.string(), "no such calibration folder");
  calib::RigCalibration cal = calib::RigCalibration::load(dir);
  const Json& recorded = session.manifest().calibration;
  for (auto it = recorded.begin(); it != recorded.end(); ++it) {
    const fs::path p = dir / it.key();
    if (!it.value().is_string() || !fs::exists(p)) continue;
    const std::string now = sha256_file(p);
    if (now != it.value().get<std::string>())
      spdlog::warn("{}: changed since the session was measured (sha256 {} then, {} now)", p.string(),
                   it.value().get<std::string>().substr(0, 12), now.substr(0, 12));
  }
  return cal;
}

std::string session_sha256(const fs::path& session_dir) {
  std::string bytes = read_file(session_dir / "session.json");
  if (fs::exists(session_dir / "journal.jsonl")) bytes += read_file(session_dir / "journal.jsonl");
  return sha256_hex(bytes);
}

}  // namespace paintlab::acq
