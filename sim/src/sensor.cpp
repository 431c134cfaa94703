#include "paintlab/sim/sensor.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <string>

#include "paintlab/core/error.h"
#include "parallel.h"
#include "rng.h"

namespace paintlab::sim {

namespace detail {

double inverse_normal_cdf(double p) {
  double lo = -40.0, hi = 40.0;
  for (int i = 0; i < 200; ++i) {
    double mid = 0.5 * (lo + hi);
    double cdf = 0.5 * std::erfc(-mid / std::sqrt(2.0));
    (cdf < p ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

NormalTable::NormalTable() {
  constexpr int n = 4097;
  for (int k = 0; k < n; ++k) nodes_[k] = static_cast<float>(inverse_normal_cdf((k + 0.5) / n));
  // Variance of the piecewise-linear sampler: mean over segments of (a^2 + ab + b^2) / 3.
  double var = 0;
  for (int k = 0; k + 1 < n; ++k) {
    double a = nodes_[k], b = nodes_[k + 1];
    var += (a * a + a * b + b * b) / 3.0;
  }
  var /= (n - 1);
  float scale = static_cast<float>(1.0 / std::sqrt(var));
  for (auto& v : nodes_) v *= scale;
}

const NormalTable& NormalTable::get() {
  static const NormalTable table;
  return table;
}

}  // namespace detail

namespace {
// Stream ids of the counter-based generator.
constexpr std::uint64_t kStreamPrnu = 0x5052'4e55;   // "PRNU"
constexpr std::uint64_t kStreamHot = 0x484f'5450;    // "HOTP"
constexpr std::uint64_t kStreamFrame = 0x4652'414d;  // "FRAM"
constexpr double kPlanck = 6.62607015e-34;
constexpr double kLightSpeed = 2.99792458e8;
}  // namespace

ResponseCurve::ResponseCurve(std::vector<double> coefficients) : c_(std::move(coefficients)) {
  if (c_.empty()) throw DataError("response curve: needs at least one coefficient");
  linear_ = c_.size() == 1 || std::all_of(c_.begin() + 1, c_.end(), [](double v) { return v == 0.0; });
}

double ResponseCurve::operator()(double x) const {
  if (x <= 0) return c_[0] * x;
  double y = 0;
  for (std::size_t k = c_.size(); k-- > 0;) y = (y + c_[k]) * x;
  return y;
}

double ResponseCurve::slope(double x) const {
  if (x <= 0) return c_[0];
  double d = 0;
  for (std::size_t k = c_.size(); k-- > 0;) d = d * x + static_cast<double>(k + 1) * c_[k];
  return d;
}

double ResponseCurve::inverse(double y) const {
  y = std::clamp(y, 0.0, 1.0);
  double lo = 0, hi = 1;
  for (int i = 0; i < 80; ++i) {
    double mid = 0.5 * (lo + hi);
    ((*this)(mid) < y ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

Sensor::Sensor(const CameraModel& camera, const SensorParams& params, std::uint64_t seed)
    : p_(params), response_(params.response_poly), seed_(seed), width_(camera.width()), height_(camera.height()) {
  const auto& m = camera.truth().rgb_matrix;
  const auto& gain = camera.truth().rgb_gain;
  for (std::size_t j = 0; j < 3; ++j)
    for (std::size_t c = 0; c < 3; ++c) {
      mix_[j * 3 + c] = gain[j] * m[j * 3 + c];
      if (mix_[j * 3 + c] != (j == c ? 1.0 : 0.0)) mix_identity_ = false;
    }
  double photon_j = kPlanck * kLightSpeed / (p_.wavelength_nm * 1e-9);
  double area = camera.truth().pixel_size_m * camera.truth().pixel_size_m;
  double base = p_.qe * area * camera.irradiance_per_radiance() / photon_j;
  double half_diag2 = 0.25 * (static_cast<double>(width_) * width_ + static_cast<double>(height_) * height_);
  const auto& v = camera.truth().vignetting;
  const auto& table = detail::NormalTable::get();
  gain_map_.resize(static_cast<std::size_t>(width_) * height_);
  camera.corner_grid();
  detail::parallel_rows(height_, 0, [&](int y) {
    for (int x = 0; x < width_; ++x) {
      Vec2 xn = camera.grid_point(x, y, 0.5, 0.5);
      double cos2 = 1.0 / (1.0 + xn.squaredNorm());
      double rho2 = (Vec2(x, y) - Vec2(camera.truth().cx_px, camera.truth().cy_px)).squaredNorm() / half_diag2;
      double vig = cos2 * cos2 * (1.0 + v[0] * rho2 + v[1] * rho2 * rho2);
      std::size_t i = static_cast<std::size_t>(y) * width_ + x;
      double prnu = 1.0 + p_.prnu_rel * table(static_cast<std::uint32_t>(detail::hash_key(seed_, kStreamPrnu, i) >> 32));
      gain_map_[i] = static_cast<float>(base * vig * std::max(prnu, 0.0));
    }
  });
  if (p_.hot_pixel_frac > 0) {
    for (std::size_t i = 0; i < gain_map_.size(); ++i)
      if (detail::uniform01(detail::hash_key(seed_, kStreamHot, i)) < p_.hot_pixel_frac)
        hot_.push_back(static_cast<std::uint32_t>(i));
  }
}

double Sensor::electrons_per_s_per_radiance(int x, int y) const {
  return gain_map_[static_cast<std::size_t>(y) * width_ + x];
}

double Sensor::dark_e_per_s(int x, int y) const {
  auto i = static_cast<std::uint32_t>(static_cast<std::size_t>(y) * width_ + x);
  return std::binary_search(hot_.begin(), hot_.end(), i) ? p_.hot_pixel_dark_e_per_s : p_.dark_current_e_per_s;
}

double Sensor::gain_dn_per_e(double gain_db) const { return p_.gain0_dn_per_e() * std::pow(10.0, gain_db / 20.0); }

double Sensor::mean_electrons(double radiance, int x, int y, double exposure_s) const {
  return radiance * static_cast<double>(electrons_per_s_per_radiance(x, y)) * exposure_s +
         dark_e_per_s(x, y) * exposure_s;
}

double Sensor::raw_from_electrons(double electrons, double gain_db) const {
  double range = p_.adc_max_dn() - p_.black_level_dn;
  double e = std::min(electrons, p_.full_well_e);
  double x = std::min(e * gain_dn_per_e(gain_db) / range, 1.0);
  return std::clamp(p_.black_level_dn + response_(x) * range, 0.0, p_.adc_max_dn());
}

double Sensor::expected_raw(double radiance, int x, int y, double exposure_s, double gain_db) const {
  return raw_from_electrons(mean_electrons(radiance, x, y, exposure_s), gain_db);
}

namespace {

// exp(-x) for x in [0, 700) to ~2e-7 relative: 2^-i built from its bits times a degree-6
// polynomial of exp on [-ln2/2, ln2/2] in Estrin's form (short dependency chains). The
// Poisson sampler calls it for every pixel below 20 electrons.
inline double exp_neg(double x) {
  double t = x * 1.4426950408889634;  // log2(e)
  double i = std::nearbyint(t);
  double y = (i - t) * 0.6931471805599453;  // in [-ln2/2, ln2/2]
  double y2 = y * y;
  double p = (1.0 + y) + y2 * (0.5 + y * (1.0 / 6)) + (y2 * y2) * ((1.0 / 24) + y * (1.0 / 120) + y2 * (1.0 / 720));
  return p * std::bit_cast<double>(static_cast<std::uint64_t>(1023 - static_cast<std::int64_t>(i)) << 52);
}

// 1 / k for the Poisson recursion.
inline const std::array<double, 201>& reciprocals() {
  static const auto table = [] {
    std::array<double, 201> t{};
    for (int k = 1; k <= 200; ++k) t[static_cast<std::size_t>(k)] = 1.0 / k;
    return t;
  }();
  return table;
}

// The whole chain for one pixel value, with every constant of the exposure.
struct Chain {
  double dark_mu, read, read2, full_well, norm, range, black, adc_max;
  int shift_left, shift_right;
  bool linear;
  std::array<double, 8> c{};  // response coefficients
  int nc = 1;
  const detail::NormalTable* normal;
  const std::array<double, 201>* inv;

  [[gnu::always_inline]] inline std::uint16_t operator()(double mu, std::uint64_t bits) const {
    float z = (*normal)(static_cast<std::uint32_t>(bits >> 32));
    double e;
    if (mu >= 20.0) {
      e = mu + std::sqrt(mu + read2) * z;
    } else {
      // Poisson by inversion of its CDF with the low 32 bits.
      double u = static_cast<double>(bits & 0xFFFFFFFFull) * 0x1.0p-32;
      // The first four thresholds without branches (the outcome is random, so branches
      // would mispredict), then the rare longer tail.
      const auto& r = *inv;
      double p1 = exp_neg(mu), p2 = p1 * mu, p3 = p2 * mu * r[2], p4 = p3 * mu * r[3];
      double c1 = p1, c2 = c1 + p2, c3 = c2 + p3, c4 = c3 + p4;
      int k = (u > c1) + (u > c2) + (u > c3) + (u > c4);
      if (k == 4) {  // K >= 4: p = P(3), cdf = P(<= 3)
        double p = p4, cdf = c4;
        for (;;) {
          p *= mu * r[static_cast<std::size_t>(k)];  // P(k)
          cdf += p;                                  // P(<= k)
          if (!(u > cdf) || k >= 200) break;
          ++k;
        }
      }
      e = k + read * z;
    }
    e = std::min(e, full_well);
    double x = std::min(e * norm, 1.0);
    double y = x;
    if (!linear) {
      if (x <= 0) {
        y = c[0] * x;
      } else {
        y = 0;
        for (int k = nc; k-- > 0;) y = (y + c[static_cast<std::size_t>(k)]) * x;
      }
    }
    double v = std::clamp(black + y * range, 0.0, adc_max);
    auto q = static_cast<std::uint32_t>(v + 0.5);
    return static_cast<std::uint16_t>(shift_left ? (q << shift_left) : (q >> shift_right));
  }
};

}  // namespace

Image<std::uint16_t> Sensor::expose(const ImageF& radiance, const ExposureSettings& s, int threads) {
  if (radiance.width() != width_ || radiance.height() != height_ || (radiance.channels() != 1 && radiance.channels() != 3))
    throw DataError("sensor: radiance image is " + std::to_string(radiance.width()) + "x" +
                    std::to_string(radiance.height()) + "x" + std::to_string(radiance.channels()) + ", expected " +
                    std::to_string(width_) + "x" + std::to_string(height_) + " with 1 or 3 channels");
  if (!(s.exposure_s >= 0) || !std::isfinite(s.exposure_s)) throw DataError("sensor: exposure must be >= 0 s");
  int out_bits = s.output_bits == 0 ? p_.adc_bits : s.output_bits;
  if (out_bits < 8 || out_bits > 16) throw DataError("sensor: output bits must be 8..16");
  std::uint64_t frame = s.frame_index ? *s.frame_index : frames_.fetch_add(1);
  if (s.frame_index) frames_.store(std::max(frames_.load(), *s.frame_index + 1));

  Chain k{};
  k.dark_mu = p_.dark_current_e_per_s * s.exposure_s;
  k.read = p_.read_noise_e;
  k.read2 = p_.read_noise_e * p_.read_noise_e;
  k.full_well = p_.full_well_e;
  k.range = p_.adc_max_dn() - p_.black_level_dn;
  k.norm = gain_dn_per_e(s.gain_db) / k.range;
  k.black = p_.black_level_dn;
  k.adc_max = p_.adc_max_dn();
  k.shift_left = std::max(0, out_bits - p_.adc_bits);
  k.shift_right = std::max(0, p_.adc_bits - out_bits);
  k.linear = response_.linear();
  const auto& coeffs = response_.coefficients();
  if (coeffs.size() > k.c.size()) throw DataError("sensor: the response curve has more than 8 coefficients");
  std::copy(coeffs.begin(), coeffs.end(), k.c.begin());
  k.nc = static_cast<int>(coeffs.size());
  k.normal = &detail::NormalTable::get();
  k.inv = &reciprocals();

  const int channels = radiance.channels();
  if (s.cfa && s.mono_mix) throw DataError("sensor: an exposure has a colour-filter array or a mono filter mix, not both");
  const bool one_of_three = s.cfa || s.mono_mix;
  if (one_of_three && channels != 3)
    throw DataError("sensor: a colour-filter array or a filter mix needs a 3-channel (scene RGB) radiance image");
  if (s.cfa)
    for (int c : *s.cfa)
      if (c < 0 || c > 2) throw DataError("sensor: a colour-filter array entry must be 0 (R), 1 (G) or 2 (B)");
  const int out_channels = one_of_three ? 1 : channels;
  Image<std::uint16_t> out(width_, height_, out_channels);
  const std::uint64_t key = detail::hash_key(seed_, kStreamFrame, frame);
  const float* in = radiance.data();
  std::uint16_t* dst = out.data();
  const float* gmap = gain_map_.data();
  const double t = s.exposure_s;
  // The radiance pixel p's camera channel j sees (the channel mix applied, never negative).
  const std::array<double, 9>& mix = mix_;
  const bool identity = mix_identity_;
  const auto camera_channel = [in, &mix, identity](std::size_t p, int j) {
    const float* L = in + p * 3;
    if (identity) return std::max(static_cast<double>(L[j]), 0.0);
    const double* r = mix.data() + 3 * j;
    return std::max(r[0] * L[0] + r[1] * L[1] + r[2] * L[2], 0.0);
  };
  // The one-channel value a pixel records under a CFA or a filter mix.
  std::array<double, 3> filter{};
  if (s.mono_mix)
    for (std::size_t c = 0; c < 3; ++c)
      filter[c] = (*s.mono_mix)[c];
  const auto sampled = [&](std::size_t p, int x, int y) {
    if (s.cfa) return camera_channel(p, (*s.cfa)[static_cast<std::size_t>(2 * (y & 1) + (x & 1))]);
    const float* L = in + p * 3;
    return std::max(filter[0] * L[0] + filter[1] * L[1] + filter[2] * L[2], 0.0);
  };
  detail::parallel_rows(height_, threads, [&](int y) {
    std::size_t p0 = static_cast<std::size_t>(y) * width_;
    if (channels == 1) {
      for (int x = 0; x < width_; ++x) {
        std::size_t i = p0 + x;
        double mu = std::max(static_cast<double>(in[i]), 0.0) * (static_cast<double>(gmap[i]) * t) + k.dark_mu;
        dst[i] = k(mu, detail::mix64(key + i));
      }
      return;
    }
    if (one_of_three) {
      for (int x = 0; x < width_; ++x) {
        std::size_t p = p0 + x;
        dst[p] = k(sampled(p, x, y) * (static_cast<double>(gmap[p]) * t) + k.dark_mu, detail::mix64(key + p));
      }
      return;
    }
    for (int x = 0; x < width_; ++x) {
      std::size_t p = p0 + x;
      double g = static_cast<double>(gmap[p]) * t;
      for (int c = 0; c < channels; ++c) {
        std::size_t i = p * channels + c;
        dst[i] = k(camera_channel(p, c) * g + k.dark_mu, detail::mix64(key + i));
      }
    }
  });
  // Hot pixels: the same noise bits, a higher dark current.
  double hot_mu = p_.hot_pixel_dark_e_per_s * s.exposure_s;
  for (std::uint32_t p : hot_) {
    double g = static_cast<double>(gmap[p]) * t;
    if (one_of_three) {
      const int x = static_cast<int>(p % static_cast<std::uint32_t>(width_)), y = static_cast<int>(p / static_cast<std::uint32_t>(width_));
      dst[p] = k(sampled(p, x, y) * g + hot_mu, detail::mix64(key + p));
      continue;
    }
    for (int c = 0; c < channels; ++c) {
      std::size_t i = static_cast<std::size_t>(p) * channels + c;
      const double L = channels == 1 ? std::max(static_cast<double>(in[i]), 0.0) : camera_channel(p, c);
      dst[i] = k(L * g + hot_mu, detail::mix64(key + i));
    }
  }
  return out;
}

}  // namespace paintlab::sim
