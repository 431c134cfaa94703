#include "paintlab/fitting/session_binning.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "paintlab/acquisition/session_reader.h"
#include "paintlab/core/error.h"
#include "paintlab/core/version.h"

namespace fs = std::filesystem;

namespace paintlab::fit {

void SessionBinOptions::check() const {
  extraction.check();
  binning.check();
}

std::vector<HdrFrame> session_frames(const acq::SessionDir& session) {
  std::vector<HdrFrame> frames;
  for (const auto& e : session.finished_entries()) frames.push_back({session.dir() / e.file, e.angle_deg});
  if (frames.empty()) throw DataError(session.dir().string() + ": the session has no finished light position");
  return frames;
}

BinnedSession bin_session(const acq::SessionDir& session, const SessionBinOptions& options) {
  options.check();
  acq::require_complete_session(session);
  const std::vector<HdrFrame> frames = session_frames(session);
  const calib::RigCalibration cal = acq::session_calibration(session, options.calib_dir);
  spdlog::info("extracting and binning {} HDR images of {}", frames.size(), session.dir().string());
  BinnedSession out;
  out.binned = bin_frames(frames, cal, options.extraction, options.binning, &out.stats);
  spdlog::info("{} samples in {} bins", out.stats.samples, out.binned.table.count_in_state(brdf::BinState::Measured));
  out.input = {{"kind", "session"},
               {"path", fs::absolute(session.dir()).lexically_normal().string()},
               {"sample", session.manifest().sample},
               {"positions", frames.size()},
               {"session_sha256", acq::session_sha256(session.dir())},
               {"extraction", out.stats.to_json()},
               {"margin_px", options.extraction.margin_px},
               {"variance", to_string(options.extraction.variance)},
               {"estimator", to_string(options.binning.estimator)}};
  return out;
}

SessionBinOptions bin_options_of_input(const Json& input, SessionBinOptions base, const std::string& where) {
  if (!input.is_object()) return base;
  if (input.contains("margin_px")) {
    if (!input["margin_px"].is_number()) throw DataError(fmt::format("{} input.margin_px: expected a number", where));
    base.extraction.margin_px = input["margin_px"].get<double>();
  }
  if (input.contains("variance")) {
    if (!input["variance"].is_string()) throw DataError(fmt::format("{} input.variance: expected a string", where));
    base.extraction.variance =
        variance_model_from_string(input["variance"].get<std::string>(), where + " input.variance");
  }
  if (input.contains("estimator")) {
    if (!input["estimator"].is_string()) throw DataError(fmt::format("{} input.estimator: expected a string", where));
    base.binning.estimator =
        bin_estimator_from_string(input["estimator"].get<std::string>(), where + " input.estimator");
  }
  base.check();
  return base;
}

AxfProvenance session_provenance(const acq::SessionDir& session) {
  const acq::SessionManifest& m = session.manifest();
  AxfProvenance p;
  p.sample_name = m.sample;
  p.measured_utc = parse_utc_timestamp(m.created_utc) >= 0 ? m.created_utc : "";
  p.rig_name = m.rig_name;
  for (auto it = m.calibration.begin(); it != m.calibration.end(); ++it)
    if (it.value().is_string()) p.calibration_sha256.emplace_back(it.key(), it.value().get<std::string>());
  p.session_sha256 = acq::session_sha256(session.dir());
  p.source = fs::absolute(session.dir()).lexically_normal().string();
  return p;
}

}  // namespace paintlab::fit
