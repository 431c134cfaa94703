#include "paintlab/fitting/compare.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

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
