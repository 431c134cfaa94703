#include "paintlab/fitting/session_binning.h"

#include "paintlab/fitting/pipeline.h"

#include <algorithm>
#include <fmt/format.h>

#include <optional>
#include <spdlog/spdlog.h>

#include "paintlab/acquisition/session_reader.h"
#include "paintlab/core/colour.h"
#include "paintlab/core/enum_names.h"
#include "paintlab/core/error.h"
#include "paintlab/fitting/coverage.h"
#include "paintlab/core/version.h"

namespace fs = std::filesystem;

namespace paintlab::fit {

constexpr EnumNames<SiteFit, 3> kSiteFitNames{{{SiteFit::Off, "off"}, {SiteFit::On, "on"}, {SiteFit::Auto, "auto"}}};

const char* to_string(SiteFit s) { return enum_name(kSiteFitNames, s); }

SiteFit site_fit_from_string(std::string_view s, std::string_view where) {
  return enum_from_name(kSiteFitNames, s, "choice (filter-array sites)", where);
}

std::optional<std::string> site_fit_refusal(const acq::SessionDir& session, const calib::RigCalibration& calibration,
                                            const ExtractionOptions& extraction) {
  const acq::SessionOptions& o = session.manifest().options;
  if (o.pixel_format.rfind("Bayer", 0) != 0)
    return fmt::format("it was measured {}, not with a Bayer camera",
                       o.pixel_format.empty() ? std::string("with a monochrome camera") : "in " + o.pixel_format);
  if (extraction.variance == VarianceModel::Local)
    return std::string("the local variance model (--variance local) compares a pixel with its neighbours, other "
                       "colours at the sites");
  if (o.colour_space == colour::kCameraRgb) return std::nullopt;
  // The variance of a site's own colour comes back out of the stored sRGB only when the
  // three channels of a pixel come from different sites (bilinear demosaicing); the
  // gradient-corrected kernels mix the site itself into the other colours.
  if (o.demosaic == "gradient-corrected")
    return std::string("it was demosaiced gradient-corrected, whose colours of a pixel share its own site: the site's "
                       "variance cannot be taken back out of its linear sRGB (measure with bilinear demosaicing, the "
                       "default, to fit at the sites)");
  if (!calibration.colour())
    return std::string("its linear sRGB goes back to camera RGB through the colour calibration, and the calibration "
                       "folder has no colour.json");
  if (!calibration.colour()->balanced_srgb_matrix())
    return fmt::format("the colour calibration is a {} model, which is not linear: only the 3x3 matrix maps sRGB back to "
                       "camera RGB",
                       calib::to_string(calibration.colour()->model));
  if (!calibration.scale() || !calibration.scale()->white_balance())
    return std::string("the scale calibration has no per-channel scale (scale_rgb) to undo the white balance with");
  return std::nullopt;
}

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

namespace {

// Why `session` is not binned at its filter-array sites (SiteFit::Auto, On), or nullopt:
// DataError naming the session for SiteFit::On.
std::optional<std::string> sites_refused(const acq::SessionDir& session, const calib::RigCalibration& cal,
                                         const SessionBinOptions& options) {
  std::optional<std::string> refusal = site_fit_refusal(session, cal, options.extraction);
  if (refusal && options.sites == SiteFit::On)
    throw DataError(fmt::format("{}: cannot be fitted at its filter-array sites (--cfa-sites on): {}",
                                session.dir().string(), *refusal));
  return refusal;
}

std::string colour_space_of(const acq::SessionDir& session) {
  const std::string& cs = session.manifest().options.colour_space;
  return cs.empty() ? colour::kCameraRgb : cs;
}

// The rules for sessions binned together: DataError naming the session that breaks one.
void check_fitted_together(const std::vector<acq::SessionDir>& sessions) {
  for (std::size_t i = 1; i < sessions.size(); ++i) {
    const acq::SessionDir& s = sessions[i];
    const acq::SessionDir& first = sessions[0];
    for (std::size_t j = 0; j < i; ++j)
      if (fs::equivalent(s.dir(), sessions[j].dir()) || acq::session_sha256(s.dir()) == acq::session_sha256(sessions[j].dir()))
        throw DataError(fmt::format("{}: given twice (as {}): a measurement binned twice would count its samples "
                                    "twice; give each session once",
                                    s.dir().string(), sessions[j].dir().string()));
    if (colour_space_of(s) != colour_space_of(first))
      throw DataError(fmt::format("{}: measured in {}, {} in {}: sessions fitted together need one colour space",
                                  s.dir().string(), colour_space_of(s), first.dir().string(), colour_space_of(first)));
    if (s.manifest().sample != first.manifest().sample)
      spdlog::warn("{} measured sample '{}', {} '{}': fitted together as one paint", s.dir().string(),
                   s.manifest().sample, first.dir().string(), first.manifest().sample);
  }
}

}  // namespace

BinnedSession bin_session(const acq::SessionDir& session, const SessionBinOptions& options) {
  return bin_sessions({session}, options);
}

BinnedSession bin_sessions(const std::vector<acq::SessionDir>& sessions, const SessionBinOptions& options) {
  options.check();
  if (sessions.empty()) throw DataError("no session to bin");
  check_fitted_together(sessions);
  std::vector<calib::RigCalibration> cals;
  std::vector<std::vector<HdrFrame>> frames;
  for (const acq::SessionDir& s : sessions) {
    acq::require_complete_session(s);
    frames.push_back(session_frames(s));
    cals.push_back(acq::session_calibration(s, options.calib_dir));
  }
  // At the sites only when every session can be (one table of each colour for all).
  ExtractionOptions extraction = options.extraction;
  if (!extraction.cfa_sites && options.sites != SiteFit::Off) {
    extraction.cfa_sites = true;
    for (std::size_t i = 0; i < sessions.size(); ++i)
      if (const auto refusal = sites_refused(sessions[i], cals[i], options)) {
        extraction.cfa_sites = false;
        if (sessions[i].manifest().options.pixel_format.rfind("Bayer", 0) == 0)
          spdlog::warn("{}: fitted on the demosaiced image, not at its filter-array sites: {}{}",
                       sessions[i].dir().string(), *refusal, sessions.size() > 1 ? " (so are the other sessions)" : "");
      }
  }
  std::vector<ExtractionStats> each(sessions.size());
  std::vector<CalibratedFrames> groups;
  for (std::size_t i = 0; i < sessions.size(); ++i) {
    spdlog::info("extracting and binning {} HDR images of {}", frames[i].size(), sessions[i].dir().string());
    groups.push_back({frames[i], &cals[i], &each[i]});
  }
  BinnedSession out;
  std::size_t measured = 0;
  if (extraction.cfa_sites) {
    out.sites = bin_frames_by_site(groups, extraction, options.binning, &out.stats);
    for (const BinnedTable& t : out.sites->tables) measured += t.table.count_in_state(brdf::BinState::Measured);
  } else {
    out.binned = bin_frames(groups, extraction, options.binning, &out.stats);
    measured = out.binned.table.count_in_state(brdf::BinState::Measured);
  }
  spdlog::info("{} samples in {} bins{}{}", out.stats.samples, measured,
               out.sites ? " (the three colours' tables together)" : "",
               sessions.size() > 1 ? fmt::format(" from {} sessions", sessions.size()) : "");
  // One session as fits have always recorded it; several as "sessions", each with its own
  // path, checksum, counts and blur, the first one's also at the top (readers of one session).
  auto path_of = [](const acq::SessionDir& s) { return fs::absolute(s.dir()).lexically_normal().string(); };
  std::vector<double> sigma;
  for (const calib::RigCalibration& c : cals) sigma.push_back(blur_sigma_to_correct(options.extraction, c));
  std::size_t positions = 0;
  for (const auto& f : frames) positions += f.size();
  const bool one_sigma = std::all_of(sigma.begin(), sigma.end(), [&](double v) { return v == sigma[0]; });
  out.input = {{"kind", sessions.size() == 1 ? "session" : "sessions"},
               {"path", path_of(sessions[0])},
               {"sample", sessions[0].manifest().sample},
               {"colour_space", colour_space_of(sessions[0])},
               {"positions", positions},
               {"extraction", out.stats.to_json()},
               {"margin_px", options.extraction.margin_px},
               // -1: each session's own calibration's (listed under "sessions")
               {"blur_sigma_px", one_sigma ? sigma[0] : -1.0},
               {"valid_margin_px", options.extraction.valid_margin_px},
               {"max_blur_correction", options.extraction.max_blur_correction},
               {"too_sharp", options.extraction.skip_too_sharp ? "skip" : "keep"},
               {"variance", to_string(options.extraction.variance)},
               {"estimator", to_string(options.binning.estimator)}};
  if (sessions.size() == 1) {
    out.input["session_sha256"] = acq::session_sha256(sessions[0].dir());
  } else {
    Json list = Json::array();
    for (std::size_t i = 0; i < sessions.size(); ++i)
      list.push_back({{"path", path_of(sessions[i])},
                      {"sample", sessions[i].manifest().sample},
                      {"positions", frames[i].size()},
                      {"session_sha256", acq::session_sha256(sessions[i].dir())},
                      {"blur_sigma_px", sigma[i]},
                      {"extraction", each[i].to_json()}});
    out.input["sessions"] = std::move(list);
  }
  if (out.sites) {
    out.input["cfa_sites"] = true;
    Json m = Json::array();
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) m.push_back(out.sites->to_colour_space(i, j));
    out.input["site_to_colour_space"] = m;
  }
  return out;
}

std::vector<fs::path> fitted_sessions(const Json& input) {
  std::vector<fs::path> out;
  if (!input.is_object()) return out;
  const std::string kind = input.value("kind", "");
  if (kind == "session" && input.contains("path") && input["path"].is_string()) {
    out.emplace_back(input["path"].get<std::string>());
  } else if (kind == "sessions" && input.contains("sessions") && input["sessions"].is_array()) {
    for (const Json& s : input["sessions"])
      if (s.is_object() && s.contains("path") && s["path"].is_string()) out.emplace_back(s["path"].get<std::string>());
  }
  return out;
}

SessionBinOptions bin_options_of_input(const Json& input, SessionBinOptions base, const std::string& where) {
  if (!input.is_object()) return base;
  // A number the input records, or `absent` (nullopt: keep the base's value).
  auto number = [&](const char* key, std::optional<double> absent) -> std::optional<double> {
    if (!input.contains(key)) return absent;
    if (!input[key].is_number()) throw DataError(fmt::format("{} input.{}: expected a number", where, key));
    return input[key].get<double>();
  };
  if (auto v = number("margin_px", std::nullopt)) base.extraction.margin_px = *v;
  if (auto v = number("max_blur_correction", std::nullopt)) base.extraction.max_blur_correction = *v;
  // The lens blur and the valid margin: fits made before these rules existed record neither,
  // and were binned without them.
  base.extraction.blur_sigma_px = *number("blur_sigma_px", 0.0);  // -1 (sessions): each one's calibration's
  base.extraction.valid_margin_px = 0;
  if (input.contains("valid_margin_px")) {
    const Json& v = input["valid_margin_px"];
    if (!v.is_number_integer() || v.get<long long>() < 0 || v.get<long long>() > 10)
      throw DataError(fmt::format("{} input.valid_margin_px: expected an integer in [0, 10], got {}", where, v.dump()));
    base.extraction.valid_margin_px = v.get<int>();
  }
  if (input.contains("too_sharp")) {
    const Json& t = input["too_sharp"];
    if (!t.is_string() || (t != "keep" && t != "skip"))
      throw DataError(fmt::format("{} input.too_sharp: expected \"keep\" or \"skip\"", where));
    base.extraction.skip_too_sharp = t == "skip";
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

std::size_t FitInput::measured_bins() const {
  if (!sites) return table.count_in_state(brdf::BinState::Measured);
  std::size_t n = 0;
  for (const BinnedTable& t : sites->tables) n += t.table.count_in_state(brdf::BinState::Measured);
  return n;
}

namespace {

FitInput binned_input(BinnedSession s) {
  FitInput in;
  in.table = std::move(s.binned.table);
  in.sites = std::move(s.sites);
  in.noise_variance = std::move(s.binned.noise_variance);
  in.sample = s.input["sample"].get<std::string>();
  in.input = std::move(s.input);
  in.stats = s.stats;
  return in;
}

}  // namespace

FitInput load_fit_input(const std::vector<fs::path>& paths, const SessionBinOptions& options) {
  if (paths.size() == 1) return load_fit_input(paths.front(), options);
  if (paths.empty()) throw DataError("no session or table to fit");
  std::vector<acq::SessionDir> sessions;
  for (const fs::path& p : paths) {
    if (!fs::exists(p)) throw IoError(p.string(), "no such file or folder");
    if (!fs::is_directory(p) || !fs::exists(p / "session.json"))
      throw DataError(fmt::format("{}: not a session folder; several inputs are sessions of one paint binned "
                                  "together (a table's samples are gone: fit a table alone)",
                                  p.string()));
    sessions.push_back(acq::SessionDir::open(p));
  }
  return binned_input(bin_sessions(sessions, options));
}

FitInput load_fit_input(const fs::path& path, const SessionBinOptions& options) {
  if (!fs::exists(path)) throw IoError(path.string(), "no such file or folder");
  FitInput in;
  if (fs::is_directory(path)) {
    if (!fs::exists(path / "session.json"))
      throw DataError(fmt::format("{}: a folder without session.json; paintlab fit reads a session folder or a "
                                  "MERL .binary table",
                                  path.string()));
    return binned_input(bin_session(acq::SessionDir::open(path), options));
  }
  spdlog::info("reading {}", path.string());
  in.table = brdf::read_merl(path);
  in.sample = path.stem().string();
  in.input = {{"kind", "merl"}, {"path", fs::absolute(path).string()}};
  const fs::path cov = coverage_map_path_for(path);
  const std::size_t measured = in.table.count_in_state(brdf::BinState::Measured);
  if (fs::exists(cov)) {
    const std::size_t filled = mark_filled_bins(cov, in.table);
    in.input["coverage_map"] = fs::absolute(cov).string();
    in.input["filled_bins_left_out"] = filled;
    if (filled > 0)
      in.warnings.push_back(fmt::format("{}: {} of its {} bins were filled by `paintlab bin --fill` ({} says so); "
                                        "filled bins are not measurements, so the fit uses the {} measured ones",
                                        path.string(), filled, measured, cov.string(), measured - filled));
  } else if (static_cast<double>(measured) > 0.9 * static_cast<double>(coverage(in.table).total.valid_bins)) {
    in.warnings.push_back(fmt::format(
        "{}: {} bins hold values, nearly every bin a rig can measure, and no coverage map ({}) says which were "
        "measured; if the table was filled (`paintlab bin --fill`), filled bins are fitted as measurements, and a fit "
        "over this many bins takes minutes (fit the unfilled table, or keep its coverage map beside it)",
        path.string(), measured, cov.filename().string()));
  }
  return in;
}

AxfPaint fit_cook_torrance_now(const FitInput& in, int lobes, const std::string& what) {
  spdlog::info("fitting a {}-lobe Cook-Torrance model to {} (give --fit FIT.json to use an existing fit)", lobes, what);
  SharedFitOptions shared;
  shared.lobes = lobes;
  const FitOutcome fit = fit_table(in.table, in.noise_variance.empty() ? nullptr : &in.noise_variance,
                                   FitRequest::with(FitModel::CookTorrance, paint_name_from(in.sample), shared), in.input);
  if (!fit.converged) spdlog::warn("the fit of {} did not converge ({})", what, fit.termination);
  return axf_from_fit_json(fit.fit, what);
}

}  // namespace paintlab::fit
