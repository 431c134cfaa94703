#include "paintlab/fitting/fit_data.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <fmt/format.h>

#include "fit_util.h"
#include "paintlab/core/enum_names.h"
#include "paintlab/core/error.h"
#include "paintlab/core/geometry.h"
#include "paintlab/core/robust.h"

namespace paintlab::fit {

namespace {

// Linear residual weights of every fit point (fit_data.h): the reference value from the
// samples of the neighbouring bins, the point's own bins left out, so that a point's weight
// does not depend on its own (sparkle-skewed) value; the per-sample scatter pooled over
// many bins (a cell of one theta_h row and ten theta_d rows, else the whole theta_h row,
// else the rows around it):
// a variance estimated from a few samples would make some weights huge by chance.
template <typename Usable>
void linear_weights(FitData& data, const brdf::MerlTable& table, const std::vector<std::uint32_t>& member_bin,
                    const Usable& usable) {
  const double floor2 = data.options.relative_floor * data.options.relative_floor;
  const int W = data.options.window_phi_d;
  // Which fit point every bin belongs to (-1: none).
  std::vector<std::int32_t> point_of(kMerlBins, -1);
  for (std::size_t q = 0; q < data.bins.size(); ++q) {
    const FitBin& b = data.bins[q];
    for (std::uint32_t m = b.member_begin; m < b.member_begin + b.member_count; ++m)
      point_of[member_bin[m]] = static_cast<std::int32_t>(q);
  }
  // Pooled relative scatter: sum (n - 1) var / sum (n - 1) mean^2 per cell and per row.
  constexpr int kCellRows = 10;  // theta_d rows per cell
  constexpr int kCells = kMerlThetaD / kCellRows;
  constexpr double kMinDof = 50.0;
  struct Pool {
    std::array<double, 3> var{0, 0, 0}, mean2{0, 0, 0};
    double dof = 0;
  };
  std::vector<Pool> cell(static_cast<std::size_t>(kMerlThetaH * kCells)), row(kMerlThetaH);
  if (data.has_statistics)
    for (std::size_t b = 0; b < kMerlBins; ++b) {
      if (table.count(b) < 2 || !usable(b)) continue;
      const brdf::MerlBin mb = brdf::merl_bin_of_flat(b);
      const double dof = static_cast<double>(table.count(b)) - 1.0;
      const brdf::Rgb v = table.value(b), var = table.variance(b);
      for (Pool* p : {&cell[static_cast<std::size_t>(mb.theta_h * kCells + mb.theta_d / kCellRows)], &row[mb.theta_h]}) {
        p->dof += dof;
        for (int c = 0; c < 3; ++c) {
          p->var[c] += dof * var[c];
          p->mean2[c] += dof * v[c] * v[c];
        }
      }
    }
  for (std::size_t q = 0; q < data.bins.size(); ++q) {
    FitBin& b = data.bins[q];
    // The point's bins are consecutive phi_d bins of one (theta_h, theta_d) row.
    const brdf::MerlBin first = brdf::merl_bin_of_flat(member_bin[b.member_begin]);
    const brdf::MerlBin last = brdf::merl_bin_of_flat(member_bin[b.member_begin + b.member_count - 1]);
    std::array<double, 3> sum_v{0, 0, 0};
    double sum_n = 0;
    // The window; twice as wide where it holds fewer samples than the point.
    for (int widen = 1; widen <= 2 && sum_n < std::max(1.0, static_cast<double>(b.count)); ++widen) {
      sum_n = 0;
      sum_v = {0, 0, 0};
      const int dj = widen, dk = W * widen;
      for (int j = first.theta_d - dj; j <= first.theta_d + dj; ++j) {
        if (j < 0 || j >= kMerlThetaD) continue;
        const int k_lo = std::max(0, first.phi_d - dk), k_hi = std::min(kMerlPhiD - 1, last.phi_d + dk);
        for (int k = k_lo; k <= k_hi; ++k) {
          const std::size_t nb = brdf::merl_flat_index({first.theta_h, j, k});
          if (point_of[nb] == static_cast<std::int32_t>(q) || !usable(nb)) continue;
          const brdf::Rgb v = table.value(nb);
          if (!(v > 0.0).all()) continue;
          const double n = data.has_statistics ? static_cast<double>(table.count(nb)) : 1.0;
          sum_n += n;
          for (int c = 0; c < 3; ++c) sum_v[c] += n * v[c];
        }
      }
    }
    // The cell, else the theta_h row, else the rows around it.
    Pool pool = cell[static_cast<std::size_t>(first.theta_h * kCells + first.theta_d / kCellRows)];
    if (pool.dof < kMinDof) pool = row[first.theta_h];
    for (int d = 1; pool.dof < kMinDof && d < kMerlThetaH; ++d)
      for (int i : {first.theta_h - d, first.theta_h + d}) {
        if (i < 0 || i >= kMerlThetaH) continue;
        pool.dof += row[i].dof;
        for (int c = 0; c < 3; ++c) {
          pool.var[c] += row[i].var[c];
          pool.mean2[c] += row[i].mean2[c];
        }
      }
    const double n = std::max(1.0, static_cast<double>(b.count));
    for (int c = 0; c < 3; ++c) {
      if (b.inv_sigma[c] == 0.0) continue;
      const double ref = sum_n > 0.0 && sum_v[c] > 0.0 ? sum_v[c] / sum_n : b.value[c];
      // The point's own noise variance (fit_data.h: noise_sigma^2 = rho / n).
      double rho = b.noise_sigma[c] * b.noise_sigma[c] * n;
      if (pool.dof > 0.0 && pool.mean2[c] > 0.0) rho = std::max(rho, pool.var[c] / pool.mean2[c]);
      b.linear_sigma[c] = std::sqrt(rho / n + floor2);
      b.linear_weight[c] = 1.0 / (b.linear_sigma[c] * ref);
    }
  }
}

// The point variance the delta correction takes (FitDataOptions::point_scatter): at least the
// scatter of the fit points' own log values, measured where the points are, not assumed from
// their samples as spread / n. The samples of a point are not independent under sparkle: a
// glint of one flake seen by one pixel in consecutive images lands in the same bin several
// times, so spread / n understates the variance of the point's mean and the correction of its
// log falls short (the same samples counted twice halve it; docs/fitting.md "Sparkle").
// Measured with second differences along phi_d inside each (theta_h, theta_d) row,
// L(a) - 2 L(b) + L(c) over three consecutive points, whose expectation of the square is
// t2(a) + 4 t2(b) + t2(c) for independent points and free of any linear trend of the model
// along the row; the ratio of the two sums over a window of rows (theta_h +-1, theta_d +-2)
// scales t2 of every point of the window's centre row. Not below 1 (a trend's curvature or a
// lobe changing inside its points reads as scatter the samples do not have, and the samples'
// own spread stays the floor), and only outside the peak (as the spread itself).
void scale_by_point_scatter(FitData& data) {
  constexpr int kRowsH = 1, kRowsD = 2;    // window half widths (rows)
  constexpr double kMinTriples = 30.0;    // below this the window keeps the samples' t2
  struct Sums {
    std::array<double, 3> scatter{0, 0, 0}, expected{0, 0, 0};
    std::array<double, 3> triples{0, 0, 0};
  };
  std::vector<Sums> row(static_cast<std::size_t>(kMerlThetaH * kMerlThetaD));
  auto row_of = [](const FitBin& b) {
    const brdf::MerlBin mb = brdf::merl_bin_of_flat(b.bin);
    return static_cast<std::size_t>(mb.theta_h * kMerlThetaD + mb.theta_d);
  };
  // data.bins is in emission order (theta_h, theta_d, then phi_d ascending): three consecutive
  // points of one row are neighbours along phi_d.
  for (std::size_t q = 0; q + 2 < data.bins.size(); ++q) {
    const FitBin &a = data.bins[q], &b = data.bins[q + 1], &c = data.bins[q + 2];
    const std::size_t r = row_of(b);
    if (row_of(a) != r || row_of(c) != r) continue;
    if (a.region == Region::Peak || b.region == Region::Peak || c.region == Region::Peak) continue;
    for (int k = 0; k < 3; ++k) {
      if (!(a.value[k] > 0.0 && b.value[k] > 0.0 && c.value[k] > 0.0)) continue;
      const double d = std::log(a.value[k]) - 2.0 * std::log(b.value[k]) + std::log(c.value[k]);
      row[r].scatter[k] += d * d;
      row[r].expected[k] += a.bias_variance[k] + 4.0 * b.bias_variance[k] + c.bias_variance[k];
      row[r].triples[k] += 1.0;
    }
  }
  // Window sums from summed-area tables over (theta_h, theta_d).
  constexpr int H = kMerlThetaH, D = kMerlThetaD;
  std::vector<Sums> sat(static_cast<std::size_t>((H + 1) * (D + 1)));
  auto at = [&](int i, int j) -> Sums& { return sat[static_cast<std::size_t>(i * (D + 1) + j)]; };
  for (int i = 0; i < H; ++i)
    for (int j = 0; j < D; ++j) {
      const Sums& s = row[static_cast<std::size_t>(i * D + j)];
      Sums& t = at(i + 1, j + 1);
      const Sums &up = at(i, j + 1), &left = at(i + 1, j), &diag = at(i, j);
      for (int k = 0; k < 3; ++k) {
        t.scatter[k] = s.scatter[k] + up.scatter[k] + left.scatter[k] - diag.scatter[k];
        t.expected[k] = s.expected[k] + up.expected[k] + left.expected[k] - diag.expected[k];
        t.triples[k] = s.triples[k] + up.triples[k] + left.triples[k] - diag.triples[k];
      }
    }
  std::vector<std::array<double, 3>> factor(row.size(), {1.0, 1.0, 1.0});
  for (int i = 0; i < H; ++i)
    for (int j = 0; j < D; ++j) {
      const int i0 = std::max(0, i - kRowsH), i1 = std::min(H, i + kRowsH + 1);
      const int j0 = std::max(0, j - kRowsD), j1 = std::min(D, j + kRowsD + 1);
      const Sums &a = at(i1, j1), &b = at(i0, j1), &c = at(i1, j0), &d = at(i0, j0);
      for (int k = 0; k < 3; ++k) {
        const double scatter = a.scatter[k] - b.scatter[k] - c.scatter[k] + d.scatter[k];
        const double expected = a.expected[k] - b.expected[k] - c.expected[k] + d.expected[k];
        const double triples = a.triples[k] - b.triples[k] - c.triples[k] + d.triples[k];
        if (triples >= kMinTriples && expected > 0.0)
          factor[static_cast<std::size_t>(i * D + j)][k] = std::max(1.0, scatter / expected);
      }
    }
  std::vector<double> glossy;
  for (FitBin& b : data.bins) {
    if (b.region == Region::Peak) continue;
    const auto& f = factor[row_of(b)];
    if (b.region == Region::Glossy)
      for (int k = 0; k < 3; ++k)
        if (b.value[k] > 0.0) glossy.push_back(f[k]);
    for (int k = 0; k < 3; ++k) {
      if (!(b.value[k] > 0.0)) continue;
      b.bias_variance[k] *= f[k];
      b.target[k] = std::log(b.value[k]) + 0.5 * b.bias_variance[k];
    }
  }
  if (!glossy.empty()) data.point_scatter = upper_median_inplace(glossy);
}

}  // namespace

void FitDataOptions::check() const {
  if (!(relative_floor > 0.0 && relative_floor < 1.0))
    throw OptionError("FitDataOptions::relative_floor", fmt::format("{}", relative_floor), "(0, 1)");
  if (window_phi_d < 1 || window_phi_d > kMerlPhiD / 2)
    throw OptionError("FitDataOptions::window_phi_d", std::to_string(window_phi_d), "1..90");
  if (sessions < 1) throw OptionError("FitDataOptions::sessions", std::to_string(sessions), ">= 1");
}

std::uint32_t auto_pooling(double excess, std::uint32_t sessions) {
  if (!(excess > kSparkleExcess)) return 1;
  return sessions > 1 ? kSparklePoolingSessions : kSparklePooling;
}

constexpr EnumNames<FitResiduals, 2> kResidualNames{{{FitResiduals::Log, "log"}, {FitResiduals::Linear, "linear"}}};

const char* to_string(FitResiduals r) { return enum_name(kResidualNames, r); }

FitResiduals fit_residuals_from_string(std::string_view s, std::string_view where) {
  return enum_from_name(kResidualNames, s, "residual form", where);
}

const char* to_string(NoiseSource s) {
  static constexpr EnumNames<NoiseSource, 3> kNames{{{NoiseSource::None, "none"},
                                                     {NoiseSource::SampleSpread, "sample-spread"},
                                                     {NoiseSource::SampleNoise, "sample-noise"}}};
  return enum_name(kNames, s);
}

void MultiStartOptions::check_shared(const char* owner) const {
  auto fail = [owner](const std::string& key, const std::string& value, const char* rule) {
    throw OptionError(std::string(owner) + "::" + key, value, rule);
  };
  if (lobes < 1 || lobes > 3) fail("lobes", std::to_string(lobes), "1..3");
  if (grid_starts < 1) fail("grid_starts", std::to_string(grid_starts), ">= 1");
  if (random_starts < 0) fail("random_starts", std::to_string(random_starts), ">= 0");
  if (max_iterations < 1) fail("max_iterations", std::to_string(max_iterations), ">= 1");
  if (start_bins < 100) fail("start_bins", std::to_string(start_bins), ">= 100");
  if (!(huber_scale >= 0.0)) fail("huber_scale", fmt::format("{}", huber_scale), ">= 0");
  if (!(m_min > 0.0 && m_min < 0.1)) fail("m_min", fmt::format("{}", m_min), "in (0, 0.1)");
  if (threads < 0) fail("threads", std::to_string(threads), ">= 0");
  if (chunk_bins < 1) fail("chunk_bins", std::to_string(chunk_bins), ">= 1");
  data.check();
}

double sparkle_excess(const brdf::MerlTable& table, const std::vector<float>* noise_variance, int channel) {
  if (!noise_variance || noise_variance->size() != 3 * kMerlBins) return NAN;
  const double lo = deg_to_rad(4.0), hi = deg_to_rad(25.0);
  double spread = 0.0, noise = 0.0;
  for (std::size_t b = 0; b < kMerlBins; ++b) {
    if (table.state(b) != brdf::BinState::Measured || table.count(b) < 3) continue;
    const double theta_h = table.mean_coords(b)[0];
    if (theta_h < lo || theta_h >= hi) continue;
    const double dof = static_cast<double>(table.count(b) - 1);
    spread += dof * table.variance(b)[channel];
    noise += dof * static_cast<double>((*noise_variance)[3 * b + static_cast<std::size_t>(channel)]);
  }
  return noise > 0.0 ? spread / noise : NAN;
}

FitData prepare_fit_data(const brdf::MerlTable& table, const FitDataOptions& requested,
                         const std::vector<float>* noise_variance) {
  requested.check();
  FitData data;
  FitDataOptions options = requested;
  data.options = requested;
  if (options.min_samples == 0) {
    data.sparkle_excess = sparkle_excess(table, noise_variance);
    options.min_samples = auto_pooling(data.sparkle_excess, options.sessions);
  }
  data.min_samples = options.min_samples;
  std::size_t with_counts = 0, measured = 0;
  for (std::size_t b = 0; b < kMerlBins; ++b) {
    if (table.state(b) != brdf::BinState::Measured) continue;
    ++measured;
    with_counts += table.count(b) > 0;
  }
  // A table from binning has counts on every measured bin; a MERL file on none.
  data.has_statistics = measured > 0 && with_counts == measured;
  const bool use_noise = data.has_statistics && noise_variance && noise_variance->size() == 3 * kMerlBins;
  data.noise_source = !data.has_statistics ? NoiseSource::None
                      : use_noise          ? NoiseSource::SampleNoise
                                           : NoiseSource::SampleSpread;

  // Relative per-sample variances per bin and channel (positive values; the sample spread
  // needs >= 2 samples).
  std::vector<float> rho;
  if (data.has_statistics) {
    rho.assign(3 * kMerlBins, -1.0f);
    for (std::size_t b = 0; b < kMerlBins; ++b) {
      if (table.state(b) != brdf::BinState::Measured || (!use_noise && table.count(b) < 2)) continue;
      const brdf::Rgb v = table.value(b);
      const brdf::Rgb var = use_noise ? brdf::Rgb((*noise_variance)[3 * b], (*noise_variance)[3 * b + 1],
                                                  (*noise_variance)[3 * b + 2])
                                      : table.variance(b);
      for (int c = 0; c < 3; ++c)
        if (v[c] > 0.0) rho[3 * b + c] = static_cast<float>(var[c] / (v[c] * v[c]));
    }
  }
  // Fallback where a neighbourhood has no variance at all: the median over the region.
  std::array<std::array<double, 3>, kRegionCount> region_median{};
  if (data.has_statistics) {
    std::array<std::array<std::vector<float>, 3>, kRegionCount> per_region;
    for (std::size_t b = 0; b < kMerlBins; ++b)
      for (int c = 0; c < 3; ++c)
        if (rho[3 * b + c] >= 0.0f) per_region[static_cast<int>(region_of_bin(b))][c].push_back(rho[3 * b + c]);
    for (int r = 0; r < kRegionCount; ++r)
      for (int c = 0; c < 3; ++c) {
        auto& v = per_region[r][c];
        if (v.empty()) {
          region_median[r][c] = 0.0;
          continue;
        }
        region_median[r][c] = upper_median_inplace(v);
      }
  }

  const double floor2 = options.relative_floor * options.relative_floor;
  // Calls f(q) for every bin q of the 3x3x3 neighbourhood of bin b (phi_d wraps around).
  auto for_each_neighbour = [](std::size_t b, const auto& f) {
    const brdf::MerlBin mb = brdf::merl_bin_of_flat(b);
    for (int di = -1; di <= 1; ++di) {
      const int i = mb.theta_h + di;
      if (i < 0 || i >= kMerlThetaH) continue;
      for (int dj = -1; dj <= 1; ++dj) {
        const int j = mb.theta_d + dj;
        if (j < 0 || j >= kMerlThetaD) continue;
        for (int dk = -1; dk <= 1; ++dk) f(brdf::merl_flat_index({i, j, (mb.phi_d + dk + kMerlPhiD) % kMerlPhiD}));
      }
    }
  };
  // Per bin: usable?, and its pooled relative per-sample variance.
  auto pooled_rho = [&](std::size_t b, Region region) {
    std::array<double, 3> pooled{0, 0, 0};
    if (!data.has_statistics) return pooled;
    std::array<double, 3> num{0, 0, 0}, den{0, 0, 0};
    for_each_neighbour(b, [&](std::size_t q) {
      // Degrees of freedom of the bin's variance estimate.
      const double dof = static_cast<double>(table.count(q)) - (use_noise ? 0.0 : 1.0);
      if (dof <= 0.0) return;
      for (int c = 0; c < 3; ++c)
        if (rho[3 * q + c] >= 0.0f) {
          num[c] += dof * rho[3 * q + c];
          den[c] += dof;
        }
    });
    for (int c = 0; c < 3; ++c) pooled[c] = den[c] > 0.0 ? num[c] / den[c] : region_median[static_cast<int>(region)][c];
    return pooled;
  };
  // The relative per-sample variance the log of a point's mean is biased by (the delta
  // correction; fit_data.h): the samples' own spread, which holds the flakes' sparkle that
  // the pixel-noise variance (the weights') does not know about, and at least that noise.
  // A ratio of sums pooled over the bin's 3x3x3 neighbourhood, sum (n - 1) var / sum (n - 1)
  // mean^2: rare bright glints leave a bin's own var / mean^2 near 0 in most bins (no glint)
  // and bounded in the others, so an average of the bins' ratios would understate the
  // scatter several times over. Not in the peak: there the spread inside a bin is the clear
  // coat's change across the bin, not noise.
  auto pooled_spread = [&](std::size_t b, Region region, const std::array<double, 3>& noise) {
    if (!data.has_statistics || region == Region::Peak) return noise;
    std::array<double, 3> num{0, 0, 0}, den{0, 0, 0};
    for_each_neighbour(b, [&](std::size_t q) {
      if (table.state(q) != brdf::BinState::Measured || table.count(q) < 2) return;
      const double dof = static_cast<double>(table.count(q)) - 1.0;
      const brdf::Rgb v = table.value(q), var = table.variance(q);
      for (int c = 0; c < 3; ++c) {
        num[c] += dof * var[c];
        den[c] += dof * v[c] * v[c];
      }
    });
    std::array<double, 3> s = noise;
    for (int c = 0; c < 3; ++c)
      if (den[c] > 0.0) s[c] = std::max(noise[c], num[c] / den[c]);
    return s;
  };
  auto usable = [&](std::size_t b) {
    if (table.state(b) != brdf::BinState::Measured) return false;
    if (data.has_statistics && table.count(b) < options.min_count) return false;
    if (!(table.value(b) > 0.0).any()) return false;
    const Eigen::Vector3d c = table.mean_coords(b);
    return brdf::LobeGeometry::from_half_diff(c[0], c[1], c[2]).valid;
  };

  // Groups of consecutive phi_d bins of one (theta_h, theta_d) row with at least
  // min_samples samples together (one bin each when min_samples <= 1 or without counts).
  struct Group {
    std::size_t first = 0;
    std::uint32_t bins = 0;
    std::vector<std::pair<std::size_t, double>> members;  // (bin, count)
    double count = 0;
    Eigen::Vector3d coords = Eigen::Vector3d::Zero();  // sums weighted by count
    std::array<double, 3> value{0, 0, 0}, rho{0, 0, 0}, spread{0, 0, 0};
  };
  std::vector<std::uint32_t> member_bin;  // the table bin of every data.members entry
  auto emit = [&](const Group& g) {
    FitBin fb;
    fb.bin = static_cast<std::uint32_t>(g.first);
    fb.bins = g.bins;
    fb.count = static_cast<std::uint32_t>(g.count);
    const double w = std::max(g.count, 1.0);
    fb.coords = g.coords / w;
    fb.region = region_of_theta_h(fb.coords[0]);
    fb.member_begin = static_cast<std::uint32_t>(data.members.size());
    fb.member_count = static_cast<std::uint32_t>(g.members.size());
    for (const auto& [bin, n] : g.members) {
      member_bin.push_back(static_cast<std::uint32_t>(bin));
      FitMember m;
      m.coords = table.mean_coords(bin);
      m.geometry = brdf::LobeGeometry::from_half_diff(m.coords[0], m.coords[1], m.coords[2]);
      m.weight = data.has_statistics ? n / w : 1.0 / static_cast<double>(g.members.size());
      data.members.push_back(m);
    }
    bool any = false;
    for (int c = 0; c < 3; ++c) {
      fb.value[c] = g.value[c] / w;
      if (!(fb.value[c] > 0.0)) continue;
      const double s2 = data.has_statistics ? (g.rho[c] / w) / w : 0.0;
      fb.noise_sigma[c] = std::sqrt(s2);
      fb.bias_variance[c] = data.has_statistics ? (g.spread[c] / w) / w : 0.0;
      fb.target[c] = std::log(fb.value[c]) + (options.delta_correction ? 0.5 * fb.bias_variance[c] : 0.0);
      fb.inv_sigma[c] = 1.0 / std::sqrt(s2 + floor2);
      ++data.residuals;
      any = true;
    }
    if (any) {
      data.bins.push_back(fb);
    } else {
      data.members.resize(fb.member_begin);
      member_bin.resize(fb.member_begin);
    }
  };
  const double target = data.has_statistics ? static_cast<double>(options.min_samples) : 0.0;
  for (int i = 0; i < kMerlThetaH; ++i)
    for (int j = 0; j < kMerlThetaD; ++j) {
      Group g, previous;
      bool have_previous = false;
      for (int k = 0; k < kMerlPhiD; ++k) {
        const std::size_t b = brdf::merl_flat_index({i, j, k});
        if (!usable(b)) continue;
        const double n = data.has_statistics ? static_cast<double>(table.count(b)) : 1.0;
        const std::array<double, 3> rb = pooled_rho(b, region_of_bin(b));
        const std::array<double, 3> rs = pooled_spread(b, region_of_bin(b), rb);
        if (g.bins == 0) g.first = b;
        ++g.bins;
        g.members.emplace_back(b, n);
        g.count += n;
        g.coords += n * table.mean_coords(b);
        const brdf::Rgb v = table.value(b);
        for (int c = 0; c < 3; ++c) {
          g.value[c] += n * v[c];
          g.rho[c] += n * rb[c];
          g.spread[c] += n * rs[c];
        }
        if (g.count >= target) {
          if (have_previous) emit(previous);
          previous = g;
          have_previous = true;
          g = Group{};
        }
      }
      if (g.bins > 0) {
        if (have_previous && g.count < 0.5 * target) {  // a small remainder joins the group before it
          previous.bins += g.bins;
          previous.members.insert(previous.members.end(), g.members.begin(), g.members.end());
          previous.count += g.count;
          previous.coords += g.coords;
          for (int c = 0; c < 3; ++c) {
            previous.value[c] += g.value[c];
            previous.rho[c] += g.rho[c];
            previous.spread[c] += g.spread[c];
          }
        } else {
          if (have_previous) emit(previous);
          previous = g;
          have_previous = true;
        }
      }
      if (have_previous) emit(previous);
    }
  if (data.bins.empty())
    throw DataError(fmt::format("the table has no measured bins with positive values{}: nothing to fit",
                                options.min_count > 1 ? fmt::format(" and at least {} samples", options.min_count)
                                                      : std::string()));
  if (data.has_statistics && options.delta_correction && options.point_scatter) scale_by_point_scatter(data);
  data.linear = options.residuals == FitResiduals::Linear;
  if (data.linear) linear_weights(data, table, member_bin, usable);
  return data;
}

FitData combine_site_data(std::array<FitData, 3> per_site) {
  FitData out;
  out.options = per_site[1].options;
  out.has_statistics = per_site[0].has_statistics && per_site[1].has_statistics && per_site[2].has_statistics;
  out.noise_source = per_site[1].noise_source;
  out.linear = per_site[1].linear;
  out.min_samples = per_site[1].min_samples;
  out.sparkle_excess = per_site[1].sparkle_excess;
  out.point_scatter = per_site[1].point_scatter;
  for (int c = 0; c < 3; ++c) {
    FitData& d = per_site[static_cast<std::size_t>(c)];
    const auto offset = static_cast<std::uint32_t>(out.members.size());
    out.members.insert(out.members.end(), d.members.begin(), d.members.end());
    for (FitBin b : d.bins) {
      for (int k = 0; k < 3; ++k)
        if (k != c) {
          b.inv_sigma[k] = 0.0;
          b.linear_weight[k] = 0.0;
        }
      if (b.inv_sigma[c] == 0.0) continue;
      b.member_begin += offset;
      ++out.residuals;
      out.bins.push_back(b);
    }
  }
  if (out.bins.empty()) throw DataError("the filter-array sites' tables have no measured bins: nothing to fit");
  return out;
}

Json RegionResidual::to_json() const {
  return {{"bins", bins}, {"residuals", residuals}, {"log_rms", log_rms}, {"noise_floor", number_or_null(noise_floor)}};
}

Json ResidualReport::to_json() const {
  Json regions_json = Json::object();
  for (int r = 0; r < kRegionCount; ++r) regions_json[to_string(static_cast<Region>(r))] = regions[r].to_json();
  Json curves_json = Json::array();
  for (const FitCurve& c : curves) curves_json.push_back(c.to_json());
  Json cells = Json::array();
  for (std::size_t k = 0; k < coverage.size(); ++k)
    if (coverage[k] > 0) cells.push_back({k / brdf::kMerlThetaD, k % brdf::kMerlThetaD, coverage[k]});
  Json coverage_json = {{"theta_h_bins", brdf::kMerlThetaH}, {"theta_d_bins", brdf::kMerlThetaD}, {"cells", cells}};
  return {{"log_rms", total.log_rms},
          {"bins_used", total.bins},
          {"residuals", total.residuals},
          {"noise_floor_log_rms", number_or_null(total.noise_floor)},
          {"noise_source", to_string(noise_source)},
          {"min_samples", min_samples},
          {"sparkle_excess", number_or_null(sparkle_excess)},
          {"point_scatter", number_or_null(point_scatter)},
          {"regions", regions_json}, {"curves", curves_json}, {"coverage", coverage_json}};
}

Json FitCurve::to_json() const {
  return {{"theta_d_deg", theta_d_deg}, {"theta_h_deg", theta_h_deg}, {"measured", measured}, {"model", model},
          {"points", points}};
}

namespace {

std::vector<FitCurve> fit_curves(const FitData& data, const std::vector<double>& model) {
  std::vector<FitCurve> curves;
  constexpr double kDeg = 180.0 / std::numbers::pi;
  for (double theta_d : kCurveThetaDDeg) {
    struct Sum {
      double theta_h = 0, measured = 0, model = 0;
      std::uint32_t points = 0, values = 0;
    };
    std::array<Sum, brdf::kMerlThetaH> sums{};
    for (std::size_t q = 0; q < data.bins.size(); ++q) {
      const FitBin& b = data.bins[q];
      if (std::abs(b.coords[1] * kDeg - theta_d) > FitCurve::kCurveHalfWidthDeg) continue;
      Sum& s = sums[static_cast<std::size_t>(brdf::merl_theta_h_index(b.coords[0]))];
      bool used = false;
      for (int c = 0; c < 3; ++c) {
        if (b.inv_sigma[c] == 0.0 || !(model[3 * q + c] > 0.0)) continue;
        s.measured += b.value[c];
        s.model += model[3 * q + c];
        ++s.values;
        used = true;
      }
      if (!used) continue;
      s.theta_h += b.coords[0] * kDeg;
      ++s.points;
    }
    FitCurve curve;
    curve.theta_d_deg = theta_d;
    for (const Sum& s : sums) {
      if (s.points == 0) continue;
      curve.theta_h_deg.push_back(s.theta_h / s.points);
      curve.measured.push_back(s.measured / s.values);
      curve.model.push_back(s.model / s.values);
      curve.points.push_back(s.points);
    }
    if (curve.theta_h_deg.size() >= 3) curves.push_back(std::move(curve));
  }
  return curves;
}

}  // namespace

ResidualReport residual_report(const FitData& data, const std::vector<double>& model) {
  ResidualReport rep;
  rep.noise_source = data.noise_source;
  rep.min_samples = data.min_samples;
  rep.sparkle_excess = data.sparkle_excess;
  rep.point_scatter = data.point_scatter;
  std::array<double, kRegionCount + 1> sq{}, noise{};
  for (std::size_t q = 0; q < data.bins.size(); ++q) {
    const FitBin& b = data.bins[q];
    const int r = static_cast<int>(b.region);
    bool used = false;
    for (int c = 0; c < 3; ++c) {
      if (b.inv_sigma[c] == 0.0) continue;
      used = true;
      const double m = model[3 * q + c];
      const double e = m > 0.0 ? std::log(m) - std::log(b.value[c]) : std::log(1e-300) - std::log(b.value[c]);
      sq[r] += e * e;
      noise[r] += b.noise_sigma[c] * b.noise_sigma[c];
      ++rep.regions[r].residuals;
    }
    rep.regions[r].bins += used;
  }
  for (int r = 0; r < kRegionCount; ++r) {
    RegionResidual& rr = rep.regions[r];
    rep.total.bins += rr.bins;
    rep.total.residuals += rr.residuals;
    sq[kRegionCount] += sq[r];
    noise[kRegionCount] += noise[r];
    if (rr.residuals > 0) {
      rr.log_rms = std::sqrt(sq[r] / rr.residuals);
      if (data.has_statistics) rr.noise_floor = std::sqrt(noise[r] / rr.residuals);
    }
  }
  if (rep.total.residuals > 0) {
    rep.total.log_rms = std::sqrt(sq[kRegionCount] / rep.total.residuals);
    if (data.has_statistics) rep.total.noise_floor = std::sqrt(noise[kRegionCount] / rep.total.residuals);
  }
  rep.curves = fit_curves(data, model);
  rep.coverage.assign(static_cast<std::size_t>(brdf::kMerlThetaH) * brdf::kMerlThetaD, 0);
  for (const FitBin& b : data.bins) {
    const auto i = static_cast<std::size_t>(brdf::merl_theta_h_index(b.coords[0]));
    const auto j = static_cast<std::size_t>(brdf::merl_theta_d_index(b.coords[1]));
    rep.coverage[i * brdf::kMerlThetaD + j] += std::max<std::uint32_t>(b.count, 1);
  }
  return rep;
}

}  // namespace paintlab::fit
