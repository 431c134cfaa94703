#include "export_support.h"

#include <fmt/format.h>

#include <algorithm>

#include "paintlab/brdf/paint.h"
#include "paintlab/core/atomic_file.h"
#include "paintlab/core/error.h"
#include "paintlab/core/hash.h"
#include "paintlab/core/json.h"
#include "paintlab/core/log.h"
#include "paintlab/core/rig.h"
#include "paintlab/core/version.h"
#include "paintlab/fitting/hole_fill.h"

namespace fs = std::filesystem;

namespace paintlab::app {

namespace {
std::string lower_extension(const fs::path& p) {
  std::string e = p.extension().string();
  std::transform(e.begin(), e.end(), e.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return e;
}
}  // namespace

fit::AxfPaint load_any_paint(const fs::path& file) {
  if (!fs::exists(file)) throw IoError(file.string(), "no such file");
  if (fs::is_directory(file)) throw UsageError(file.string() + ": a folder, expected a paint file (.axf.h5, fit.json or .toml)");
  const std::string ext = lower_extension(file);
  if (ext == ".h5" || ext == ".hdf5") return fit::read_axf_file(file);
  if (ext == ".json") {
    fit::AxfPaint p = fit::axf_from_fit_json(read_json_file(file), file.string());
    p.provenance.source = fs::absolute(file).lexically_normal().string();
    return p;
  }
  if (ext == ".toml") {
    fit::AxfPaint p = fit::axf_from_paint(brdf::load_paint_file(file));
    p.provenance.source = fs::absolute(file).lexically_normal().string();
    return p;
  }
  throw UsageError(file.string() + ": unknown kind of paint file (expected .axf.h5 / .h5, fit .json or paint .toml)");
}

bool is_session_dir(const fs::path& path) { return fs::is_directory(path) && fs::exists(path / "session.json"); }

std::vector<fit::HdrFrame> session_frames(const acq::SessionDir& session) {
  std::vector<fit::HdrFrame> frames;
  for (const auto& e : session.finished_entries()) frames.push_back({session.dir() / e.file, e.angle_deg});
  if (frames.empty()) throw DataError(session.dir().string() + ": the session has no finished light position");
  return frames;
}

calib::RigCalibration session_calibration(const acq::SessionDir& session, const std::optional<fs::path>& calib_dir) {
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

std::string write_filled_merl(brdf::MerlTable table, const fs::path& out) {
  const fit::HoleFillReport r = fit::fill_holes(table);
  brdf::write_merl(out, table);
  return fmt::format(
      "wrote {} (MERL .binary: {} measured bins, {} filled from the phi_d mirror, {} by push-pull, {} below the "
      "horizon left empty)",
      out.string(), r.measured_bins, r.filled_mirror, r.filled_pyramid, r.invalid_empty);
}

std::string session_sha256(const fs::path& session_dir) {
  std::string bytes = read_file(session_dir / "session.json");
  if (fs::exists(session_dir / "journal.jsonl")) bytes += read_file(session_dir / "journal.jsonl");
  return sha256_hex(bytes);
}

fit::AxfProvenance session_provenance(const acq::SessionDir& session) {
  const acq::SessionManifest& m = session.manifest();
  fit::AxfProvenance p;
  p.sample_name = m.sample;
  p.measured_utc = parse_utc_timestamp(m.created_utc) >= 0 ? m.created_utc : "";
  p.rig_name = m.rig_name;
  for (auto it = m.calibration.begin(); it != m.calibration.end(); ++it)
    if (it.value().is_string()) p.calibration_sha256.emplace_back(it.key(), it.value().get<std::string>());
  p.session_sha256 = session_sha256(session.dir());
  p.source = fs::absolute(session.dir()).lexically_normal().string();
  return p;
}

}  // namespace paintlab::app
