#include "paintlab/calibration/response.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <tbb/blocked_range.h>
#include <tbb/combinable.h>
#include <tbb/parallel_for.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <memory>
#include <numeric>

#include "paintlab/calibration/dark.h"
#include "paintlab/core/enum_names.h"
#include "paintlab/core/error.h"
#include "paintlab/core/robust.h"
#include "paintlab/core/line_fit.h"

namespace paintlab::calib {

// ---------------------------------------------------------------------------------------------
// Names, noise, weights

constexpr EnumNames<Weighting, 3> kWeightingNames{{{Weighting::Robertson, "robertson"},
                                                   {Weighting::Hat, "hat"},
                                                   {Weighting::InverseVariance, "inverse-variance"}}};
constexpr EnumNames<ResponseMethod, 2> kResponseMethodNames{
    {{ResponseMethod::Robertson, "robertson"}, {ResponseMethod::Debevec, "debevec"}}};

std::vector<std::uint16_t> parse_no_data(const std::string& text, std::string_view flag) {
  std::vector<std::uint16_t> out;
  if (text.empty()) return out;
  std::size_t start = 0;
  while (true) {
    const auto comma = text.find(',', start);
    const std::string item = text.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
    char* end = nullptr;
    const long v = std::strtol(item.c_str(), &end, 10);
    if (item.empty() || end != item.c_str() + item.size() || v < 0 || v > 65535)
      throw UsageError(fmt::format("{}: '{}' is not a value 0..65535 (give R,G,B or one value)", flag, item));
    out.push_back(static_cast<std::uint16_t>(v));
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  if (out.size() != 1 && out.size() != 3) throw UsageError(fmt::format("{}: give one value (mono) or R,G,B", flag));
  return out;
}

const char* to_string(Weighting w) { return enum_name(kWeightingNames, w); }

Weighting weighting_from_string(const std::string& s, std::string_view where) {
  return enum_from_name(kWeightingNames, s, "weighting", where);
}

const char* to_string(ResponseMethod m) { return enum_name(kResponseMethodNames, m); }

ResponseMethod response_method_from_string(const std::string& s, std::string_view where) {
  return enum_from_name(kResponseMethodNames, s, "response method", where);
}

double NoiseModel::variance_dn2(double u) const {
  return std::max(read_noise_dn * read_noise_dn, 1.0 / 12.0) + gain_dn_per_e * std::max(u, 0.0);
}

Json NoiseModel::to_json() const {
  return {{"read_noise_dn", read_noise_dn}, {"gain_dn_per_e", gain_dn_per_e}, {"source", source}};
}

NoiseModel NoiseModel::from_json(const Json& j, const std::string& where) {
  NoiseModel n;
  n.read_noise_dn = json_get<double>(j, "read_noise_dn", where);
  n.gain_dn_per_e = json_get<double>(j, "gain_dn_per_e", where);
  n.source = json_get_or<std::string>(j, "source", "", where);
  if (!(n.read_noise_dn >= 0.0) || !(n.gain_dn_per_e >= 0.0))
    throw DataError(where + ": noise: read_noise_dn and gain_dn_per_e must be >= 0");
  return n;
}

double certainty(Weighting w, double u, const ValueWindow& window) {
  const double span = window.u_saturation() - window.floor_dn;
  if (span <= 0.0) return 0.0;
  const double x = (u - window.floor_dn) / span;
  if (!(x > 0.0 && x < 1.0)) return 0.0;
  switch (w) {
    case Weighting::Robertson:
    case Weighting::InverseVariance: {
      // exp(-(4x-2)^2) shifted and scaled to 1 at the centre and 0 at both ends.
      const double e4 = std::exp(4.0);
      const double v = 4.0 * x - 2.0;
      return std::max(0.0, (e4 * std::exp(-v * v) - 1.0) / (e4 - 1.0));
    }
    case Weighting::Hat:
      return 1.0 - std::abs(2.0 * x - 1.0);
  }
  return 0.0;
}

// ---------------------------------------------------------------------------------------------
// The curve

namespace {

struct KnotGrid {
  double u0 = 0.0;
  double step = 1.0;
  int count = 2;

  // Segment k (0..count-2) and position f within it (outside [0,1] beyond the ends).
  void locate(double u, int* k, double* f) const {
    const double x = (u - u0) / step;
    int i = static_cast<int>(std::floor(x));
    i = std::clamp(i, 0, count - 2);
    *k = i;
    *f = x - i;
  }
  double knot(int k) const { return u0 + step * k; }
};

KnotGrid grid_of(const std::vector<double>& knots) {
  KnotGrid g;
  g.u0 = knots.front();
  g.count = static_cast<int>(knots.size());
  g.step = (knots.back() - knots.front()) / (g.count - 1);
  return g;
}

}  // namespace

double ResponseCurve::to_linear(int channel, double u) const {
  const KnotGrid g = grid_of(knots_dn);
  int k = 0;
  double f = 0.0;
  g.locate(u, &k, &f);
  const auto& v = linear[static_cast<std::size_t>(channel)];
  return v[k] + f * (v[k + 1] - v[k]);
}

double ResponseCurve::slope(int channel, double u) const {
  const KnotGrid g = grid_of(knots_dn);
  int k = 0;
  double f = 0.0;
  g.locate(u, &k, &f);
  const auto& v = linear[static_cast<std::size_t>(channel)];
  return (v[k + 1] - v[k]) / g.step;
}

double ResponseCurve::variance(int channel, double u) const {
  if (!residual_std.empty()) {
    const KnotGrid g = grid_of(knots_dn);
    int k = 0;
    double f = 0.0;
    g.locate(u, &k, &f);
    f = std::clamp(f, 0.0, 1.0);
    const auto& sd = residual_std[static_cast<std::size_t>(channel)];
    const double v = sd[k] + f * (sd[k + 1] - sd[k]);
    return v * v;
  }
  if (!noise.known()) return 0.0;
  const double s = slope(channel, u);
  return s * s * noise.variance_dn2(u);
}

ResponseCurve ResponseCurve::identity(int bit_depth, int channels, const ValueWindow& window) {
  ResponseCurve r;
  r.bit_depth = bit_depth;
  r.channels = channels;
  r.window = window;
  const double top = std::ldexp(1.0, bit_depth) - 1.0;
  r.knots_dn = {-window.black_dn, top - window.black_dn};
  r.linear.assign(static_cast<std::size_t>(channels), r.knots_dn);
  r.report.nonlinearity_rel.assign(static_cast<std::size_t>(channels), 0.0);
  r.report.monotonic_violation_rel.assign(static_cast<std::size_t>(channels), 0.0);
  return r;
}

Json ResponseCurve::to_json() const {
  Json report_json = {{"samples_used", report.samples_used},
                      {"linearity_error_rel", report.linearity_error_rel},
                      {"linearity_rms_rel", report.linearity_rms_rel},
                      {"nonlinearity_rel", report.nonlinearity_rel},
                      {"monotonic_violation_rel", report.monotonic_violation_rel},
                      {"exposure_ratio", report.exposure_ratio}};
  return {{"provenance", provenance.to_json()},
          {"method", to_string(method)},
          {"weighting", to_string(weighting)},
          {"bit_depth", bit_depth},
          {"channels", channels},
          {"black_dn", window.black_dn},
          {"saturation_dn", window.saturation_dn},
          {"floor_dn", window.floor_dn},
          {"dark_subtracted", dark_subtracted},
          {"units", "linear: g(u), u = raw - dark (DN); scaled to least-squares slope 1 against u over the used range"},
          {"knots_dn", knots_dn},
          {"linear", linear},
          {"residual_std", residual_std},
          {"noise", noise.to_json()},
          {"fit", report_json}};
}

ResponseCurve ResponseCurve::from_json(const Json& j, const std::string& where) {
  ResponseCurve r;
  if (j.contains("provenance")) r.provenance = Provenance::from_json(j.at("provenance"), where);
  r.method = response_method_from_string(json_get<std::string>(j, "method", where), where + ": key 'method'");
  r.weighting = weighting_from_string(json_get<std::string>(j, "weighting", where), where + ": key 'weighting'");
  r.bit_depth = json_get<int>(j, "bit_depth", where);
  r.channels = json_get<int>(j, "channels", where);
  r.window.black_dn = json_get<double>(j, "black_dn", where);
  r.window.saturation_dn = json_get<double>(j, "saturation_dn", where);
  r.window.floor_dn = json_get<double>(j, "floor_dn", where);
  r.dark_subtracted = json_get<bool>(j, "dark_subtracted", where);
  r.knots_dn = json_get<std::vector<double>>(j, "knots_dn", where);
  r.linear = json_get<std::vector<std::vector<double>>>(j, "linear", where);
  if (r.bit_depth < 1 || r.bit_depth > 16) throw DataError(where + ": bit_depth must be 1..16");
  if (r.channels != 1 && r.channels != 3) throw DataError(where + ": channels must be 1 or 3");
  if (r.knots_dn.size() < 2) throw DataError(where + ": knots_dn needs at least 2 knots");
  const double step = (r.knots_dn.back() - r.knots_dn.front()) / static_cast<double>(r.knots_dn.size() - 1);
  if (!(step > 0.0)) throw DataError(where + ": knots_dn must ascend");
  for (std::size_t k = 0; k < r.knots_dn.size(); ++k)
    if (std::abs(r.knots_dn[k] - (r.knots_dn.front() + step * static_cast<double>(k))) > 1e-6 * std::max(1.0, step))
      throw DataError(fmt::format("{}: knots_dn must be uniformly spaced (knot {} is off)", where, k));
  if (r.linear.size() != static_cast<std::size_t>(r.channels))
    throw DataError(fmt::format("{}: linear has {} curves for {} channels", where, r.linear.size(), r.channels));
  for (const auto& v : r.linear) {
    if (v.size() != r.knots_dn.size())
      throw DataError(fmt::format("{}: linear has {} values for {} knots", where, v.size(), r.knots_dn.size()));
    for (double x : v)
      if (!std::isfinite(x)) throw DataError(where + ": linear holds a value that is not finite");
  }
  if (!(r.window.saturation_dn > r.window.floor_dn + r.window.black_dn))
    throw DataError(where + ": saturation_dn must lie above floor_dn + black_dn");
  if (j.contains("residual_std")) {
    r.residual_std = json_get<std::vector<std::vector<double>>>(j, "residual_std", where);
    if (!r.residual_std.empty()) {
      if (r.residual_std.size() != r.linear.size())
        throw DataError(where + ": residual_std needs one list per channel");
      for (const auto& v : r.residual_std) {
        if (v.size() != r.knots_dn.size()) throw DataError(where + ": residual_std needs one value per knot");
        for (double x : v)
          if (!(x >= 0.0) || !std::isfinite(x)) throw DataError(where + ": residual_std values must be finite and >= 0");
      }
    }
  }
  if (j.contains("noise")) r.noise = NoiseModel::from_json(j.at("noise"), where);
  if (j.contains("fit")) {
    const Json& f = j.at("fit");
    r.report.samples_used = json_get_or<long long>(f, "samples_used", 0, where);
    r.report.linearity_error_rel = json_get_or<double>(f, "linearity_error_rel", 0.0, where);
    r.report.nonlinearity_rel = json_get_or<std::vector<double>>(f, "nonlinearity_rel", {}, where);
    r.report.linearity_rms_rel = json_get_or<double>(f, "linearity_rms_rel", 0.0, where);
    r.report.monotonic_violation_rel =
        json_get_or<std::vector<double>>(f, "monotonic_violation_rel", {}, where);
    if (f.contains("exposure_ratio")) {
      if (!f.at("exposure_ratio").is_array()) throw DataError(where + ": fit.exposure_ratio must be an array");
      for (const Json& v : f.at("exposure_ratio"))  // null: no well-exposed sample in that image
        r.report.exposure_ratio.push_back(v.is_number() ? v.get<double>() : std::numeric_limits<double>::quiet_NaN());
    }
  }
  return r;
}

void ResponseCurve::save(const std::filesystem::path& path) const { write_json_file(path, to_json()); }

ResponseCurve ResponseCurve::load(const std::filesystem::path& path) {
  return from_json(read_json_file(path), path.string());
}

void ResponseOptions::check() const {
  if (max_knots < 4) throw UsageError(fmt::format("response: max_knots = {}; must be >= 4", max_knots));
  if (!std::isfinite(smoothness)) throw UsageError("response: smoothness must be finite");
  if (max_knots > 4096) throw UsageError(fmt::format("response: max_knots = {}; must be <= 4096", max_knots));
  if (!std::isfinite(black_dn)) throw UsageError("response: black_dn must be finite");
  if (!use_method_weighting && weighting == Weighting::InverseVariance)
    throw UsageError("response: inverse-variance weighting needs a response; use robertson or hat to recover one");
  if (!no_data.empty() && no_data.size() != 1 && no_data.size() != 3)
    throw UsageError(fmt::format("response: no_data has {} values; give one per channel (1 or 3)", no_data.size()));
}

// ---------------------------------------------------------------------------------------------
// Recovery

namespace {

// What one sample contributes: segment k, position f in it, weight w (0 = unused).
struct SampleInfo {
  int k;
  float f;
  float w;
};

constexpr std::size_t kBlockPixels = 2048;

class Solver {
 public:
  Solver(std::span<const StackFrame> frames, int bit_depth, const ResponseOptions& opt, const DarkFrame* dark)
      : frames_(frames), bit_depth_(bit_depth), opt_(opt), dark_(dark) {
    const auto& first = *frames[0].pixels;
    channels_ = first.channels();
    pixels_ = first.pixel_count();
    samples_ = pixels_ * static_cast<std::size_t>(channels_);
    method_ = opt.method;
    weighting_ = opt.use_method_weighting
                     ? (opt.method == ResponseMethod::Robertson ? Weighting::Robertson : Weighting::Hat)
                     : opt.weighting;
  }

  ResponseCurve run();

 private:
  void choose_window();
  void build_nodata();
  void build_grid();
  SampleInfo info(std::size_t j, std::size_t p, std::size_t s, std::uint16_t z) const {
    if (!dark_) return code_table_[z];
    return info_dark(j, p, s, z);
  }
  SampleInfo info_dark(std::size_t j, std::size_t p, std::size_t s, std::uint16_t z) const;
  // Calls f(j, c, s, si) for every sample of pixels [p0, p1) with nonzero weight, frame by frame.
  template <class F>
  void visit(std::size_t p0, std::size_t p1, F&& f) const {
    const int C = channels_;
    for (std::size_t j = 0; j < frames_.size(); ++j) {
      const std::uint16_t* px = frames_[j].pixels->data();
      const std::uint8_t* nd = nodata_.empty() ? nullptr : nodata_[j].data();
      if (!dark_ && C == 1) {
        for (std::size_t p = p0; p < p1; ++p) {
          const SampleInfo& si = code_table_[px[p]];
          if (si.w > 0.0f && !(nd && nd[p])) f(j, 0, p, si);
        }
        continue;
      }
      if (!dark_ && C == 3) {
        for (std::size_t p = p0; p < p1; ++p) {
          if (nd && nd[p]) continue;
          for (int c = 0; c < 3; ++c) {
            const std::size_t s = p * 3 + c;
            const SampleInfo& si = code_table_[px[s]];
            if (si.w > 0.0f) f(j, c, s, si);
          }
        }
        continue;
      }
      for (std::size_t p = p0; p < p1; ++p) {
        if (nd && nd[p]) continue;
        for (int c = 0; c < C; ++c) {
          const std::size_t s = p * C + c;
          const SampleInfo si = info_dark(j, p, s, px[s]);
          if (si.w > 0.0f) f(j, c, s, si);
        }
      }
    }
  }
  // Estimates of pixels [p0, p1) from the current curve: E (Robertson, linear curve) or
  // ln E (Debevec, log curve); NaN where no sample has weight.
  void estimate(std::size_t p0, std::size_t p1, bool log_domain, std::vector<double>* e) const;
  double value(int c, int k, float f) const {
    const auto& g = g_[static_cast<std::size_t>(c)];
    return g[k] + f * (g[k + 1] - g[k]);
  }
  void solve_direct(bool robertson);
  void finish(ResponseCurve* out);
  void residual_statistics(ResponseCurve* out);

  std::span<const StackFrame> frames_;
  int bit_depth_;
  ResponseOptions opt_;
  const DarkFrame* dark_;
  ResponseMethod method_;
  Weighting weighting_;
  int channels_ = 1;
  std::size_t pixels_ = 0, samples_ = 0;

  ValueWindow window_;
  KnotGrid grid_;
  std::vector<SampleInfo> code_table_;               // by raw value, when there is no dark map
  std::vector<float> certainty_table_;               // by integer u - u_lo, with a dark map
  double u_lo_ = 0.0;
  std::vector<std::vector<std::uint8_t>> nodata_;    // [frame][pixel]
  std::vector<std::vector<double>> g_;               // [channel][knot]; ln g for Debevec
  std::vector<std::vector<double>> diag_;            // [channel][knot]: data weight of the knot
  std::vector<double> log_t_;
  int ref_knot_ = 0;
};

void Solver::choose_window() {
  const std::uint32_t top = (1u << bit_depth_) - 1u;
  double saturation = opt_.saturation_dn;
  if (saturation < 0.0) {
    // The largest value present; when a noticeable share of all values sits exactly there
    // (a pile-up), the sensor or ADC clips at that level.
    std::vector<long long> hist(top + 1, 0);
    for (const auto& fr : frames_)
      for (std::uint16_t v : fr.pixels->values()) ++hist[v];
    std::uint32_t vmax = top;
    while (vmax > 0 && hist[vmax] == 0) --vmax;
    const long long total = static_cast<long long>(samples_ * frames_.size());
    const bool pile = hist[vmax] >= std::max<long long>(10, total / 10000);
    const double level = pile ? vmax : top;
    const double margin = bit_depth_ > 8 ? std::ldexp(1.0, bit_depth_ - 8) : 0.0;
    saturation = level - margin;
  }
  window_.saturation_dn = saturation;
  window_.black_dn = dark_ ? dark_->mean_bias_dn : opt_.black_dn;
  if (opt_.floor_dn >= 0.0) {
    window_.floor_dn = opt_.floor_dn;
  } else {
    window_.floor_dn = (dark_ && dark_->read_noise_measured) ? 3.0 * dark_->read_noise_dn : 0.0;
  }
  if (!(window_.u_saturation() > window_.floor_dn + 2.0))
    throw CalibrationError(fmt::format(
        "response: no usable range: saturation at {} DN, black level {} DN, noise floor {} DN", window_.saturation_dn,
        window_.black_dn, window_.floor_dn));
}

void Solver::build_nodata() {
  if (opt_.no_data.empty()) return;
  if (static_cast<int>(opt_.no_data.size()) != channels_)
    throw UsageError(fmt::format("response: the no-data colour has {} values, the images {} channels",
                                 opt_.no_data.size(), channels_));
  nodata_.resize(frames_.size());
  for (std::size_t j = 0; j < frames_.size(); ++j) {
    const auto* px = frames_[j].pixels->data();
    auto& m = nodata_[j];
    m.assign(pixels_, 0);
    for (std::size_t p = 0; p < pixels_; ++p) {
      bool all = true;
      for (int c = 0; c < channels_; ++c) all = all && px[p * channels_ + c] == opt_.no_data[c];
      m[p] = all ? 1 : 0;
    }
  }
}

void Solver::build_grid() {
  const double top = std::ldexp(1.0, bit_depth_) - 1.0;
  double u_min = -window_.black_dn;
  double u_max = top - window_.black_dn;
  if (dark_) {
    float lo = std::numeric_limits<float>::max();
    float hi = std::numeric_limits<float>::lowest();
    for (const auto& fr : frames_)
      for (std::size_t s = 0; s < samples_; ++s) {
        const float d = dark_->level(s, fr.exposure_s);
        lo = std::min(lo, d);
        hi = std::max(hi, d);
      }
    u_min = -hi;
    u_max = top - lo;
  }
  u_min = std::floor(u_min);
  u_max = std::ceil(u_max);
  const double range = u_max - u_min;
  const int max_knots = bit_depth_ <= 8 ? static_cast<int>(range) + 1 : opt_.max_knots;
  grid_.u0 = u_min;
  grid_.step = std::max(1.0, std::ceil(range / (max_knots - 1)));
  grid_.count = std::max(2, static_cast<int>(std::ceil(range / grid_.step)) + 1);

  if (!dark_) {
    code_table_.resize(static_cast<std::size_t>(top) + 1);
    for (std::size_t z = 0; z < code_table_.size(); ++z) {
      const double u = static_cast<double>(z) - window_.black_dn;
      SampleInfo si{};
      double f = 0.0;
      grid_.locate(u, &si.k, &f);
      si.f = static_cast<float>(f);
      si.w = static_cast<double>(z) >= window_.saturation_dn ? 0.0f
                                                              : static_cast<float>(certainty(weighting_, u, window_));
      code_table_[z] = si;
    }
  } else {
    u_lo_ = u_min;
    certainty_table_.resize(static_cast<std::size_t>(range) + 2);
    for (std::size_t i = 0; i < certainty_table_.size(); ++i)
      certainty_table_[i] = static_cast<float>(certainty(weighting_, u_lo_ + static_cast<double>(i), window_));
  }
  // The reference knot: nearest the middle of the usable range.
  const double mid = 0.5 * (window_.floor_dn + window_.u_saturation());
  ref_knot_ = std::clamp(static_cast<int>(std::lround((mid - grid_.u0) / grid_.step)), 1, grid_.count - 2);
}

SampleInfo Solver::info_dark(std::size_t j, std::size_t p, std::size_t s, std::uint16_t z) const {
  const double u = static_cast<double>(z) - dark_->level(s, frames_[j].exposure_s);
  SampleInfo si{};
  double f = 0.0;
  grid_.locate(u, &si.k, &f);
  si.f = static_cast<float>(f);
  if (static_cast<double>(z) >= window_.saturation_dn || dark_->hot.data()[p]) {
    si.w = 0.0f;
  } else {
    const long i = std::clamp(std::lround(u - u_lo_), 0L, static_cast<long>(certainty_table_.size()) - 1);
    si.w = certainty_table_[static_cast<std::size_t>(i)];
  }
  return si;
}

void Solver::estimate(std::size_t p0, std::size_t p1, bool log_domain, std::vector<double>* e) const {
  const std::size_t base = p0 * channels_;
  const std::size_t n = (p1 - p0) * channels_;
  std::vector<double> num(n, 0.0), den(n, 0.0);
  visit(p0, p1, [&](std::size_t j, int c, std::size_t s, const SampleInfo& si) {
    const double y = value(c, si.k, si.f);
    const double t = frames_[j].exposure_s;
    const std::size_t i = s - base;
    if (log_domain) {
      num[i] += si.w * (y - log_t_[j]);
      den[i] += si.w;
    } else {
      num[i] += si.w * t * y;
      den[i] += si.w * t * t;
    }
  });
  e->resize(n);
  for (std::size_t i = 0; i < n; ++i)
    (*e)[i] = den[i] > 0.0 ? num[i] / den[i] : std::numeric_limits<double>::quiet_NaN();
}


// ---- Robertson's curve under a log-log curvature prior (docs/research/hdr-sparse-brackets.md) ----
//
// When every exposure ratio is a whole power of one step k, the data fix g only up to a ripple
// periodic in ln g with period ln k (Grossberg and Nayar 2003), and on sparse brackets the noise
// picks a staircase among them. The prior that decides is the curvature of ln g against ln u,
// zero for every power law (which camera curves are close to). Brackets whose ratios share no
// such step (mixed ratios) fix the curve themselves and get no prior.

// The weight of the prior relative to the data's misfit at the unconstrained curve.
constexpr double kLogLogPriorWeight = 0.1;
// Steps below this ratio leave ripples the second-difference penalty already removes.
constexpr double kMinAmbiguousStep = 0.2231;  // ln 1.25

// The largest step s >= ln 1.25 such that every ln(t_j / t_min) is a whole multiple of s
// (within 5 % of s), or 0 when there is none.
double common_log_step(std::span<const StackFrame> frames) {
  std::vector<double> lt;
  for (const auto& f : frames)
    if (f.exposure_s > 0.0) lt.push_back(std::log(f.exposure_s));
  std::sort(lt.begin(), lt.end());
  lt.erase(std::unique(lt.begin(), lt.end(), [](double a, double b) { return b - a < 1e-3; }), lt.end());
  if (lt.size() < 2) return 0.0;
  double best = 0.0;
  for (std::size_t i = 1; i < lt.size(); ++i)
    for (int n = 1; n <= 4; ++n) {
      const double step = (lt[i] - lt[i - 1]) / n;
      if (step < kMinAmbiguousStep || step <= best) continue;
      const bool whole = std::all_of(lt.begin(), lt.end(), [&](double v) {
        const double q = (v - lt.front()) / step;
        return std::abs(q - std::round(q)) <= 0.05;
      });
      if (whole) best = step;
    }
  return best;
}

// g at every knot from the knots from k_lo up: below k_lo, g(u) = g(u_lo) u / u_lo.
Eigen::MatrixXd lower_extension(const KnotGrid& grid, int k_lo) {
  const int K = grid.count, Ks = K - k_lo;
  Eigen::MatrixXd T = Eigen::MatrixXd::Zero(K, Ks);
  const double u_lo = grid.knot(k_lo);
  for (int k = 0; k < K; ++k) {
    if (k >= k_lo)
      T(k, k - k_lo) = 1.0;
    else
      T(k, 0) = std::max(0.0, grid.knot(k)) / u_lo;
  }
  return T;
}

// P = D^T D with D the second derivative against s = ln u on the knots from k_lo up, each row
// times sqrt of its cell width: h^T P h approximates the integral of h''(s)^2 ds.
Eigen::MatrixXd log_log_curvature(const KnotGrid& grid, int k_lo) {
  const int Ks = grid.count - k_lo;
  Eigen::MatrixXd D = Eigen::MatrixXd::Zero(std::max(0, Ks - 2), Ks);
  for (int i = 1; i + 1 < Ks; ++i) {
    const double s0 = std::log(grid.knot(k_lo + i - 1)), s1 = std::log(grid.knot(k_lo + i)),
                 s2 = std::log(grid.knot(k_lo + i + 1));
    const double h1 = s1 - s0, h2 = s2 - s1, c = 2.0 / (h1 + h2), w = std::sqrt(0.5 * (h1 + h2));
    D(i - 1, i - 1) = w * c / h1;
    D(i - 1, i) = -w * (c / h1 + c / h2);
    D(i - 1, i + 1) = w * c / h2;
  }
  return D.transpose() * D;
}

double rayleigh(const Eigen::MatrixXd& A, const Eigen::MatrixXd& B, const Eigen::VectorXd& g) {
  return g.dot(A * g) / g.dot(B * g);
}

// The exponent of the power law g = u^gamma (gamma in [0.2, 6], golden-section search) that
// fits the data best: where the refinement starts.
double best_power_law_gamma(const Eigen::MatrixXd& A, const Eigen::MatrixXd& B, const Eigen::VectorXd& log_u) {
  auto misfit = [&](double gamma) { return rayleigh(A, B, (gamma * log_u).array().exp().matrix()); };
  const double phi = 0.5 * (std::sqrt(5.0) - 1.0);
  double a = 0.2, b = 6.0;
  double x1 = b - phi * (b - a), x2 = a + phi * (b - a), f1 = misfit(x1), f2 = misfit(x2);
  for (int it = 0; it < 60 && b - a > 1e-6; ++it) {
    if (f1 < f2) {
      b = x2;
      x2 = x1;
      f2 = f1;
      x1 = b - phi * (b - a);
      f1 = misfit(x1);
    } else {
      a = x1;
      x1 = x2;
      f1 = f2;
      x2 = a + phi * (b - a);
      f2 = misfit(x2);
    }
  }
  return 0.5 * (a + b);
}

// Minimises F(h) = g^T A g / g^T B g + mu h^T P h over h = ln g, h[ref] held, by
// Levenberg-Marquardt with a Gauss-Newton Hessian made positive semi-definite. False when F
// never falls (the caller keeps the eigenvector solution).
bool minimise_log_log(const Eigen::MatrixXd& A, const Eigen::MatrixXd& B, const Eigen::MatrixXd& P, double mu,
                      int ref, Eigen::VectorXd* h) {
  const int n = static_cast<int>(h->size());
  auto value = [&](const Eigen::VectorXd& x) {
    const Eigen::VectorXd g = x.array().exp().matrix();
    return rayleigh(A, B, g) + mu * x.dot(P * x);
  };
  double F = value(*h), nu = 1e-3;
  bool improved = false;
  for (int it = 0; it < 100; ++it) {
    const Eigen::VectorXd g = h->array().exp().matrix();
    const Eigen::VectorXd Ag = A * g, Bg = B * g;
    const double s = g.dot(Bg), r = g.dot(Ag) / s;
    const Eigen::VectorXd dr = 2.0 * (Ag - r * Bg) / s;
    const Eigen::VectorXd gdr = g.cwiseProduct(dr);
    Eigen::VectorXd grad = gdr + 2.0 * mu * (P * *h);
    Eigen::MatrixXd H = g.asDiagonal() * (2.0 * (A - r * B) / s) * g.asDiagonal();
    H.diagonal() += gdr.cwiseAbs();
    H += 2.0 * mu * P;
    grad[ref] = 0.0;
    H.row(ref).setZero();
    H.col(ref).setZero();
    H(ref, ref) = 1.0;
    bool step_taken = false;
    for (int tries = 0; tries < 12 && !step_taken; ++tries) {
      Eigen::MatrixXd Hl = H;
      for (int i = 0; i < n; ++i) Hl(i, i) += nu * std::max(H(i, i), 1e-12);
      const Eigen::LDLT<Eigen::MatrixXd> ldlt(Hl);
      Eigen::VectorXd delta = ldlt.solve(-grad);
      if (!delta.allFinite()) {
        nu *= 10.0;
        continue;
      }
      delta = delta.cwiseMax(-2.0).cwiseMin(2.0);
      delta[ref] = 0.0;
      const Eigen::VectorXd trial = *h + delta;
      const double Ft = value(trial);
      if (std::isfinite(Ft) && Ft < F) {
        const double drop = F - Ft;
        *h = trial;
        F = Ft;
        nu = std::max(nu / 3.0, 1e-12);
        step_taken = improved = true;
        if (drop < 1e-12 * F) return true;
      } else {
        nu *= 10.0;
      }
    }
    if (!step_taken) break;
  }
  return improved;
}

void Solver::solve_direct(bool robertson) {
  // The least-squares problem over all weighted samples,
  //   Robertson: sum w (g(u) - t E)^2          Debevec: sum w (ln g(u) - ln t - ln E)^2,
  // has per-pixel unknowns E that are linear in g: eliminating them leaves a quadratic form
  // g^T M g (each pixel adds sum_j w_j b_j b_j^T - v v^T / S, b_j the sample's basis vector),
  // plus the curvature penalty. Debevec's form is linear least squares with ln g fixed at the
  // reference knot. Robertson's is homogeneous in g: the fixed point of their alternating
  // iteration (E from g, g from E, rescale) is the smallest generalised eigenvector of
  // (M + penalty, sum w b b^T), solved here directly. The classic iteration crawls along the
  // directions the data leave nearly free (e.g. the self-similar ambiguity of brackets whose
  // exposures step by one constant ratio) and stops wherever its tolerance says.
  const int K = grid_.count;
  const int C = channels_;
  const std::size_t KK = static_cast<std::size_t>(K) * K;
  struct Acc {
    std::vector<double> m;     // [c][K][K], upper triangle
    std::vector<double> b;     // [c][K][K], upper triangle: sum w b b^T alone
    std::vector<double> q;     // [c][K] (Debevec's right-hand side)
    std::vector<double> diag;  // [c][K]
  };
  tbb::combinable<Acc> acc([&] {
    return Acc{std::vector<double>(C * KK, 0.0), robertson ? std::vector<double>(C * KK, 0.0) : std::vector<double>(),
               std::vector<double>(static_cast<std::size_t>(C) * K, 0.0),
               std::vector<double>(static_cast<std::size_t>(C) * K, 0.0)};
  });
  const std::size_t J = frames_.size();
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, pixels_, kBlockPixels), [&](const auto& r) {
    Acc& a = acc.local();
    struct Sample {
      int k;
      double f, w, t, lt;
    };
    std::vector<Sample> samples(J);
    std::vector<int> vi(2 * J);
    std::vector<double> vv(2 * J);
    for (std::size_t p = r.begin(); p < r.end(); ++p)
      for (int c = 0; c < C; ++c) {
        const std::size_t s = p * C + c;
        std::size_t n = 0;
        for (std::size_t j = 0; j < J; ++j) {
          if (!nodata_.empty() && nodata_[j][p]) continue;
          const SampleInfo si = info(j, p, s, frames_[j].pixels->data()[s]);
          if (si.w <= 0.0f) continue;
          samples[n++] = {si.k, si.f, si.w, frames_[j].exposure_s, log_t_[j]};
        }
        if (n < 2) continue;  // one sample fixes E and says nothing about g
        double* m = a.m.data() + c * KK;
        double* diag = a.diag.data() + static_cast<std::size_t>(c) * K;
        double S = 0.0, mean_lt = 0.0;
        for (std::size_t i = 0; i < n; ++i) {
          const Sample& x = samples[i];
          S += robertson ? x.w * x.t * x.t : x.w;
          mean_lt += x.w * x.lt;
        }
        double W = 0.0;
        for (std::size_t i = 0; i < n; ++i) W += samples[i].w;
        mean_lt /= W;
        std::size_t nv = 0;
        auto add_v = [&](int k, double value) {
          for (std::size_t i = 0; i < nv; ++i)
            if (vi[i] == k) {
              vv[i] += value;
              return;
            }
          vi[nv] = k;
          vv[nv] = value;
          ++nv;
        };
        for (std::size_t i = 0; i < n; ++i) {
          const Sample& x = samples[i];
          const double f0 = 1.0 - x.f, f1 = x.f;
          m[x.k * static_cast<std::size_t>(K) + x.k] += x.w * f0 * f0;
          m[(x.k + 1) * static_cast<std::size_t>(K) + x.k + 1] += x.w * f1 * f1;
          m[x.k * static_cast<std::size_t>(K) + x.k + 1] += x.w * f0 * f1;
          diag[x.k] += x.w * f0 * f0;
          diag[x.k + 1] += x.w * f1 * f1;
          if (robertson) {
            double* bb = a.b.data() + c * KK;
            bb[x.k * static_cast<std::size_t>(K) + x.k] += x.w * f0 * f0;
            bb[(x.k + 1) * static_cast<std::size_t>(K) + x.k + 1] += x.w * f1 * f1;
            bb[x.k * static_cast<std::size_t>(K) + x.k + 1] += x.w * f0 * f1;
          }
          const double coef = robertson ? x.w * x.t : x.w;
          if (f0 != 0.0) add_v(x.k, coef * f0);
          if (f1 != 0.0) add_v(x.k + 1, coef * f1);
          if (!robertson) {
            double* q = a.q.data() + static_cast<std::size_t>(c) * K;
            q[x.k] += x.w * (x.lt - mean_lt) * f0;
            q[x.k + 1] += x.w * (x.lt - mean_lt) * f1;
          }
        }
        for (std::size_t i = 0; i < nv; ++i)
          for (std::size_t l = 0; l < nv; ++l) {
            if (vi[i] > vi[l]) continue;
            m[vi[i] * static_cast<std::size_t>(K) + vi[l]] -= vv[i] * vv[l] / S;
          }
      }
  });
  std::vector<double> m(C * KK, 0.0), q(static_cast<std::size_t>(C) * K, 0.0);
  std::vector<double> bmat(robertson ? C * KK : 0, 0.0);
  diag_.assign(C, std::vector<double>(K, 0.0));
  acc.combine_each([&](const Acc& a) {
    for (std::size_t i = 0; i < m.size(); ++i) m[i] += a.m[i];
    for (std::size_t i = 0; i < bmat.size(); ++i) bmat[i] += a.b[i];
    for (std::size_t i = 0; i < q.size(); ++i) q[i] += a.q[i];
    for (int c = 0; c < C; ++c)
      for (int k = 0; k < K; ++k) diag_[c][k] += a.diag[static_cast<std::size_t>(c) * K + k];
  });

  const double u_ref = grid_.knot(ref_knot_);
  for (int c = 0; c < C; ++c) {
    double mean_diag = 0.0;
    int n = 0;
    for (int k = 0; k < K; ++k)
      if (diag_[c][k] > 0.0) {
        mean_diag += diag_[c][k];
        ++n;
      }
    if (n < 3)
      throw CalibrationError(fmt::format(
          "response: channel {}: too few usable values (between the noise floor {} DN and saturation {} DN, in at "
          "least two exposures of a pixel); the stack is too dark, too bright or too small",
          c, window_.floor_dn, window_.saturation_dn));
    mean_diag /= n;
    const double smoothness = opt_.smoothness >= 0.0 ? opt_.smoothness : (robertson ? 1.0 : 1e-3);
    const double lambda = smoothness * mean_diag;
    Eigen::MatrixXd A(K, K);
    const double* mc = m.data() + c * KK;
    for (int i = 0; i < K; ++i)
      for (int l = i; l < K; ++l) {
        A(i, l) = mc[static_cast<std::size_t>(i) * K + l];
        A(l, i) = A(i, l);
      }
    const Eigen::MatrixXd A_data = A;  // the data's form alone: its Rayleigh quotient is their misfit
    for (int k = 1; k + 1 < K; ++k) {
      const int idx[3] = {k - 1, k, k + 1};
      const double coef[3] = {1.0, -2.0, 1.0};
      for (int x = 0; x < 3; ++x)
        for (int y = 0; y < 3; ++y) A(idx[x], idx[y]) += lambda * coef[x] * coef[y];
    }
    A.diagonal().array() += 1e-9 * mean_diag;
    Eigen::VectorXd x;
    if (robertson) {
      // Homogeneous in g: minimise the Rayleigh quotient g^T (M + penalty) g / g^T D_w g,
      // D_w = sum w b b^T (the data's own scale), i.e. the smallest generalised eigenvector.
      // This is the fixed point Robertson's alternation converges to; normalising by a single
      // knot instead would reward shrinking the curve away from that knot.
      Eigen::MatrixXd B = Eigen::MatrixXd::Zero(K, K);
      const double* bc = bmat.data() + c * KK;
      for (int i = 0; i < K; ++i)
        for (int l = i; l < K && l <= i + 1; ++l) {
          B(i, l) = bc[static_cast<std::size_t>(i) * K + l];
          B(l, i) = B(i, l);
        }
      B.diagonal().array() += 1e-6 * mean_diag;
      const Eigen::GeneralizedSelfAdjointEigenSolver<Eigen::MatrixXd> eig(A, B);
      if (eig.info() != Eigen::Success)
        throw CalibrationError(fmt::format("response: channel {}: the eigenproblem did not converge", c));
      x = eig.eigenvectors().col(0);
      if (!(std::abs(x[ref_knot_]) > 0.0))
        throw CalibrationError(fmt::format("response: channel {}: the least-squares system is singular", c));
      x *= u_ref / x[ref_knot_];
      // The log-log curvature prior decides what the exposure ratios leave free (see above):
      // from the best power law, the curve that fits the data under the prior.
      int k_lo = 0;
      while (k_lo < K && !(grid_.knot(k_lo) > std::max(window_.floor_dn, 0.0))) ++k_lo;
      const double step = common_log_step(frames_);
      if (step > 0.0 && k_lo + 3 < K && ref_knot_ >= k_lo) {
        const Eigen::MatrixXd T = lower_extension(grid_, k_lo);
        const Eigen::MatrixXd As = T.transpose() * A * T;
        const Eigen::MatrixXd Bs = T.transpose() * B * T;
        const Eigen::MatrixXd P = log_log_curvature(grid_, k_lo);
        Eigen::VectorXd log_u(K - k_lo);
        for (int k = k_lo; k < K; ++k) log_u[k - k_lo] = std::log(grid_.knot(k) / u_ref);
        const double gamma = best_power_law_gamma(As, Bs, log_u);
        // The prior's weight in units of the data's own misfit (their noise level): it decides
        // along the directions the data leave free and yields where they speak.
        const double mu = kLogLogPriorWeight * rayleigh(A_data, B, x);
        Eigen::VectorXd h = (std::log(u_ref) + gamma * log_u.array()).matrix();
        if (minimise_log_log(As, Bs, P, mu, ref_knot_ - k_lo, &h)) {
          x = T * h.array().exp().matrix();
          x *= u_ref / x[ref_knot_];
        } else {
          spdlog::warn("response: channel {}: the log-log prior's solve did not improve on its start; the curve is "
                       "the unconstrained eigenvector",
                       c);
        }
      }
    } else {
      const Eigen::LDLT<Eigen::MatrixXd> ldlt(A);
      if (ldlt.info() != Eigen::Success)
        throw CalibrationError(fmt::format("response: channel {}: the least-squares system is singular", c));
      Eigen::VectorXd e_ref = Eigen::VectorXd::Zero(K);
      e_ref[ref_knot_] = 1.0;
      const Eigen::VectorXd y1 = ldlt.solve(e_ref);
      Eigen::VectorXd rhs(K);
      for (int k = 0; k < K; ++k) rhs[k] = q[static_cast<std::size_t>(c) * K + k];
      const Eigen::VectorXd y0 = ldlt.solve(rhs);
      const double mu = (std::log(u_ref) - y0[ref_knot_]) / y1[ref_knot_];
      x = y0 + mu * y1;
    }
    if (!x.allFinite())
      throw CalibrationError(fmt::format("response: channel {}: the solution is not finite", c));
    for (int k = 0; k < K; ++k) g_[c][k] = x[k];
  }
}

ResponseCurve Solver::run() {
  choose_window();
  build_nodata();
  build_grid();
  log_t_.resize(frames_.size());
  for (std::size_t j = 0; j < frames_.size(); ++j) log_t_[j] = std::log(frames_[j].exposure_s);
  g_.assign(channels_, std::vector<double>(grid_.count, 0.0));
  solve_direct(method_ == ResponseMethod::Robertson);
  ResponseCurve out;
  finish(&out);
  return out;
}

void Solver::finish(ResponseCurve* out) {
  const int K = grid_.count;
  const int C = channels_;
  out->method = method_;
  out->weighting = weighting_;
  out->bit_depth = bit_depth_;
  out->channels = C;
  out->window = window_;
  out->dark_subtracted = dark_ != nullptr;
  out->knots_dn.resize(K);
  for (int k = 0; k < K; ++k) out->knots_dn[k] = grid_.knot(k);

  // Linear values, scaled to least-squares slope 1 against u over the used range (weights:
  // the data weight of each knot).
  const double u_sat = window_.u_saturation();
  auto in_range = [&](int c, int k) {
    const double u = grid_.knot(k);
    return u > window_.floor_dn && u < u_sat && diag_[c][k] > 0.0;
  };
  std::vector<std::vector<double>> lin(C, std::vector<double>(K));
  out->report.nonlinearity_rel.assign(C, 0.0);
  out->report.monotonic_violation_rel.assign(C, 0.0);
  for (int c = 0; c < C; ++c) {
    for (int k = 0; k < K; ++k) lin[c][k] = method_ == ResponseMethod::Robertson ? g_[c][k] : std::exp(g_[c][k]);
    double sgu = 0.0, sgg = 0.0;
    for (int k = 0; k < K; ++k) {
      if (!in_range(c, k)) continue;
      sgu += diag_[c][k] * lin[c][k] * grid_.knot(k);
      sgg += diag_[c][k] * lin[c][k] * lin[c][k];
    }
    const double scale = sgg > 0.0 ? sgu / sgg : 1.0;
    for (double& v : lin[c]) v *= scale;
    const double top = std::abs(lin[c][std::clamp(static_cast<int>(std::lround((u_sat - grid_.u0) / grid_.step)), 0,
                                                   K - 1)]);
    // Largest decrease between consecutive knots with data, then the non-decreasing
    // projection over the used range (weights: data weight of each knot; knots without
    // data get a token weight so that they are pooled with their neighbours).
    int last = -1;
    double worst_drop = 0.0;
    for (int k = 0; k < K; ++k) {
      if (!in_range(c, k)) continue;
      if (last >= 0) worst_drop = std::max(worst_drop, lin[c][last] - lin[c][k]);
      last = k;
    }
    out->report.monotonic_violation_rel[c] = top > 0.0 ? worst_drop / top : 0.0;
    if (out->report.monotonic_violation_rel[c] > 0.01)
      spdlog::warn("response: channel {}: the recovered curve falls by {:.1f} % of its top value within the used range",
                   c, 100.0 * out->report.monotonic_violation_rel[c]);
    {
      int k0 = 0;
      while (k0 < K && grid_.knot(k0) < window_.floor_dn) ++k0;
      int k1 = K - 1;
      while (k1 > k0 && grid_.knot(k1) > u_sat) --k1;
      double wmax = 0.0;
      for (int k = k0; k <= k1; ++k) wmax = std::max(wmax, diag_[c][k]);
      struct Block {
        double value, weight;
        int count;
      };
      std::vector<Block> blocks;
      for (int k = k0; k <= k1; ++k) {
        blocks.push_back({lin[c][k], diag_[c][k] + 1e-9 * wmax + 1e-300, 1});
        while (blocks.size() >= 2 && blocks[blocks.size() - 2].value > blocks.back().value) {
          Block b = blocks.back();
          blocks.pop_back();
          Block& a = blocks.back();
          const double w = a.weight + b.weight;
          a.value = (a.value * a.weight + b.value * b.weight) / w;
          a.weight = w;
          a.count += b.count;
        }
      }
      int k = k0;
      for (const Block& b : blocks)
        for (int i = 0; i < b.count; ++i) lin[c][k++] = b.value;
      // Knots outside the used range must not undercut or overtake it.
      for (int i = k0 - 1; i >= 0; --i) lin[c][i] = std::min(lin[c][i], lin[c][i + 1]);
      for (int i = k1 + 1; i < K; ++i) lin[c][i] = std::max(lin[c][i], lin[c][i - 1]);
    }
    // Nonlinearity: weighted straight line a + b u through the used range.
    double sw = 0, su = 0, sv = 0, suu = 0, suv = 0;
    for (int k = 0; k < K; ++k) {
      if (!in_range(c, k)) continue;
      const double w = diag_[c][k];
      const double u = grid_.knot(k);
      sw += w;
      su += w * u;
      sv += w * lin[c][k];
      suu += w * u * u;
      suv += w * u * lin[c][k];
    }
    const double det = sw * suu - su * su;
    if (det > 0.0) {
      const double b = (sw * suv - su * sv) / det;
      const double a = (sv - b * su) / sw;
      double worst = 0.0;
      for (int k = 0; k < K; ++k)
        if (in_range(c, k)) worst = std::max(worst, std::abs(lin[c][k] - (a + b * grid_.knot(k))));
      out->report.nonlinearity_rel[c] = worst / std::abs(a + b * u_sat);
    }
  }
  out->linear = lin;
  g_ = lin;
  method_ = ResponseMethod::Robertson;
  residual_statistics(out);
}

void Solver::residual_statistics(ResponseCurve* out) {
  // With the final (linear) curve: residuals g(u) - t E of every weighted sample, E the
  // Robertson estimate of its pixel. Gives the linearity error, each image's exposure
  // ratio and the spread per knot (robust: median absolute residual, from a histogram of
  // |r| / rms in a second pass).
  const int K = grid_.count;
  const int C = channels_;
  const std::size_t J = frames_.size();
  const std::size_t CK = static_cast<std::size_t>(C) * K;
  constexpr int kRatioBins = 4000;  // ratio histogram over [0.5, 1.5)
  constexpr int kAbsBins = 256;     // |r| / rms histogram over [0, 8)
  auto nearest = [&](const SampleInfo& si) { return si.f > 0.5f ? si.k + 1 : si.k; };

  struct Pass1 {
    double sq = 0.0;
    long long n = 0;
    long long used = 0;
    double contributing = 0.0;
    long long pixels = 0;
    std::vector<std::vector<long long>> ratio_hist;
    std::vector<double> r2;
    std::vector<long long> cnt;
  };
  tbb::combinable<Pass1> acc1([&] {
    Pass1 s;
    s.ratio_hist.assign(J, std::vector<long long>(kRatioBins, 0));
    s.r2.assign(CK, 0.0);
    s.cnt.assign(CK, 0);
    return s;
  });
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, pixels_, kBlockPixels), [&](const auto& r) {
    std::vector<double> e;
    estimate(r.begin(), r.end(), false, &e);
    Pass1& st = acc1.local();
    const std::size_t base = r.begin() * C;
    std::vector<int> count(e.size(), 0);
    visit(r.begin(), r.end(), [&](std::size_t j, int c, std::size_t s, const SampleInfo& si) {
      const double est = e[s - base];
      if (!(est > 0.0)) return;
      const double t = frames_[j].exposure_s;
      const double y = value(c, si.k, si.f);
      ++st.used;
      ++count[s - base];
      if (si.w >= 0.5f) {
        const double ratio = y / (t * est);
        st.sq += (ratio - 1.0) * (ratio - 1.0);
        ++st.n;
        const int bin = static_cast<int>(std::floor((ratio - 0.5) * kRatioBins));
        if (bin >= 0 && bin < kRatioBins) ++st.ratio_hist[j][bin];
      }
      const std::size_t b = static_cast<std::size_t>(c) * K + nearest(si);
      st.r2[b] += (y - t * est) * (y - t * est);
      ++st.cnt[b];
    });
    for (int n : count)
      if (n > 0) {
        st.contributing += n;
        ++st.pixels;
      }
  });
  Pass1 tot;
  tot.ratio_hist.assign(J, std::vector<long long>(kRatioBins, 0));
  tot.r2.assign(CK, 0.0);
  tot.cnt.assign(CK, 0);
  acc1.combine_each([&](const Pass1& s) {
    tot.sq += s.sq;
    tot.n += s.n;
    tot.used += s.used;
    tot.contributing += s.contributing;
    tot.pixels += s.pixels;
    for (std::size_t j = 0; j < J; ++j)
      for (int b = 0; b < kRatioBins; ++b) tot.ratio_hist[j][b] += s.ratio_hist[j][b];
    for (std::size_t b = 0; b < CK; ++b) {
      tot.r2[b] += s.r2[b];
      tot.cnt[b] += s.cnt[b];
    }
  });
  out->report.samples_used = tot.used;
  out->report.linearity_rms_rel = tot.n > 0 ? std::sqrt(tot.sq / static_cast<double>(tot.n)) : 0.0;
  {
    // Median of |ratio - 1| from the ratio histograms of all images.
    std::vector<long long> dev(kRatioBins / 2, 0);
    long long n = 0;
    for (std::size_t j = 0; j < J; ++j)
      for (int b = 0; b < kRatioBins; ++b) {
        const int d = std::abs(b - kRatioBins / 2) - (b < kRatioBins / 2 ? 1 : 0);
        dev[static_cast<std::size_t>(std::min(d, kRatioBins / 2 - 1))] += tot.ratio_hist[j][b];
        n += tot.ratio_hist[j][b];
      }
    // Samples outside [0.5, 1.5) count as large deviations.
    const long long outside = tot.n - n;
    long long run = 0;
    out->report.linearity_error_rel = 0.5;
    for (int d = 0; d < kRatioBins / 2 && tot.n > 0; ++d) {
      run += dev[static_cast<std::size_t>(d)];
      if (2 * run >= n + outside) {
        out->report.linearity_error_rel = kMadToSigma * (d + 0.5) / kRatioBins;
        break;
      }
    }
  }
  out->report.exposure_ratio.assign(J, std::numeric_limits<double>::quiet_NaN());
  for (std::size_t j = 0; j < J; ++j) {
    const auto& h = tot.ratio_hist[j];
    const long long n = std::accumulate(h.begin(), h.end(), 0LL);
    long long run = 0;
    for (int b = 0; b < kRatioBins && n > 0; ++b) {
      run += h[b];
      if (2 * run >= n) {
        out->report.exposure_ratio[j] = 0.5 + (b + 0.5) / kRatioBins;
        break;
      }
    }
  }

  // Second pass: median of |r| per knot from a histogram scaled by the knot's RMS.
  std::vector<double> rms(CK, 0.0);
  for (std::size_t b = 0; b < CK; ++b)
    rms[b] = tot.cnt[b] > 0 ? std::sqrt(tot.r2[b] / static_cast<double>(tot.cnt[b])) : 0.0;
  tbb::combinable<std::vector<std::uint32_t>> acc2([&] { return std::vector<std::uint32_t>(CK * kAbsBins, 0); });
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, pixels_, kBlockPixels), [&](const auto& r) {
    std::vector<double> e;
    estimate(r.begin(), r.end(), false, &e);
    auto& h = acc2.local();
    const std::size_t base = r.begin() * C;
    visit(r.begin(), r.end(), [&](std::size_t j, int c, std::size_t s, const SampleInfo& si) {
      const double est = e[s - base];
      if (!(est > 0.0)) return;
      const std::size_t b = static_cast<std::size_t>(c) * K + nearest(si);
      if (!(rms[b] > 0.0)) return;
      const double y = value(c, si.k, si.f);
      const double a = std::abs(y - frames_[j].exposure_s * est) / rms[b];
      const int bin = std::min(kAbsBins - 1, static_cast<int>(a * (kAbsBins / 8.0)));
      ++h[b * kAbsBins + bin];
    });
  });
  std::vector<long long> hist(CK * kAbsBins, 0);
  acc2.combine_each([&](const std::vector<std::uint32_t>& h) {
    for (std::size_t i = 0; i < hist.size(); ++i) hist[i] += h[i];
  });
  // Residuals are taken against an estimate made from the same samples, which removes a
  // share 1/n of their variance: corrected with n / (n - 1), n the mean samples per pixel.
  const double n_mean = tot.pixels > 0 ? tot.contributing / static_cast<double>(tot.pixels) : 0.0;
  const double dof = n_mean > 1.5 ? std::sqrt(n_mean / (n_mean - 1.0)) : 1.0;
  constexpr long long kMinCount = 30;
  out->residual_std.assign(C, std::vector<double>(K, 0.0));
  for (int c = 0; c < C; ++c) {
    auto& sd = out->residual_std[c];
    std::vector<int> known;
    for (int k = 0; k < K; ++k) {
      const std::size_t b = static_cast<std::size_t>(c) * K + k;
      if (tot.cnt[b] < kMinCount) continue;
      long long run = 0;
      int bin = 0;
      for (; bin < kAbsBins; ++bin) {
        run += hist[b * kAbsBins + bin];
        if (2 * run >= tot.cnt[b]) break;
      }
      const double median_abs = (bin + 0.5) * (8.0 / kAbsBins) * rms[b];
      sd[k] = kMadToSigma * median_abs * dof;
      known.push_back(k);
    }
    if (known.empty()) {
      out->residual_std.clear();
      break;
    }
    // Knots without enough samples: interpolated between measured neighbours, held at the ends.
    for (int k = 0; k < K; ++k) {
      const auto it = std::lower_bound(known.begin(), known.end(), k);
      if (it != known.end() && *it == k) continue;
      if (it == known.begin()) sd[k] = sd[known.front()];
      else if (it == known.end()) sd[k] = sd[known.back()];
      else {
        const int a = *(it - 1), b = *it;
        sd[k] = sd[a] + (sd[b] - sd[a]) * (k - a) / static_cast<double>(b - a);
      }
    }
  }

  // Read + shot model in DN fitted to the spread over the used range: var_dn = (sd / slope)^2.
  WeightedLineFit variance;  // against the level u
  if (!out->residual_std.empty())
    for (int c = 0; c < C; ++c)
      for (int k = 0; k + 1 < K; ++k) {
        const std::size_t b = static_cast<std::size_t>(c) * K + k;
        const double u = grid_.knot(k);
        const double slope = (g_[c][k + 1] - g_[c][k]) / grid_.step;
        if (tot.cnt[b] < kMinCount || u <= window_.floor_dn || u >= window_.u_saturation() || !(slope > 0.0)) continue;
        variance.add(u, std::pow(out->residual_std[c][k] / slope, 2), static_cast<double>(tot.cnt[b]));
      }
  if (variance.determined()) {
    double b = variance.slope();
    double a = variance.intercept();
    if (b < 0.0) {  // no measurable shot noise: a constant variance
      b = 0.0;
      a = variance.mean_y();
    }
    out->noise.read_noise_dn = std::sqrt(std::max(a, 1.0 / 12.0));
    out->noise.gain_dn_per_e = b;
    out->noise.source = "response residuals";
  }
}

}  // namespace

ResponseCurve recover_response(std::span<const StackFrame> frames, int bit_depth, const ResponseOptions& options,
                               const DarkFrame* dark) {
  options.check();
  check_stack(frames, bit_depth, 2);
  {
    double t_min = frames[0].exposure_s;
    double t_max = t_min;
    for (const auto& f : frames) {
      t_min = std::min(t_min, f.exposure_s);
      t_max = std::max(t_max, f.exposure_s);
    }
    if (t_max <= t_min * (1.0 + 1e-9))
      throw DataError("response: every image has the same exposure time; a stack needs different exposures");
  }
  if (dark) {
    const auto& first = *frames[0].pixels;
    if (dark->width() != first.width() || dark->height() != first.height() || dark->channels() != first.channels())
      throw DataError(fmt::format("response: the dark frame is {}x{}x{}, the images {}x{}x{}", dark->width(),
                                  dark->height(), dark->channels(), first.width(), first.height(), first.channels()));
  }
  Solver solver(frames, bit_depth, options, dark);
  return solver.run();
}

}  // namespace paintlab::calib
