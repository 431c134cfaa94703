#include "paintlab/acquisition/hdr_merge.h"

#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <tbb/combinable.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "paintlab/core/error.h"

namespace paintlab::acq {

void HdrOptions::check() const {
  if (tile_values < 64) throw UsageError(fmt::format("hdr: tile_values = {}; must be >= 64", tile_values));
  if (!std::isfinite(saturation_dn) || !std::isfinite(floor_dn) || !std::isfinite(black_dn))
    throw UsageError("hdr: saturation_dn, floor_dn and black_dn must be finite");
  if (!(noise.read_noise_dn >= 0.0) || !(noise.gain_dn_per_e >= 0.0))
    throw UsageError("hdr: the noise model's read_noise_dn and gain_dn_per_e must be >= 0");
}

namespace {

// Per dark-subtracted integer value u (with a per-pixel dark map): the weighted linear value
// a + frac * b, the weight w and w^2 x variance.
struct Entry {
  float a, b, w, wv;
};
// Per raw value (without a dark map, saturation folded in): weighted linear value, weight,
// w^2 x variance.
struct CodeEntry {
  float a, w, wv;
};
// The same as four floats {a, w, wv, 0} for the batch merge, whose accumulators are
// interleaved {s1, s2, s3, -} per value: one 16-byte multiply-add per value and frame.
typedef float Float4 __attribute__((vector_size(16)));

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
  std::vector<std::vector<Entry>> lut;   // [channel][i]
  std::vector<std::vector<CodeEntry>> code_lut;  // [channel][raw value]
  std::vector<std::vector<Float4>> code_lut4;    // [channel][raw value]: {a, w, wv, 0}
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

  // Adds one frame's contribution to the accumulators of values [v0, v1) (whole pixels).
  void accumulate(const std::uint16_t* z, double exposure_s, std::size_t v0, std::size_t v1, float* s1, float* s2,
                  float* s3) const {
    const float t = static_cast<float>(exposure_s);
    const float t2 = t * t;
    if (!dark) {
      if (C == 1) {
        const CodeEntry* e = code_lut[0].data();
        for (std::size_t v = v0; v < v1; ++v) {
          const CodeEntry& x = e[z[v]];
          const std::size_t i = v - v0;
          s1[i] += t * x.a;
          s2[i] += t2 * x.w;
          s3[i] += t2 * x.wv;
        }
      } else {
        const CodeEntry* e[3] = {code_lut[0].data(), code_lut[1].data(), code_lut[2].data()};
        for (std::size_t v = v0; v < v1; v += 3)
          for (int c = 0; c < 3; ++c) {
            const CodeEntry& x = e[c][z[v + c]];
            const std::size_t i = v + c - v0;
            s1[i] += t * x.a;
            s2[i] += t2 * x.w;
            s3[i] += t2 * x.wv;
          }
      }
      return;
    }
    if (C == 1) accumulate_dark<1>(z, t, v0, v1, s1, s2, s3);
    else accumulate_dark<3>(z, t, v0, v1, s1, s2, s3);
  }

  // Without a dark map, into interleaved accumulators {s1, s2, s3, -}.
  void accumulate_codes(const std::uint16_t* z, double exposure_s, std::size_t v0, std::size_t v1,
                        Float4* acc) const {
    const float t = static_cast<float>(exposure_s);
    const Float4 tv{t, t * t, t * t, 0.0f};
    if (C == 1) {
      const Float4* e = code_lut4[0].data();
      for (std::size_t v = v0; v < v1; ++v) acc[v - v0] += tv * e[z[v]];
    } else {
      const Float4* e[3] = {code_lut4[0].data(), code_lut4[1].data(), code_lut4[2].data()};
      for (std::size_t v = v0; v < v1; v += 3)
        for (int c = 0; c < 3; ++c) acc[v + c - v0] += tv * e[c][z[v + c]];
    }
  }

  // With a dark map: u = z - (bias + rate t) per value, linear value interpolated in the
  // table of integer u. In blocks: first the table index and fraction of every value (a loop
  // the compiler vectorises; the index is computed in float from u - u_lo >= 0, where
  // truncation is floor, and saturated raw values go to the table's all-zero last entry),
  // then the table look-ups.
  template <int kChannels>
#if defined(__GNUC__) && !defined(__clang__)
  __attribute__((optimize("tree-vectorize", "vect-cost-model=dynamic")))
#endif
  void accumulate_dark(const std::uint16_t* z, float t, std::size_t v0, std::size_t v1, float* s1, float* s2,
                       float* s3) const {
    constexpr std::size_t kBlock = 1020;  // a multiple of 3 (whole RGB pixels) and of 4
    const float* bias = dark->bias_dn.data();
    const float* rate = dark->rate_dn_per_s.data();
    const std::size_t n = lut[0].size();
    const float top = static_cast<float>(n - 3);  // the last entry with a real neighbour above
    const int zero = static_cast<int>(n - 1);
    const float offset = static_cast<float>(u_lo);
    const float t2 = t * t;
    const float saturation = sat;
    const Entry* e[3] = {lut[0].data(), lut[kChannels == 3 ? 1 : 0].data(), lut[kChannels == 3 ? 2 : 0].data()};
    alignas(64) int idx[kBlock];
    alignas(64) float fr[kBlock];
    for (std::size_t b0 = v0; b0 < v1; b0 += kBlock) {
      const std::size_t m = std::min(kBlock, v1 - b0);
      const std::uint16_t* zb = z + b0;
      const float* bb = bias + b0;
      const float* rb = rate + b0;
      for (std::size_t k = 0; k < m; ++k) {
        const float zz = static_cast<float>(zb[k]);
        float x = zz - (bb[k] + rb[k] * t) - offset;
        x = x > 0.0f ? x : 0.0f;
        x = x < top ? x : top;
        const int i = static_cast<int>(x);
        fr[k] = x - static_cast<float>(i);
        idx[k] = zero + (i - zero) * static_cast<int>(zz < saturation);
      }
      float* a1 = s1 + (b0 - v0);
      float* a2 = s2 + (b0 - v0);
      float* a3 = s3 + (b0 - v0);
      for (std::size_t k = 0; k < m; k += kChannels)
        for (int c = 0; c < kChannels; ++c) {
          const std::size_t q = k + static_cast<std::size_t>(c);
          const Entry& en = e[c][idx[q]];
          a1[q] += t * (en.a + fr[q] * en.b);
          a2[q] += t2 * en.w;
          a3[q] += t2 * en.wv;
        }
    }
  }

  struct Counts {
    long long valid = 0, saturated = 0, dark = 0, hot = 0;
  };

  // Turns the accumulators of values [v0, v1) into radiance, variance and validity.
  // `shortest`/`longest`: the frames with the shortest and longest exposure (bounds for
  // values no exposure measured).
  void finalise(std::size_t v0, std::size_t v1, const float* s1, const float* s2, const float* s3,
                const std::uint16_t* shortest, double t_short, const std::uint16_t* longest, double t_long,
                ExrImage* out, Counts* counts) const {
    const float inf = std::numeric_limits<float>::infinity();
    float* valid_plane = out->planes[static_cast<std::size_t>(2 * C)].data();
    for (std::size_t v = v0; v < v1; v += C) {
      const std::size_t p = v / C;
      bool ok = true;
      bool saturated = false;
      for (int c = 0; c < C; ++c) {
        const std::size_t i = v + c - v0;
        float e, var;
        if (s2[i] > 0.0f) {
          e = s1[i] / s2[i];
          var = s3[i] / (s2[i] * s2[i]);
        } else {
          ok = false;
          var = inf;
          if (static_cast<float>(shortest[v + c]) >= sat) {
            saturated = true;
            e = static_cast<float>(y_sat[c] / t_short);
          } else {
            const double d = dark ? dark->level(v + c, t_long) : black[c];
            e = static_cast<float>(std::max(0.0, linear(c, longest[v + c] - d)) / t_long);
          }
        }
        if (flat) {
          const float g = flat->gain.data()[v + c];
          e /= g;
          var /= g * g;
        }
        out->planes[static_cast<std::size_t>(c)].data()[p] = e;
        out->planes[static_cast<std::size_t>(C + c)].data()[p] = var;
      }
      const bool hot = dark && dark->hot.data()[p];
      if (hot) {
        ok = false;
        for (int c = 0; c < C; ++c) out->planes[static_cast<std::size_t>(C + c)].data()[p] = inf;
      }
      valid_plane[p] = ok ? 1.0f : 0.0f;
      if (ok) ++counts->valid;
      else if (hot) ++counts->hot;
      else if (saturated) ++counts->saturated;
      else ++counts->dark;
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
    for (const auto& n : names) {
      img.names.push_back(n);
      img.planes.emplace_back(W, H, 1);
    }
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

  HdrStats stats_of(const Counts& n) const {
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
    m.code_lut.assign(channels, std::vector<CodeEntry>(65536));
    for (int c = 0; c < channels; ++c) {
      std::vector<double> w(m.code_lut[c].size());
      double wmax = 0.0;
      for (std::size_t z = 0; z < w.size(); ++z) {
        w[z] = static_cast<double>(z) >= m.window.saturation_dn ? 0.0 : weight(c, z - m.window.black_dn);
        wmax = std::max(wmax, w[z]);
      }
      for (std::size_t z = 0; z < w.size(); ++z) {
        const double u = static_cast<double>(z) - m.window.black_dn;
        const double wn = wmax > 0.0 ? w[z] / wmax : 0.0;
        m.code_lut[c][z] = {static_cast<float>(wn * m.linear(c, u)), static_cast<float>(wn),
                            static_cast<float>(wn * wn * variance(c, u))};
      }
    }
    m.code_lut4.assign(channels, std::vector<Float4>(65536));
    for (int c = 0; c < channels; ++c)
      for (std::size_t z = 0; z < 65536; ++z) {
        const CodeEntry& e = m.code_lut[c][z];
        m.code_lut4[c][z] = Float4{e.a, e.w, e.wv, 0.0f};
      }
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
    // One more entry, all zero: where accumulate_dark() sends saturated raw values.
    m.lut.assign(channels, std::vector<Entry>(n + 1, Entry{0.0f, 0.0f, 0.0f, 0.0f}));
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
        m.lut[c][i] = {static_cast<float>(wn * y0), static_cast<float>(wn * (y1 - y0)), static_cast<float>(wn),
                       static_cast<float>(wn * wn * variance(c, u))};
      }
    }
  }
}

HdrMerger::~HdrMerger() = default;

int HdrMerger::width() const { return impl_->W; }
int HdrMerger::height() const { return impl_->H; }
int HdrMerger::channels() const { return impl_->C; }
int HdrMerger::bit_depth() const { return impl_->bits; }
const calib::ValueWindow& HdrMerger::window() const { return impl_->window; }
calib::Weighting HdrMerger::weighting() const { return impl_->weighting; }

HdrResult HdrMerger::merge(std::span<const calib::StackFrame> frames) const {
  const Impl& m = *impl_;
  if (frames.empty()) throw DataError("hdr: no frames to merge");
  for (std::size_t j = 0; j < frames.size(); ++j) {
    if (!frames[j].pixels) throw DataError(fmt::format("hdr: frame {} has no pixels", j + 1));
    m.check_frame(*frames[j].pixels, frames[j].exposure_s, j);
  }
  std::size_t j_short = 0, j_long = 0;
  std::vector<double> exposures;
  for (std::size_t j = 0; j < frames.size(); ++j) {
    exposures.push_back(frames[j].exposure_s);
    if (frames[j].exposure_s < frames[j_short].exposure_s) j_short = j;
    if (frames[j].exposure_s > frames[j_long].exposure_s) j_long = j;
  }
  HdrResult result;
  result.image = m.make_image(exposures);
  const std::size_t V = m.values();
  const std::size_t tile = m.tile_values;
  const std::size_t tiles = (V + tile - 1) / tile;
  tbb::combinable<Impl::Counts> counts;
  struct Buffers {
    std::vector<float> s1, s2, s3;
    std::vector<Float4> acc;
  };
  tbb::combinable<Buffers> buffers([&] {
    return Buffers{std::vector<float>(tile), std::vector<float>(tile), std::vector<float>(tile),
                   std::vector<Float4>(m.dark ? 0 : tile)};
  });
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, tiles, 1), [&](const auto& r) {
    Buffers& b = buffers.local();
    Impl::Counts& n = counts.local();
    for (std::size_t ti = r.begin(); ti < r.end(); ++ti) {
      const std::size_t v0 = ti * tile;
      const std::size_t v1 = std::min(V, v0 + tile);
      std::fill_n(b.s1.begin(), v1 - v0, 0.0f);
      std::fill_n(b.s2.begin(), v1 - v0, 0.0f);
      std::fill_n(b.s3.begin(), v1 - v0, 0.0f);
      if (m.dark) {
        for (const auto& f : frames)
          m.accumulate(f.pixels->data(), f.exposure_s, v0, v1, b.s1.data(), b.s2.data(), b.s3.data());
      } else {
        std::fill_n(b.acc.begin(), v1 - v0, Float4{0.0f, 0.0f, 0.0f, 0.0f});
        for (const auto& f : frames) m.accumulate_codes(f.pixels->data(), f.exposure_s, v0, v1, b.acc.data());
        for (std::size_t i = 0; i < v1 - v0; ++i) {
          b.s1[i] = b.acc[i][0];
          b.s2[i] = b.acc[i][1];
          b.s3[i] = b.acc[i][2];
        }
      }
      m.finalise(v0, v1, b.s1.data(), b.s2.data(), b.s3.data(), frames[j_short].pixels->data(),
                 frames[j_short].exposure_s, frames[j_long].pixels->data(), frames[j_long].exposure_s, &result.image,
                 &n);
    }
  });
  Impl::Counts total;
  counts.combine_each([&](const Impl::Counts& n) {
    total.valid += n.valid;
    total.saturated += n.saturated;
    total.dark += n.dark;
    total.hot += n.hot;
  });
  result.stats = m.stats_of(total);
  return result;
}

// ---------------------------------------------------------------------------------------------
// Streaming

struct HdrAccumulator::State {
  const HdrMerger::Impl* merger = nullptr;
  std::vector<float> s1, s2, s3;
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
  st->s1.assign(V, 0.0f);
  st->s2.assign(V, 0.0f);
  st->s3.assign(V, 0.0f);
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
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, (V + tile - 1) / tile, 1), [&](const auto& r) {
    for (std::size_t ti = r.begin(); ti < r.end(); ++ti) {
      const std::size_t v0 = ti * tile;
      const std::size_t v1 = std::min(V, v0 + tile);
      m.accumulate(pixels.data(), exposure_s, v0, v1, st.s1.data() + v0, st.s2.data() + v0, st.s3.data() + v0);
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
  tbb::combinable<HdrMerger::Impl::Counts> counts;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, (V + tile - 1) / tile, 1), [&](const auto& r) {
    auto& n = counts.local();
    for (std::size_t ti = r.begin(); ti < r.end(); ++ti) {
      const std::size_t v0 = ti * tile;
      const std::size_t v1 = std::min(V, v0 + tile);
      m.finalise(v0, v1, st.s1.data() + v0, st.s2.data() + v0, st.s3.data() + v0, st.shortest.data(), st.t_short,
                 st.longest.data(), st.t_long, &result.image, &n);
    }
  });
  HdrMerger::Impl::Counts total;
  counts.combine_each([&](const HdrMerger::Impl::Counts& n) {
    total.valid += n.valid;
    total.saturated += n.saturated;
    total.dark += n.dark;
    total.hot += n.hot;
  });
  result.stats = m.stats_of(total);
  std::vector<float>().swap(st.s1);
  std::vector<float>().swap(st.s2);
  std::vector<float>().swap(st.s3);
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
