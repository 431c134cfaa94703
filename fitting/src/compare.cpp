#include "paintlab/fitting/compare.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "paintlab/brdf/rusinkiewicz.h"
#include "paintlab/core/error.h"
#include "paintlab/core/geometry.h"

namespace paintlab::fit {

namespace {

// The values of a number or an array of numbers ("-" otherwise), and their relative errors.
std::string values(const Json& v, const char* format) {
  if (v.is_number()) return fmt::format(fmt::runtime(format), v.get<double>());
  if (!v.is_array()) return "-";
  std::string s;
  for (const auto& x : v) s += (s.empty() ? "" : " ") + (x.is_number() ? fmt::format(fmt::runtime(format), x.get<double>()) : "-");
  return s;
}

std::string errors(const Json& truth, const Json& fit) {
  auto one = [](const Json& t, const Json& f) -> std::string {
    if (!t.is_number() || !f.is_number() || t.get<double>() == 0.0) return "-";
    return fmt::format("{:+.1f}", 100.0 * (f.get<double>() / t.get<double>() - 1.0));
  };
  if (truth.is_number()) return one(truth, fit) + " %";
  if (!truth.is_array() || !fit.is_array() || truth.size() != fit.size()) return "-";
  std::string s;
  for (std::size_t c = 0; c < truth.size(); ++c) s += (c ? " " : "") + one(truth[c], fit[c]);
  return s + " %";
}

Json lobe_value(const Json& paint, std::size_t lobe, const char* key) {
  if (!paint.contains("lobes") || !paint["lobes"].is_array() || lobe >= paint["lobes"].size()) return Json();
  return paint["lobes"][lobe].value(key, Json());
}

}  // namespace

std::string compare_table(const Json& truth, const Json& fit, const Json& stddev) {
  std::string s = fmt::format("{:<11} {:<22} {:<22} {:<22} {}\n", "parameter", "truth", "fit", "std dev", "error");
  auto line = [&](const std::string& name, const Json& t, const Json& f, const Json& sd) {
    s += fmt::format("{:<11} {:<22} {:<22} {:<22} {}\n", name, values(t, "{:.4f}"), values(f, "{:.4f}"),
                     values(sd, "{:.2g}"), errors(t, f));
  };
  const Json none = Json::object();
  const Json& sd = stddev.is_object() ? stddev : none;
  line("kd", truth.value("kd", Json()), fit.value("kd", Json()), sd.value("kd", Json()));
  const std::size_t nt = truth.contains("lobes") ? truth["lobes"].size() : 0;
  const std::size_t nf = fit.contains("lobes") ? fit["lobes"].size() : 0;
  for (std::size_t l = 0; l < std::max(nt, nf); ++l)
    for (const char* k : {"ks", "m", "r"})
      line(fmt::format("lobe {} {}", l + 1, k), lobe_value(truth, l, k), lobe_value(fit, l, k), lobe_value(sd, l, k));
  return s;
}

}  // namespace paintlab::fit

namespace paintlab::fit {

std::vector<GrazingBand> compare_by_grazing_band(const brdf::MerlTable& measured, const brdf::Brdf& paint,
                                                 std::vector<double> edges_deg) {
  if (edges_deg.size() < 2 || edges_deg.front() < 0.0 || edges_deg.back() > 90.0 ||
      !std::is_sorted(edges_deg.begin(), edges_deg.end()) ||
      std::adjacent_find(edges_deg.begin(), edges_deg.end()) != edges_deg.end())
    throw DataError("grazing bands: the edges must increase within [0, 90] deg");
  const std::size_t n = edges_deg.size() - 1;
  std::vector<std::vector<double>> ratios(n);
  std::vector<GrazingBand> bands(n);
  for (std::size_t k = 0; k < n; ++k) {
    bands[k].lo_deg = edges_deg[k];
    bands[k].hi_deg = edges_deg[k + 1];
  }
  for (std::size_t b = 0; b < brdf::kMerlBins; ++b) {
    if (measured.state(b) != brdf::BinState::Measured) continue;
    const Eigen::Vector3d c = measured.mean_coords(b);
    const brdf::DirectionPair d = brdf::directions_from_half_diff({c[0], 0.0, c[1], c[2]});
    const double worst = rad_to_deg(std::acos(std::clamp(std::min(d.wi.z(), d.wo.z()), -1.0, 1.0)));
    const auto it = std::upper_bound(edges_deg.begin(), edges_deg.end(), worst);
    if (it == edges_deg.begin()) continue;
    const std::size_t k = std::min(n - 1, static_cast<std::size_t>(it - edges_deg.begin()) - 1);
    if (worst > edges_deg.back()) continue;
    const brdf::Rgb f = paint.eval(d.wi, d.wo), v = measured.value(b);
    if (!(f.minCoeff() > 0.0) || !(v.minCoeff() > 0.0)) {
      ++bands[k].non_positive;
      continue;
    }
    ++bands[k].bins;
    for (int ch = 0; ch < 3; ++ch) ratios[k].push_back(std::log(v[ch] / f[ch]));
  }
  for (std::size_t k = 0; k < n; ++k) {
    std::vector<double>& r = ratios[k];
    if (r.empty()) continue;
    double s2 = 0.0;
    for (double x : r) s2 += x * x;
    bands[k].rms = std::sqrt(s2 / static_cast<double>(r.size()));
    std::sort(r.begin(), r.end());
    auto quantile = [&](double q) { return r[static_cast<std::size_t>(std::lround(q * static_cast<double>(r.size() - 1)))]; };
    bands[k].median = quantile(0.5);
    bands[k].p05 = quantile(0.05);
    bands[k].p95 = quantile(0.95);
  }
  return bands;
}

std::string grazing_band_table(const std::vector<GrazingBand>& bands) {
  std::string s = "measured against the paint by max(theta_i, theta_o) (log ratio, channels pooled):\n";
  for (const GrazingBand& b : bands)
    s += fmt::format("  {:>4.0f}-{:<3.0f} deg  {:>8} bins  RMS {:.3f}  median {:+.4f}  5 % {:+.3f}  95 % {:+.3f}{}\n",
                     b.lo_deg, b.hi_deg, b.bins, b.rms, b.median, b.p05, b.p95,
                     b.non_positive ? fmt::format("  ({} bins <= 0 left out)", b.non_positive) : std::string());
  return s;
}

Json grazing_band_json(const std::vector<GrazingBand>& bands) {
  Json a = Json::array();
  for (const GrazingBand& b : bands)
    a.push_back({{"max_theta_deg", {b.lo_deg, b.hi_deg}},
                 {"bins", b.bins},
                 {"non_positive", b.non_positive},
                 {"log_ratio_rms", b.rms},
                 {"log_ratio_median", b.median},
                 {"log_ratio_p05", b.p05},
                 {"log_ratio_p95", b.p95}});
  return a;
}

}  // namespace paintlab::fit
