#include "paintlab/fitting/pipeline.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <fmt/format.h>

#include "paintlab/core/enum_names.h"
#include "paintlab/core/error.h"
#include "paintlab/fitting/coverage.h"

namespace paintlab::fit {

constexpr EnumNames<FitModel, 2> kModelNames{
    {{FitModel::CookTorrance, "cook-torrance"}, {FitModel::AxfCarPaint, "axf-carpaint"}}};

const char* to_string(FitModel m) { return enum_name(kModelNames, m); }

FitModel fit_model_from_string(std::string_view s, std::string_view where) {
  return enum_from_name(kModelNames, s, "model", where);
}

void FitRequest::set_shared(const SharedFitOptions& s) {
  for (MultiStartOptions* o : {static_cast<MultiStartOptions*>(&cook_torrance), static_cast<MultiStartOptions*>(&axf_carpaint)}) {
    o->lobes = s.lobes;
    o->seed = s.seed;
    o->threads = s.threads;
    o->max_iterations = s.max_iterations;
    o->data.min_samples = s.min_samples;
  }
}

FitRequest FitRequest::with(FitModel model, std::string name, const SharedFitOptions& shared) {
  FitRequest r;
  r.model = model;
  r.name = std::move(name);
  r.set_shared(shared);
  return r;
}

void FitRequest::check() const {
  cook_torrance.check();
  axf_carpaint.check();
}

std::string paint_name_from(std::string_view text) {
  std::string out;
  for (char ch : text) {
    const unsigned char u = static_cast<unsigned char>(ch);
    const char lower = static_cast<char>(std::tolower(u));
    const bool ok = (lower >= 'a' && lower <= 'z') || (lower >= '0' && lower <= '9') || lower == '.' ||
                    lower == '_' || lower == '-';
    out += ok ? lower : '-';
  }
  if (out.empty()) out = "fitted";
  return out;
}

namespace {

// The sessions binned into a fit's table, from its "input" (session_binning.h: "kind":
// "sessions" lists them); 1 for one session or a table.
std::uint32_t sessions_in(const Json& input) {
  if (!input.is_object() || !input.contains("kind") || input["kind"] != "sessions") return 1;
  const auto it = input.find("sessions");
  return it != input.end() && it->is_array() && !it->empty() ? static_cast<std::uint32_t>(it->size()) : 1;
}

std::string region_lines(const ResidualReport& r) {
  std::string s = fmt::format("  residual log-RMS  {:.4f} over {} bins ({} values)", r.total.log_rms, r.total.bins,
                              r.total.residuals);
  if (std::isfinite(r.total.noise_floor)) s += fmt::format(", noise floor {:.4f}", r.total.noise_floor);
  s += "\n";
  if (r.min_samples > 1 || std::isfinite(r.sparkle_excess)) {
    s += r.min_samples > 1 ? fmt::format("  fit points        phi_d bins pooled to {} samples", r.min_samples)
                           : std::string("  fit points        a point per bin");
    if (std::isfinite(r.sparkle_excess))
      s += fmt::format(" (glossy samples spread {:.3g} x their noise: {})", r.sparkle_excess,
                       r.sparkle_excess > kSparkleExcess ? "sparkle" : "no sparkle");
    s += "\n";
    if (std::isfinite(r.point_scatter) && r.point_scatter > 1.0)
      s += fmt::format("                    glossy points scatter {:.3g} x their samples' spread / n (dependent samples: "
                       "the log correction takes it)\n", r.point_scatter);
  }
  for (int k = 0; k < kRegionCount; ++k) {
    const RegionResidual& g = r.regions[k];
    s += fmt::format("    {:<8} {:.4f} over {} bins", to_string(static_cast<Region>(k)), g.log_rms, g.bins);
    if (std::isfinite(g.noise_floor)) s += fmt::format(" (floor {:.4f})", g.noise_floor);
    s += "\n";
  }
  return s;
}

std::string ct_report(const CookTorranceFit& f) {
  std::string s = fmt::format("cook-torrance, {} lobe{}\n", f.params.lobes.size(), f.params.lobes.size() == 1 ? "" : "s");
  s += fmt::format("  kd                [{:.5g}, {:.5g}, {:.5g}] +- [{:.2g}, {:.2g}, {:.2g}]\n", f.params.kd[0],
                   f.params.kd[1], f.params.kd[2], f.stddev.kd[0], f.stddev.kd[1], f.stddev.kd[2]);
  for (std::size_t l = 0; l < f.params.lobes.size(); ++l) {
    const brdf::CtLobe& p = f.params.lobes[l];
    const brdf::CtLobe& e = f.stddev.lobes[l];
    s += fmt::format("  lobe {}            ks [{:.5g}, {:.5g}, {:.5g}]  m {:.5g} +- {:.2g}  r {:.4g} +- {:.2g}\n", l + 1,
                     p.ks[0], p.ks[1], p.ks[2], p.m, e.m, p.r, e.r);
  }
  s += region_lines(f.residual);
  if (std::isfinite(f.residual.sparkle_excess) && f.residual.sparkle_excess > kSparkleDrawNote)
    s += "  note              the session sparkles: the +- count the samples as independent, but a flake lobe's\n"
         "                    split into ks and r rests on the few flakes lit near grazing (theta_d > 65 deg) and\n"
         "                    differs more between panels of a paint; sessions of other spheres or orientations\n"
         "                    fitted together (`paintlab fit S1 S2 ...`) average more flakes (docs/fitting.md\n"
         "                    \"Sparkle\")\n";
  s += fmt::format("  solver            {} iterations, {} residual blocks, cost {:.6g} -> {:.6g}, {:.2f} s, {} starts\n",
                   f.summary.iterations, f.summary.residual_blocks, f.summary.initial_cost, f.summary.final_cost,
                   f.summary.time_s, f.summary.starts.size());
  return s;
}

std::string axf_report(const AxfFit& f) {
  const auto& p = f.params;
  std::string s = fmt::format("axf-carpaint, {} lobe{}\n", p.lobes.size(), p.lobes.size() == 1 ? "" : "s");
  s += fmt::format("  clear-coat ior    {:.4f} +- {:.2g}\n  diffuse           {:.5g} +- {:.2g}\n", p.ior, f.stddev.ior,
                   p.diffuse, f.stddev.diffuse);
  for (std::size_t k = 0; k < p.lobes.size(); ++k)
    s += fmt::format("  lobe {}            coefficient {:.5g} +- {:.2g}  spread {:.5g} +- {:.2g}  F0 {:.3g}{}\n", k + 1,
                     p.lobes[k].coefficient, f.stddev.lobes[k].coefficient, p.lobes[k].spread,
                     f.stddev.lobes[k].spread, p.lobes[k].f0, std::isfinite(f.stddev.lobes[k].f0) &&
                     f.stddev.lobes[k].f0 > 0 ? "" : " (held)");
  s += fmt::format("  colour table      {} x {} (theta_hbar x theta_ibar): {} texels measured, {} filled\n",
                   p.chi.theta_h_samples, p.chi.theta_i_samples, f.chi.measured_texels, f.chi.filled_texels);
  s += fmt::format("  achromatic log-RMS {:.4f}\n", f.achromatic.total.log_rms);
  s += region_lines(f.residual);
  s += fmt::format("  solver            {} iterations, {} residual blocks, cost {:.6g} -> {:.6g}, {:.2f} s, {} starts\n",
                   f.summary.iterations, f.summary.residual_blocks, f.summary.initial_cost, f.summary.final_cost,
                   f.summary.time_s, f.summary.starts.size());
  return s;
}

// The outcome's convergence, and a report line when the solver stopped before converging.
void set_termination(FitOutcome& out, const FitSummary& s) {
  out.converged = s.converged;
  out.termination = fmt::format("{} ({} iterations)", s.termination, s.iterations);
  if (!s.converged)
    out.report += fmt::format("  NOT CONVERGED     {}: the parameters are the solver's last\n", out.termination);
}

}  // namespace

FitOutcome fit_table(const brdf::MerlTable& table, const std::vector<float>* noise_variance, const FitRequest& request,
                     const Json& input) {
  FitOutcome out;
  auto run = [&](auto options, auto fit, auto report) {
    options.data.sessions = sessions_in(input);
    const FitData data = prepare_fit_data(table, options.data, noise_variance);
    const auto f = fit(data, options);
    out.fit = f.to_json(request.name);
    out.report = report(f);
    set_termination(out, f.summary);
  };
  switch (request.model) {
    case FitModel::CookTorrance:
      run(request.cook_torrance, fit_cook_torrance, ct_report);
      break;
    case FitModel::AxfCarPaint:
      run(request.axf_carpaint, fit_axf_carpaint, axf_report);
      break;
  }
  Json in = input;
  in["coverage"] = coverage(table).to_json();
  out.fit["input"] = in;
  return out;
}

FitOutcome fit_sites(const SiteTables& sites, const FitRequest& request, const Json& input) {
  if (request.model != FitModel::CookTorrance)
    throw DataError(fmt::format("a fit at the filter-array sites is a cook-torrance fit; the {} model's colour table "
                                "is fitted in the session's colour space (fit without the sites)",
                                to_string(request.model)));
  const CtFitOptions& options = request.cook_torrance;
  // Auto pooling decided once for the three tables (each looked at in its own colour): the
  // sites of one camera see the same flakes.
  FitDataOptions site_data = options.data;
  site_data.sessions = sessions_in(input);
  double excess = NAN;
  if (site_data.min_samples == 0) {
    for (std::size_t c = 0; c < 3; ++c) {
      const BinnedTable& t = sites.tables[c];
      const double e = sparkle_excess(t.table, t.noise_variance.empty() ? nullptr : &t.noise_variance, static_cast<int>(c));
      if (std::isfinite(e) && !(e <= excess)) excess = e;
    }
    site_data.min_samples = auto_pooling(excess, site_data.sessions);
  }
  std::array<FitData, 3> per_site;
  for (std::size_t c = 0; c < 3; ++c) {
    const BinnedTable& t = sites.tables[c];
    try {
      per_site[c] = prepare_fit_data(t.table, site_data, t.noise_variance.empty() ? nullptr : &t.noise_variance);
      per_site[c].sparkle_excess = excess;
    } catch (const DataError& e) {
      throw DataError(fmt::format("the {} sites: {}", std::array<const char*, 3>{"red", "green", "blue"}[c], e.what()));
    }
  }
  const FitData data = combine_site_data(std::move(per_site));
  const CookTorranceFit camera = fit_cook_torrance(data, options);
  int clipped = 0;
  const CookTorranceFit f = transform_colours(camera, sites.to_colour_space, &clipped);
  FitOutcome out;
  out.fit = f.to_json(request.name);
  out.report = ct_report(f);
  out.report += fmt::format("  colour            fitted at the filter-array sites in camera RGB (R {}, G {}, B {} fit "
                            "points; residuals above in camera RGB), kd and ks mapped to the session's colour space{}\n",
                            std::count_if(data.bins.begin(), data.bins.end(), [](const FitBin& b) { return b.inv_sigma[0] != 0.0; }),
                            std::count_if(data.bins.begin(), data.bins.end(), [](const FitBin& b) { return b.inv_sigma[1] != 0.0; }),
                            std::count_if(data.bins.begin(), data.bins.end(), [](const FitBin& b) { return b.inv_sigma[2] != 0.0; }),
                            clipped > 0 ? fmt::format(" ({} negative value{} outside its gamut set to 0)", clipped,
                                                      clipped == 1 ? "" : "s")
                                        : std::string());
  set_termination(out, f.summary);
  Json in = input;
  in["coverage"] = coverage(sites.tables[1].table).to_json();  // the greens: half the pixels
  Json camera_fit = brdf::to_json(brdf::PaintSpec{request.name, camera.params, std::nullopt, {}});
  in["camera_rgb_fit"] = {{"kd", camera_fit["kd"]}, {"lobes", camera_fit["lobes"]}};
  out.fit["input"] = in;
  return out;
}

}  // namespace paintlab::fit
