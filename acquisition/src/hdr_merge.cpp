#include "paintlab/acquisition/hdr_merge.h"

#include "paintlab/calibration/record.h"
#include "paintlab/core/hash.h"

#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <tbb/combinable.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

#include "hdr_merge_kernels.h"
#include "paintlab/core/error.h"

namespace paintlab::acq {

void HdrOptions::check() const {
  if (tile_values < 64) throw UsageError(fmt::format("hdr: tile_values = {}; must be >= 64", tile_values));
  if (!std::isfinite(saturation_dn) || !std::isfinite(floor_dn) || !std::isfinite(black_dn))
    throw UsageError("hdr: saturation_dn, floor_dn and black_dn must be finite");
  if (!(noise.read_noise_dn >= 0.0) || !(noise.gain_dn_per_e >= 0.0))
    throw UsageError("hdr: the noise model's read_noise_dn and gain_dn_per_e must be >= 0");
}

namespace detail {
struct HdrCounts {
  long long valid = 0, saturated = 0, dark = 0, hot = 0;
};
}  // namespace detail
using detail::Float4;
using detail::HdrCounts;
using detail::kBlockValues;

namespace {

using detail::Int4;
using detail::shuffle_lanes;

// e = s1 / s2 and var = s3 / s2^2 (then / gain, / gain^2) of a block of values; ok where s2 > 0
// (where s2 = 0, no exposure had weight: the sums are divided by 1 instead, which leaves the
// zero sums' 0, and ok = 0 marks the pixel invalid). Four values at a time: their
// accumulators transposed into one vector per sum, then the same IEEE operations as one by one.
template <bool kDark, bool kFlat>
void sums_to_radiance(const Float4* acc, const float* gain, std::size_t m, float* e, float* var, int* ok) {
  const Float4 one = {1.0f, 1.0f, 1.0f, 1.0f};
  const Float4 zero = {0.0f, 0.0f, 0.0f, 0.0f};
  std::size_t k = 0;
  for (; k + 4 <= m; k += 4) {
    const Float4 t0 = shuffle_lanes<0, 4, 1, 5>(acc[k], acc[k + 1]);
    const Float4 t1 = shuffle_lanes<0, 4, 1, 5>(acc[k + 2], acc[k + 3]);
    const Float4 t2 = shuffle_lanes<2, 6, 3, 7>(acc[k], acc[k + 1]);
    const Float4 t3 = shuffle_lanes<2, 6, 3, 7>(acc[k + 2], acc[k + 3]);
    const Float4 c0 = shuffle_lanes<0, 1, 4, 5>(t0, t1);
    const Float4 s2 = shuffle_lanes<2, 3, 6, 7>(t0, t1);
    const Float4 s3 = shuffle_lanes<0, 1, 4, 5>(t2, t3);
    Float4 s1 = c0;
    if (kDark) s1 = c0 + shuffle_lanes<2, 3, 6, 7>(t2, t3);
    const Int4 good = s2 > zero;
    const Float4 den = good ? s2 : one;
    Float4 ek = s1 / den;
    Float4 vk = s3 / (den * den);
    if (kFlat) {
      Float4 g;
      std::memcpy(&g, gain + k, sizeof g);
      ek /= g;
      vk /= g * g;
    }
    std::memcpy(e + k, &ek, sizeof ek);
    std::memcpy(var + k, &vk, sizeof vk);
    const Int4 flag = good & Int4{1, 1, 1, 1};
    std::memcpy(ok + k, &flag, sizeof flag);
  }
  for (; k < m; ++k) {
    const float s1 = kDark ? acc[k][0] + acc[k][3] : acc[k][0];
    const float s2 = acc[k][1];
    const float s3 = acc[k][2];
    const bool good = s2 > 0.0f;
    const float den = good ? s2 : 1.0f;
    float ek = s1 / den;
    float vk = s3 / (den * den);
    if (kFlat) {
      const float g = gain[k];
      ek /= g;
      vk /= g * g;
    }
    e[k] = ek;
    var[k] = vk;
    ok[k] = good;
  }
}

// One channel: radiance, variance and validity planes of a block; returns the invalid pixels.
#if defined(__GNUC__) && !defined(__clang__)
__attribute__((optimize("tree-vectorize", "vect-cost-model=dynamic")))
#endif
std::size_t write_mono(const float* __restrict e, const float* __restrict var, const int* __restrict ok,
                       const std::uint8_t* __restrict hot, std::size_t n, float* __restrict y, float* __restrict vy,
                       float* __restrict valid) {
  std::memcpy(y, e, n * sizeof(float));
  std::memcpy(vy, var, n * sizeof(float));
  int bad = 0;
  if (hot) {
    for (std::size_t p = 0; p < n; ++p) {
      const int good = ok[p] & static_cast<int>(hot[p] == 0);
      valid[p] = static_cast<float>(good);
      bad += 1 - good;
    }
  } else {
    for (std::size_t p = 0; p < n; ++p) {
      valid[p] = static_cast<float>(ok[p]);
      bad += 1 - ok[p];
    }
  }
  return static_cast<std::size_t>(bad);
}

}  // namespace

struct HdrMerger::Impl {
  int W = 0, H = 0, C = 1, bits = 8;
  calib::ValueWindow window;
  calib::Weighting weighting = calib::Weighting::Robertson;
  std::string noise_desc;
  float sat = 255.0f;
  std::vector<float> black;              // per channel, without a dark map
  std::optional<calib::ResponseCurve> response;
  std::optional<calib::DarkFrame> dark;
  std::optional<calib::FlatField> flat;
  int u_lo = 0;                          // dark-map tables: entry i <-> u = u_lo + i
  // Without a dark map [channel][raw value] {w y, w, w^2 var, 0}; with one [channel][i]
  // {w y, w, w^2 var, w (y(u + 1) - y(u))} for u = u_lo + i, then one all-zero entry.
  std::vector<Float4> table;
  std::vector<int> channel_offset;       // kBlockValues byte offsets of (k mod 3)'s table
  detail::MergeTables tables;
  const detail::Kernels* kernels = nullptr;
  std::vector<float> y_sat;              // per channel: g(u at saturation)
  std::size_t tile_values = 16384;

  std::size_t values() const { return static_cast<std::size_t>(W) * H * C; }
  double linear(int c, double u) const { return response ? response->to_linear(c, u) : u; }

  void check_frame(const Image<std::uint16_t>& img, double t, std::size_t index) const {
    if (img.width() != W || img.height() != H || img.channels() != C)
      throw DataError(fmt::format("hdr: frame {} is {}x{}x{}, the merger was set up for {}x{}x{}", index + 1,
                                  img.width(), img.height(), img.channels(), W, H, C));
    if (!std::isfinite(t) || t <= 0.0)
      throw DataError(fmt::format("hdr: frame {} has exposure {} s (must be finite and > 0)", index + 1, t));
  }

  // Turns the sums of values [v0, v0 + m) (whole pixels, m <= kBlockValues) into radiance,
  // variance and validity. `shortest`/`longest`: the frames with the shortest and longest
  // exposure (bounds for values no exposure measured).
  void finalise(std::size_t v0, std::size_t m, const Float4* acc, const std::uint16_t* shortest,
                double t_short, const std::uint16_t* longest, double t_long, ExrImage* out, HdrCounts* counts) const {
    alignas(64) float e[kBlockValues];
    alignas(64) float var[kBlockValues];
    alignas(64) int ok[kBlockValues];
    const float* gain = flat ? flat->gain.data() + v0 : nullptr;
    if (dark) {
      if (flat) sums_to_radiance<true, true>(acc, gain, m, e, var, ok);
      else sums_to_radiance<true, false>(acc, gain, m, e, var, ok);
    } else {
      if (flat) sums_to_radiance<false, true>(acc, gain, m, e, var, ok);
      else sums_to_radiance<false, false>(acc, gain, m, e, var, ok);
    }
    const std::size_t p0 = v0 / C;
    const std::size_t np = m / C;
    const std::uint8_t* hot = dark ? dark->hot.data() + p0 : nullptr;
    float* valid_plane = out->planes[static_cast<std::size_t>(2 * C)].data() + p0;
    std::size_t bad = 0;
    if (C == 1) {
      bad = write_mono(e, var, ok, hot, np, out->planes[0].data() + p0, out->planes[1].data() + p0, valid_plane);
    } else {
      float* y[3];
      float* vy[3];
      for (int c = 0; c < 3; ++c) {
        y[c] = out->planes[static_cast<std::size_t>(c)].data() + p0;
        vy[c] = out->planes[static_cast<std::size_t>(3 + c)].data() + p0;
      }
      for (std::size_t p = 0; p < np; ++p) {
        for (int c = 0; c < 3; ++c) {
          y[c][p] = e[3 * p + c];
          vy[c][p] = var[3 * p + c];
        }
        const bool good = ok[3 * p] && ok[3 * p + 1] && ok[3 * p + 2] && !(hot && hot[p]);
        valid_plane[p] = good ? 1.0f : 0.0f;
        bad += !good;
      }
    }
    counts->valid += static_cast<long long>(np - bad);
    if (bad == 0) return;
    // The invalid pixels: bounds where no exposure measured, var = inf.
    const float inf = std::numeric_limits<float>::infinity();
    for (std::size_t p = 0; p < np; ++p) {
      if (valid_plane[p] == 1.0f) continue;
      bool saturated = false;
      for (int c = 0; c < C; ++c) {
        const std::size_t k = p * C + c;
        if (ok[k]) continue;
        const std::size_t v = v0 + k;
        float ev;
        if (static_cast<float>(shortest[v]) >= sat) {
          saturated = true;
          ev = static_cast<float>(y_sat[c] / t_short);
        } else {
          const double d = dark ? dark->level(v, t_long) : black[c];
          ev = static_cast<float>(std::max(0.0, linear(c, longest[v] - d)) / t_long);
        }
        if (flat) ev /= gain[k];
        out->planes[static_cast<std::size_t>(c)].data()[p0 + p] = ev;
        out->planes[static_cast<std::size_t>(C + c)].data()[p0 + p] = inf;
      }
      if (hot && hot[p]) {
        for (int c = 0; c < C; ++c) out->planes[static_cast<std::size_t>(C + c)].data()[p0 + p] = inf;
        ++counts->hot;
      } else if (saturated) {
        ++counts->saturated;
      } else {
        ++counts->dark;
      }
    }
  }

  ExrImage make_image(std::span<const double> exposures) const {
    ExrImage img;
    img.width = W;
    img.height = H;
    std::vector<std::string> names;
    if (C == 1) names = {"Y", "var.Y"};
    else names = {"R", "G", "B", "var.R", "var.G", "var.B"};
    names.push_back("valid");
    img.names = names;
    // Allocated (and zero-filled by the vector) on every worker at once.
    img.planes.resize(names.size());
    tbb::parallel_for(std::size_t{0}, names.size(), [&](std::size_t i) { img.planes[i] = ImageF(W, H, 1); });
    std::string times;
    for (double t : exposures) times += (times.empty() ? "" : ",") + fmt::format("{:.9g}", t);
    img.attributes["paintlab.units"] =
        flat ? "linearised DN per second, flat-field corrected" : "linearised DN per second";
    img.attributes["paintlab.exposures_s"] = times;
    img.attributes["paintlab.weighting"] = calib::to_string(weighting);
    img.attributes["paintlab.variance"] = noise_desc;
    img.attributes["paintlab.valid"] =
        "1: measured by at least one exposure in every channel and not a hot pixel; 0: value is a bound, var = inf";
    return img;
  }

  HdrStats stats_of(const HdrCounts& n) const {
    HdrStats s;
    s.pixels = static_cast<long long>(W) * H;
    s.valid = n.valid;
    s.saturated = n.saturated;
    s.dark = n.dark;
    s.hot = n.hot;
    s.weighting = calib::to_string(weighting);
    s.noise_model = noise_desc;
    return s;
  }
};

HdrCalibration HdrCalibration::of(const calib::RigCalibration& rig) {
  return {rig.response(), rig.dark(), rig.flat()};
}

void HdrFiles::complete_from(const std::filesystem::path& calibration_dir) {
  const auto fill = [&](std::filesystem::path& file, const char* name) {
    if (file.empty() && std::filesystem::exists(calibration_dir / name)) file = calibration_dir / name;
  };
  fill(response, calib::kResponseFile);
  fill(dark, calib::kDarkFile);
  fill(flat, calib::kFlatFile);
}

HdrCalibration HdrFiles::load() const {
  HdrCalibration cal;
  if (!response.empty()) cal.response = calib::ResponseCurve::load(response);
  if (!dark.empty()) cal.dark = calib::DarkFrame::load(dark);
  if (!flat.empty()) cal.flat = calib::FlatField::load(flat);
  return cal;
}

void HdrFiles::stamp(ExrImage& image) const {
  if (!response.empty()) image.attributes["paintlab.response_sha256"] = sha256_file(response);
  if (!dark.empty()) image.attributes["paintlab.dark_sha256"] = sha256_file(dark);
  if (!flat.empty()) image.attributes["paintlab.flat_sha256"] = sha256_file(flat);
}

HdrMerger::HdrMerger(const HdrCalibration& calibration, const HdrOptions& options, int width, int height,
                     int channels, int bit_depth)
    : impl_(std::make_unique<Impl>()) {
  options.check();
  Impl& m = *impl_;
  if (width <= 0 || height <= 0) throw DataError(fmt::format("hdr: image size {}x{} is empty", width, height));
  if (channels != 1 && channels != 3) throw DataError(fmt::format("hdr: {} channels (1 or 3 supported)", channels));
  if (bit_depth < 8 || bit_depth > 16) throw DataError(fmt::format("hdr: bit depth {} is not in 8..16", bit_depth));
  m.W = width;
  m.H = height;
  m.C = channels;
  m.bits = bit_depth;
  m.tile_values = std::max<std::size_t>(options.tile_values / channels * channels, static_cast<std::size_t>(channels));
  m.response = calibration.response;
  m.dark = calibration.dark;
  m.flat = calibration.flat;
  const auto geometry_error = [&](const char* what, int w, int h, int c) {
    return DataError(fmt::format("hdr: the {} is {}x{}x{}, the frames {}x{}x{}", what, w, h, c, width, height, channels));
  };
  if (m.response) {
    if (m.response->channels != channels)
      throw DataError(fmt::format("hdr: the response has {} channel(s), the frames {}", m.response->channels, channels));
    if (m.response->bit_depth != bit_depth)
      throw DataError(fmt::format("hdr: the response was made from {}-bit data, the frames are {}-bit",
                                  m.response->bit_depth, bit_depth));
  }
  if (m.dark && (m.dark->width() != width || m.dark->height() != height || m.dark->channels() != channels))
    throw geometry_error("dark frame", m.dark->width(), m.dark->height(), m.dark->channels());
  if (m.flat && (m.flat->width() != width || m.flat->height() != height || m.flat->channels() != channels))
    throw geometry_error("flat field", m.flat->width(), m.flat->height(), m.flat->channels());
  if (m.dark) {
    for (std::size_t s = 0; s < m.dark->bias_dn.size(); ++s)
      if (!std::isfinite(m.dark->bias_dn.data()[s]) || !std::isfinite(m.dark->rate_dn_per_s.data()[s]))
        throw DataError(fmt::format("hdr: the dark frame holds a value that is not finite (value {})", s));
  }

  // The usable window.
  const double full = std::ldexp(1.0, bit_depth) - 1.0;
  m.window.saturation_dn =
      options.saturation_dn >= 0.0 ? options.saturation_dn : (m.response ? m.response->window.saturation_dn : full);
  m.window.black_dn = options.black_dn >= 0.0 ? options.black_dn
                      : m.response       ? m.response->window.black_dn
                      : m.dark           ? m.dark->mean_bias_dn
                                         : 0.0;
  if (options.floor_dn >= 0.0) m.window.floor_dn = options.floor_dn;
  else if (m.response) m.window.floor_dn = m.response->window.floor_dn;
  else if (m.dark && m.dark->read_noise_measured) m.window.floor_dn = 3.0 * m.dark->read_noise_dn;
  else m.window.floor_dn = 0.0;
  if (!(m.window.u_saturation() > m.window.floor_dn))
    throw DataError(fmt::format("hdr: no usable range: saturation {} DN, black level {} DN, noise floor {} DN",
                                m.window.saturation_dn, m.window.black_dn, m.window.floor_dn));
  m.sat = static_cast<float>(m.window.saturation_dn);
  m.black.assign(channels, static_cast<float>(m.window.black_dn));

  // Where the variance comes from.
  calib::NoiseModel noise = options.noise;
  const bool residuals = m.response && !m.response->residual_std.empty();
  if (!residuals && !noise.known()) {
    if (m.response && m.response->noise.known()) noise = m.response->noise;
    if (m.flat && m.flat->noise.known()) noise = m.flat->noise;
  }
  if (!residuals && m.dark && m.dark->read_noise_measured && noise.known() && noise.read_noise_dn == 0.0)
    noise.read_noise_dn = m.dark->read_noise_dn;
  if (residuals) m.noise_desc = "response residual spread";
  else if (noise.known())
    m.noise_desc = fmt::format("read {:.4g} DN + shot {:.4g} DN/e ({})", noise.read_noise_dn, noise.gain_dn_per_e,
                               noise.source);
  else m.noise_desc = "quantisation only (no noise model known): a lower bound";
  const bool have_noise = residuals || noise.known();
  m.weighting = options.weighting ? *options.weighting
                                  : (have_noise ? calib::Weighting::InverseVariance : calib::Weighting::Robertson);

  auto variance = [&](int c, double u) {
    if (residuals) return m.response->variance(c, u);
    const double s = m.response ? m.response->slope(c, u) : 1.0;
    return s * s * (noise.known() ? noise.variance_dn2(u) : 1.0 / 12.0);
  };
  auto weight = [&](int c, double u) {
    const double cert = calib::certainty(m.weighting, u, m.window);
    if (cert <= 0.0) return 0.0;
    if (m.weighting != calib::Weighting::InverseVariance) return cert;
    const double v = variance(c, u);
    return v > 0.0 ? cert / v : 0.0;
  };
  m.y_sat.resize(channels);
  for (int c = 0; c < channels; ++c) m.y_sat[c] = static_cast<float>(m.linear(c, m.window.u_saturation()));

  if (!m.dark) {
    // Every 16-bit value has an entry (values above 2^bits - 1 count as saturated), so a
    // frame with stray high values can never index outside the table.
    m.table.assign(static_cast<std::size_t>(channels) * 65536, Float4{0.0f, 0.0f, 0.0f, 0.0f});
    for (int c = 0; c < channels; ++c) {
      std::vector<double> w(65536);
      double wmax = 0.0;
      for (std::size_t z = 0; z < w.size(); ++z) {
        w[z] = static_cast<double>(z) >= m.window.saturation_dn ? 0.0 : weight(c, z - m.window.black_dn);
        wmax = std::max(wmax, w[z]);
      }
      for (std::size_t z = 0; z < w.size(); ++z) {
        const double u = static_cast<double>(z) - m.window.black_dn;
        const double wn = wmax > 0.0 ? w[z] / wmax : 0.0;
        m.table[static_cast<std::size_t>(c) * 65536 + z] =
            Float4{static_cast<float>(wn * m.linear(c, u)), static_cast<float>(wn),
                   static_cast<float>(wn * wn * variance(c, u)), 0.0f};
      }
    }
    m.tables.codes = m.table.data();
  } else {
    float lo = std::numeric_limits<float>::max(), hi = std::numeric_limits<float>::lowest();
    for (std::size_t s = 0; s < m.dark->bias_dn.size(); ++s) {
      // The dark level over the exposures the camera can plausibly use (up to 1 h).
      const float b = m.dark->bias_dn.data()[s];
      const float r = m.dark->rate_dn_per_s.data()[s];
      lo = std::min({lo, b, b + r * 3600.0f});
      hi = std::max({hi, b, b + r * 3600.0f});
    }
    m.u_lo = static_cast<int>(std::floor(-hi)) - 1;
    const int u_hi = static_cast<int>(std::ceil(full - lo)) + 1;
    const std::size_t n = static_cast<std::size_t>(u_hi - m.u_lo + 1);
    // One more entry per channel, all zero: where the kernels send saturated raw values.
    const std::size_t stride = n + 1;
    m.table.assign(static_cast<std::size_t>(channels) * stride, Float4{0.0f, 0.0f, 0.0f, 0.0f});
    for (int c = 0; c < channels; ++c) {
      std::vector<double> w(n);
      double wmax = 0.0;
      for (std::size_t i = 0; i < n; ++i) {
        w[i] = weight(c, m.u_lo + static_cast<double>(i));
        wmax = std::max(wmax, w[i]);
      }
      for (std::size_t i = 0; i < n; ++i) {
        const double u = m.u_lo + static_cast<double>(i);
        const double wn = wmax > 0.0 ? w[i] / wmax : 0.0;
        const double y0 = m.linear(c, u);
        const double y1 = m.linear(c, u + 1.0);
        m.table[static_cast<std::size_t>(c) * stride + i] =
            Float4{static_cast<float>(wn * y0), static_cast<float>(wn), static_cast<float>(wn * wn * variance(c, u)),
                   static_cast<float>(wn * (y1 - y0))};
      }
    }
    detail::MergeTables& t = m.tables;
    t.dark_lut = m.table.data();
    t.dark_stride = stride;
    t.bias = m.dark->bias_dn.data();
    t.rate = m.dark->rate_dn_per_s.data();
    t.u_lo = static_cast<float>(m.u_lo);
    t.top = static_cast<float>(n - 2);  // the last entry with a real neighbour above
    t.zero = static_cast<int>(n);
    t.saturation = m.sat;
    if (static_cast<std::size_t>(channels) * stride * sizeof(Float4) >
        static_cast<std::size_t>(std::numeric_limits<int>::max()))
      throw DataError(fmt::format("hdr: the dark frame spans {} DN; its table does not fit", n));
    m.channel_offset.resize(kBlockValues);
    for (std::size_t k = 0; k < kBlockValues; ++k)
      m.channel_offset[k] = static_cast<int>((k % static_cast<std::size_t>(channels)) * stride * sizeof(Float4));
    t.channel_offset = m.channel_offset.data();
  }
  m.tables.channels = channels;
  m.kernels = options.baseline_simd ? &detail::baseline_kernels() : &detail::kernels();
}

HdrMerger::~HdrMerger() = default;

int HdrMerger::width() const { return impl_->W; }
int HdrMerger::height() const { return impl_->H; }
int HdrMerger::channels() const { return impl_->C; }
int HdrMerger::bit_depth() const { return impl_->bits; }
const calib::ValueWindow& HdrMerger::window() const { return impl_->window; }
calib::Weighting HdrMerger::weighting() const { return impl_->weighting; }

const char* HdrMerger::simd() const { return impl_->kernels->name; }

namespace {

// Per-thread buffers of a merge: the accumulators of one block and the kernels' scratch.
struct BlockBuffers {
  std::vector<Float4> acc;
  std::vector<int> off;
  std::vector<float> tf;
  explicit BlockBuffers(std::size_t frames) : acc(kBlockValues), off(frames * kBlockValues), tf(frames * kBlockValues) {}
};

void add_counts(tbb::combinable<HdrCounts>& counts, HdrCounts* total) {
  counts.combine_each([&](const HdrCounts& n) {
    total->valid += n.valid;
    total->saturated += n.saturated;
    total->dark += n.dark;
    total->hot += n.hot;
  });
}

}  // namespace

HdrResult HdrMerger::merge(std::span<const calib::StackFrame> frames) const {
  const Impl& m = *impl_;
  if (frames.empty()) throw DataError("hdr: no frames to merge");
  for (std::size_t j = 0; j < frames.size(); ++j) {
    if (!frames[j].pixels) throw DataError(fmt::format("hdr: frame {} has no pixels", j + 1));
    m.check_frame(*frames[j].pixels, frames[j].exposure_s, j);
  }
  std::size_t j_short = 0, j_long = 0;
  std::vector<double> exposures;
  std::vector<detail::Frame> kframes;
  for (std::size_t j = 0; j < frames.size(); ++j) {
    exposures.push_back(frames[j].exposure_s);
    kframes.push_back(detail::make_frame(frames[j].pixels->data(), frames[j].exposure_s));
    if (frames[j].exposure_s < frames[j_short].exposure_s) j_short = j;
    if (frames[j].exposure_s > frames[j_long].exposure_s) j_long = j;
  }
  HdrResult result;
  result.image = m.make_image(exposures);
  const std::size_t V = m.values();
  const std::size_t tile = m.tile_values;
  const std::size_t tiles = (V + tile - 1) / tile;
  tbb::combinable<HdrCounts> counts;
  tbb::combinable<BlockBuffers> buffers([&] { return BlockBuffers(frames.size()); });
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, tiles, 1), [&](const auto& r) {
    BlockBuffers& b = buffers.local();
    HdrCounts& n = counts.local();
    for (std::size_t ti = r.begin(); ti < r.end(); ++ti) {
      const std::size_t t1 = std::min(V, (ti + 1) * tile);
      for (std::size_t v0 = ti * tile; v0 < t1; v0 += kBlockValues) {
        const std::size_t mv = std::min(kBlockValues, t1 - v0);
        std::fill_n(b.acc.begin(), mv, Float4{0.0f, 0.0f, 0.0f, 0.0f});
        m.kernels->accumulate(m.tables, kframes.data(), kframes.size(), v0, mv, b.acc.data(), b.off.data(),
                              b.tf.data());
        m.finalise(v0, mv, b.acc.data(), frames[j_short].pixels->data(), frames[j_short].exposure_s,
                   frames[j_long].pixels->data(), frames[j_long].exposure_s, &result.image, &n);
      }
    }
  });
  HdrCounts total;
  add_counts(counts, &total);
  result.stats = m.stats_of(total);
  return result;
}

// ---------------------------------------------------------------------------------------------
// Streaming

struct HdrAccumulator::State {
  const HdrMerger::Impl* merger = nullptr;
  std::vector<Float4> acc;                 // per value: the kernels' accumulators
  Image<std::uint16_t> shortest, longest;  // copies: bounds for values no exposure measured
  double t_short = 0.0, t_long = 0.0;
  std::vector<double> exposures;
  bool spent = false;
};

HdrAccumulator::HdrAccumulator(std::unique_ptr<State> state) : state_(std::move(state)) {}
HdrAccumulator::~HdrAccumulator() = default;
HdrAccumulator::HdrAccumulator(HdrAccumulator&&) noexcept = default;
HdrAccumulator& HdrAccumulator::operator=(HdrAccumulator&&) noexcept = default;

HdrAccumulator HdrMerger::accumulator() const {
  auto st = std::make_unique<HdrAccumulator::State>();
  st->merger = impl_.get();
  const std::size_t V = impl_->values();
  st->acc.assign(V, Float4{0.0f, 0.0f, 0.0f, 0.0f});
  return HdrAccumulator(std::move(st));
}

int HdrAccumulator::frames() const { return static_cast<int>(state_->exposures.size()); }

void HdrAccumulator::add(const Image<std::uint16_t>& pixels, double exposure_s) {
  State& st = *state_;
  if (st.spent) throw DataError("hdr: add() after finish()");
  const HdrMerger::Impl& m = *st.merger;
  m.check_frame(pixels, exposure_s, st.exposures.size());
  const std::size_t V = m.values();
  const std::size_t tile = m.tile_values;
  const detail::Frame frame = detail::make_frame(pixels.data(), exposure_s);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, (V + tile - 1) / tile, 1), [&](const auto& r) {
    alignas(64) int off[kBlockValues];
    alignas(64) float tf[kBlockValues];
    for (std::size_t ti = r.begin(); ti < r.end(); ++ti) {
      const std::size_t t1 = std::min(V, (ti + 1) * tile);
      for (std::size_t v0 = ti * tile; v0 < t1; v0 += kBlockValues)
        m.kernels->accumulate(m.tables, &frame, 1, v0, std::min(kBlockValues, t1 - v0), st.acc.data() + v0, off, tf);
    }
  });
  if (st.exposures.empty() || exposure_s < st.t_short) {
    st.shortest = pixels;
    st.t_short = exposure_s;
  }
  if (st.exposures.empty() || exposure_s > st.t_long) {
    st.longest = pixels;
    st.t_long = exposure_s;
  }
  st.exposures.push_back(exposure_s);
}

HdrResult HdrAccumulator::finish() {
  State& st = *state_;
  if (st.spent) throw DataError("hdr: finish() called twice");
  if (st.exposures.empty()) throw DataError("hdr: no frames were added");
  st.spent = true;
  const HdrMerger::Impl& m = *st.merger;
  HdrResult result;
  result.image = m.make_image(st.exposures);
  const std::size_t V = m.values();
  const std::size_t tile = m.tile_values;
  tbb::combinable<HdrCounts> counts;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, (V + tile - 1) / tile, 1), [&](const auto& r) {
    auto& n = counts.local();
    for (std::size_t ti = r.begin(); ti < r.end(); ++ti) {
      const std::size_t t1 = std::min(V, (ti + 1) * tile);
      for (std::size_t v0 = ti * tile; v0 < t1; v0 += kBlockValues)
        m.finalise(v0, std::min(kBlockValues, t1 - v0), st.acc.data() + v0, st.shortest.data(), st.t_short, st.longest.data(), st.t_long, &result.image, &n);
    }
  });
  HdrCounts total;
  add_counts(counts, &total);
  result.stats = m.stats_of(total);
  std::vector<Float4>().swap(st.acc);
  return result;
}

HdrResult merge_hdr(std::span<const calib::StackFrame> frames, int bit_depth, const HdrCalibration& calibration,
                    const HdrOptions& options) {
  if (frames.empty() || !frames[0].pixels) throw DataError("hdr: no frames to merge");
  const auto& first = *frames[0].pixels;
  HdrMerger merger(calibration, options, first.width(), first.height(), first.channels(), bit_depth);
  return merger.merge(frames);
}

}  // namespace paintlab::acq
