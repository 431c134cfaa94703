#include "paintlab/fitting/session_binning.h"

#include "paintlab/fitting/pipeline.h"

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

BinnedSession bin_session(const acq::SessionDir& session, const SessionBinOptions& options) {
  options.check();
  acq::require_complete_session(session);
  const std::vector<HdrFrame> frames = session_frames(session);
  const calib::RigCalibration cal = acq::session_calibration(session, options.calib_dir);
  spdlog::info("extracting and binning {} HDR images of {}", frames.size(), session.dir().string());
  ExtractionOptions extraction = options.extraction;
  if (options.sites != SiteFit::Off && !extraction.cfa_sites) {
    const std::optional<std::string> refusal = site_fit_refusal(session, cal, extraction);
    if (refusal && options.sites == SiteFit::On)
      throw DataError(fmt::format("{}: cannot be fitted at its filter-array sites (--cfa-sites on): {}",
                                  session.dir().string(), *refusal));
    if (refusal && session.manifest().options.pixel_format.rfind("Bayer", 0) == 0)
      spdlog::warn("{}: fitted on the demosaiced image, not at its filter-array sites: {}", session.dir().string(),
                   *refusal);
    extraction.cfa_sites = !refusal;
  }
  BinnedSession out;
  std::size_t measured = 0;
  if (extraction.cfa_sites) {
    out.sites = bin_frames_by_site(frames, cal, extraction, options.binning, &out.stats);
    for (const BinnedTable& t : out.sites->tables) measured += t.table.count_in_state(brdf::BinState::Measured);
  } else {
    out.binned = bin_frames(frames, cal, extraction, options.binning, &out.stats);
    measured = out.binned.table.count_in_state(brdf::BinState::Measured);
  }
  spdlog::info("{} samples in {} bins{}", out.stats.samples, measured,
               out.sites ? " (the three colours' tables together)" : "");
  out.input = {{"kind", "session"},
               {"path", fs::absolute(session.dir()).lexically_normal().string()},
               {"sample", session.manifest().sample},
               {"colour_space", session.manifest().options.colour_space.empty()
                                    ? colour::kCameraRgb
                                    : session.manifest().options.colour_space},
               {"positions", frames.size()},
               {"session_sha256", acq::session_sha256(session.dir())},
               {"extraction", out.stats.to_json()},
               {"margin_px", options.extraction.margin_px},
               {"blur_sigma_px", blur_sigma_to_correct(options.extraction, cal)},
               {"valid_margin_px", options.extraction.valid_margin_px},
               {"max_blur_correction", options.extraction.max_blur_correction},
               {"too_sharp", options.extraction.skip_too_sharp ? "skip" : "keep"},
               {"variance", to_string(options.extraction.variance)},
               {"estimator", to_string(options.binning.estimator)}};
  if (out.sites) {
    out.input["cfa_sites"] = true;
    Json m = Json::array();
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) m.push_back(out.sites->to_colour_space(i, j));
    out.input["site_to_colour_space"] = m;
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
  base.extraction.blur_sigma_px = *number("blur_sigma_px", 0.0);
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

FitInput load_fit_input(const fs::path& path, const SessionBinOptions& options) {
  if (!fs::exists(path)) throw IoError(path.string(), "no such file or folder");
  FitInput in;
  if (fs::is_directory(path)) {
    if (!fs::exists(path / "session.json"))
      throw DataError(fmt::format("{}: a folder without session.json; paintlab fit reads a session folder or a "
                                  "MERL .binary table",
                                  path.string()));
    BinnedSession s = bin_session(acq::SessionDir::open(path), options);
    in.table = std::move(s.binned.table);
    in.sites = std::move(s.sites);
    in.noise_variance = std::move(s.binned.noise_variance);
    in.sample = s.input["sample"].get<std::string>();
    in.input = std::move(s.input);
    in.stats = s.stats;
    return in;
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
