#include "paintlab/fitting/binning.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fmt/format.h>

#include "bin_index.h"
#include "paintlab/core/enum_names.h"
#include "fit_util.h"
#include "paintlab/core/error.h"

namespace paintlab::fit {

namespace {

// One bin's running sums in one 64-byte cache line. Coordinates are summed as offsets
// from the bin's lower edges (small numbers: float is exact enough); values in double so
// variance = (S2 - S1^2 / n) / (n - 1) keeps its digits. Noise variances live beside.
struct alignas(64) Cell {
  std::uint32_t count = 0;
  float offset[3] = {0, 0, 0};
  double sum[3] = {0, 0, 0};
  double sumsq[3] = {0, 0, 0};
};
static_assert(sizeof(Cell) == 64);

struct GroupCell {
  std::uint32_t count = 0;
  float sum[3] = {0, 0, 0};
};

struct Edges {
  std::array<double, kMerlThetaH> th;
  std::array<double, kMerlThetaD> td;
  std::array<double, kMerlPhiD> pd;
  Edges() {
    for (int i = 0; i < kMerlThetaH; ++i) th[i] = detail::theta_h_edge(i);
    for (int j = 0; j < kMerlThetaD; ++j) td[j] = detail::theta_d_edge(j);
    for (int k = 0; k < kMerlPhiD; ++k) pd[k] = detail::phi_d_edge(k);
  }
};
const Edges& edges() {
  static const Edges e;
  return e;
}

bool values_finite(const float* v) { return std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]); }

// Bin of sample s of a batch, kNoBin when it is rejected.
inline std::uint32_t batch_bin(const SampleBatch& b, std::size_t s) {
  const double th = b.theta_h[s], td = b.theta_d[s], pd = b.phi_d[s];
  if (!detail::angles_valid(th, td, pd) || !values_finite(&b.value[3 * s])) return kNoBin;
  return detail::flat_index(detail::theta_h_index(th), detail::theta_d_index(td),
                            detail::phi_d_index_reduced(detail::reduce_phi_d(pd)));
}

[[noreturn]] void die(const char* what) {
  std::fprintf(stderr, "paintlab: internal error: %s\n", what);
  std::abort();
}

}  // namespace

// ---------------------------------------------------------------------------------------
// SampleBatch

void SampleBatch::clear() {
  theta_h.clear();
  theta_d.clear();
  phi_d.clear();
  value.clear();
  variance.clear();
}

void SampleBatch::reserve(std::size_t n, bool with_variance) {
  theta_h.reserve(n);
  theta_d.reserve(n);
  phi_d.reserve(n);
  value.reserve(3 * n);
  if (with_variance) variance.reserve(3 * n);
}

void SampleBatch::push_back(double th, double td, double pd, float r, float g, float b) {
  theta_h.push_back(th);
  theta_d.push_back(td);
  phi_d.push_back(pd);
  value.push_back(r);
  value.push_back(g);
  value.push_back(b);
}

void SampleBatch::push_back(double th, double td, double pd, const float rgb[3], const float var[3]) {
  push_back(th, td, pd, rgb[0], rgb[1], rgb[2]);
  variance.insert(variance.end(), var, var + 3);
}

void SampleBatch::append(const SampleBatch& o) {
  if (has_variance() != o.has_variance() && !empty() && !o.empty())
    die("SampleBatch::append: one batch has noise variances, the other not");
  theta_h.insert(theta_h.end(), o.theta_h.begin(), o.theta_h.end());
  theta_d.insert(theta_d.end(), o.theta_d.begin(), o.theta_d.end());
  phi_d.insert(phi_d.end(), o.phi_d.begin(), o.phi_d.end());
  value.insert(value.end(), o.value.begin(), o.value.end());
  variance.insert(variance.end(), o.variance.begin(), o.variance.end());
}

void SampleBatch::check_consistent() const {
  const std::size_t n = theta_h.size();
  if (theta_d.size() != n || phi_d.size() != n || value.size() != 3 * n ||
      (!variance.empty() && variance.size() != 3 * n))
    die("SampleBatch: arrays of different lengths");
}

// ---------------------------------------------------------------------------------------
// Options

constexpr EnumNames<BinEstimator, 2> kEstimatorNames{
    {{BinEstimator::Mean, "mean"}, {BinEstimator::MedianOfMeans, "median-of-means"}}};

const char* to_string(BinEstimator e) { return enum_name(kEstimatorNames, e); }

BinEstimator bin_estimator_from_string(std::string_view s, std::string_view where) {
  return enum_from_name(kEstimatorNames, s, "bin estimator", where);
}

void BinningOptions::check() const {
  if (groups < 3 || groups > 9 || groups % 2 == 0)
    throw OptionError("BinningOptions::groups", std::to_string(groups), "odd, 3..9");
  if (threads < 0) throw OptionError("BinningOptions::threads", std::to_string(threads), ">= 0 (0 = all cores)");
}

brdf::Rgb BinnedTable::noise(std::size_t bin) const {
  if (noise_variance.empty()) return brdf::Rgb::Zero();
  return {noise_variance[3 * bin], noise_variance[3 * bin + 1], noise_variance[3 * bin + 2]};
}

// ---------------------------------------------------------------------------------------
// BinAccumulator

struct BinAccumulator::Impl {
  BinningOptions opt;
  std::vector<Cell> cells;
  std::vector<float> noise;       // 3 per bin: sums of the samples' noise variances
  std::vector<GroupCell> groups;  // [bin * G + g], median-of-means only
  std::uint64_t binned = 0;
  std::uint64_t rejected = 0;
  std::uint64_t without_noise = 0;    // binned samples that carried no noise variance

  explicit Impl(BinningOptions o) : opt(o), cells(kMerlBins), noise(3 * kMerlBins, 0.0f) {
    if (opt.estimator == BinEstimator::MedianOfMeans) groups.resize(kMerlBins * static_cast<std::size_t>(opt.groups));
  }

  // Asks for the memory a sample of bin `bin` will update (kNoBin: nothing).
  inline void prefetch(std::uint32_t bin) const {
    if (bin == kNoBin) return;
    __builtin_prefetch(&cells[bin], 1, 3);
    __builtin_prefetch(&noise[3 * static_cast<std::size_t>(bin)], 1, 3);
  }

  // Adds sample s of batch b to bin `bin` (a valid index).
  inline void accumulate(std::uint32_t bin, const SampleBatch& b, std::size_t s) {
    const Edges& e = edges();
    const std::uint32_t i = bin / detail::kSlice;
    const std::uint32_t j = (bin / kMerlPhiD) % kMerlThetaD;
    const std::uint32_t k = bin % kMerlPhiD;
    Cell& c = cells[bin];
    ++c.count;
    c.offset[0] += static_cast<float>(b.theta_h[s] - e.th[i]);
    c.offset[1] += static_cast<float>(b.theta_d[s] - e.td[j]);
    c.offset[2] += static_cast<float>(detail::reduce_phi_d(b.phi_d[s]) - e.pd[k]);
    const float* v = &b.value[3 * s];
    for (int ch = 0; ch < 3; ++ch) {
      const double x = v[ch];
      c.sum[ch] += x;
      c.sumsq[ch] += x * x;
    }
    if (!b.variance.empty()) {
      const float* n = &b.variance[3 * s];
      float* acc = &noise[3 * static_cast<std::size_t>(bin)];
      acc[0] += n[0];
      acc[1] += n[1];
      acc[2] += n[2];
    }
    if (!groups.empty()) {
      // Round-robin per bin: balanced groups, and the same for add() and add_parallel().
      GroupCell& g = groups[static_cast<std::size_t>(bin) * opt.groups + (c.count - 1) % static_cast<std::uint32_t>(opt.groups)];
      ++g.count;
      g.sum[0] += v[0];
      g.sum[1] += v[1];
      g.sum[2] += v[2];
    }
  }

  void finish_batch(const SampleBatch& b, std::uint64_t n_rejected) {
    const std::uint64_t n = b.size();
    binned += n - n_rejected;
    rejected += n_rejected;
    if (b.variance.empty()) without_noise += n - n_rejected;
  }
};

BinAccumulator::BinAccumulator(BinningOptions options) {
  options.check();
  impl_ = std::make_unique<Impl>(options);
}
BinAccumulator::~BinAccumulator() = default;
BinAccumulator::BinAccumulator(BinAccumulator&&) noexcept = default;
BinAccumulator& BinAccumulator::operator=(BinAccumulator&&) noexcept = default;

void BinAccumulator::add(const SampleBatch& batch) {
  batch.check_consistent();
  Impl& m = *impl_;
  std::uint64_t n_rejected = 0;
  const std::size_t n = batch.size();
  // Two passes per block: the bin indices (a loop without stores to the table, which the
  // compiler can pipeline), then the scattered accumulation.
  constexpr std::size_t kBlock = 1024;
  std::uint32_t bins[kBlock];
  constexpr std::size_t kPrefetch = 16;
  for (std::size_t s0 = 0; s0 < n; s0 += kBlock) {
    const std::size_t len = std::min(kBlock, n - s0);
    for (std::size_t q = 0; q < len; ++q) bins[q] = batch_bin(batch, s0 + q);
    // The table (about 110 MB) is far larger than the caches: every sample touches one
    // random cell and its noise sums. Prefetching them kPrefetch samples ahead overlaps
    // those memory accesses instead of waiting for each in turn.
    for (std::size_t q = 0; q < std::min(len, kPrefetch); ++q) m.prefetch(bins[q]);
    for (std::size_t q = 0; q < len; ++q) {
      if (q + kPrefetch < len) m.prefetch(bins[q + kPrefetch]);
      if (bins[q] == kNoBin) {
        ++n_rejected;
        continue;
      }
      m.accumulate(bins[q], batch, s0 + q);
    }
  }
  m.finish_batch(batch, n_rejected);
}

void BinAccumulator::add_parallel(const SampleBatch& batch) {
  batch.check_consistent();
  Impl& m = *impl_;
  const std::size_t n = batch.size();
  const int threads = m.opt.threads > 0 ? m.opt.threads : tbb::this_task_arena::max_concurrency();
  constexpr std::size_t kChunk = 16384;
  constexpr std::uint32_t kPrefetch = 16;
  if (threads <= 1 || n < 2 * kChunk) {
    add(batch);
    return;
  }
  // Phase 1, parallel over chunks of the batch: bin indices, and each chunk's sample
  // numbers sorted (stably) by the worker partition that owns their bin. Partitions are
  // ranges of theta_h rows.
  constexpr int kParts = 16;
  std::array<std::uint8_t, kMerlThetaH> part_of_row;
  for (int i = 0; i < kMerlThetaH; ++i) part_of_row[i] = static_cast<std::uint8_t>(i * kParts / kMerlThetaH);
  const std::size_t chunks = (n + kChunk - 1) / kChunk;
  std::vector<std::uint32_t> bins(n), order(n);
  std::vector<std::array<std::uint32_t, kParts + 1>> offsets(chunks);
  std::atomic<std::uint64_t> n_rejected{0};
  tbb::task_arena arena(threads);
  arena.execute([&] {
    tbb::parallel_for(std::size_t{0}, chunks, [&](std::size_t c) {
      const std::size_t lo = c * kChunk, hi = std::min(n, lo + kChunk);
      std::array<std::uint32_t, kParts + 1> count{};
      std::uint64_t rej = 0;
      for (std::size_t s = lo; s < hi; ++s) {
        const std::uint32_t bin = batch_bin(batch, s);
        bins[s] = bin;
        if (bin == kNoBin)
          ++rej;
        else
          ++count[part_of_row[bin / detail::kSlice] + 1];
      }
      for (int p = 0; p < kParts; ++p) count[p + 1] += count[p];
      offsets[c] = count;
      for (std::size_t s = lo; s < hi; ++s)
        if (bins[s] != kNoBin) order[lo + count[part_of_row[bins[s] / detail::kSlice]]++] = static_cast<std::uint32_t>(s);
      n_rejected += rej;
    });
    // Phase 2, parallel over partitions: each walks its samples chunk by chunk, so every
    // bin sees its samples in batch order, as with add().
    tbb::parallel_for(0, kParts, [&](int p) {
      for (std::size_t c = 0; c < chunks; ++c) {
        const std::size_t lo = c * kChunk;
        const std::uint32_t q_end = offsets[c][p + 1];
        for (std::uint32_t q = offsets[c][p]; q < q_end; ++q) {
          if (q + kPrefetch < q_end) m.prefetch(bins[order[lo + q + kPrefetch]]);
          const std::uint32_t s = order[lo + q];
          m.accumulate(bins[s], batch, s);
        }
      }
    });
  });
  m.finish_batch(batch, n_rejected.load());
}

std::uint64_t BinAccumulator::samples_binned() const { return impl_->binned; }
std::uint64_t BinAccumulator::samples_rejected() const { return impl_->rejected; }
bool BinAccumulator::has_noise_variance() const { return impl_->binned > 0 && impl_->without_noise == 0; }
const BinningOptions& BinAccumulator::options() const { return impl_->opt; }

std::size_t BinAccumulator::memory_bytes() const {
  return impl_->cells.size() * sizeof(Cell) + impl_->noise.size() * sizeof(float) +
         impl_->groups.size() * sizeof(GroupCell);
}

BinnedTable BinAccumulator::finish() const {
  const Impl& m = *impl_;
  BinnedTable out;
  out.samples_binned = m.binned;
  out.samples_rejected = m.rejected;
  out.estimator = m.opt.estimator;
  const bool noise = has_noise_variance();
  if (noise) out.noise_variance.assign(3 * kMerlBins, 0.0f);
  const Edges& e = edges();
  const int G = m.opt.groups;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, kMerlBins, 8192), [&](const tbb::blocked_range<std::size_t>& r) {
    std::vector<double> means(static_cast<std::size_t>(G));
    for (std::size_t bin = r.begin(); bin < r.end(); ++bin) {
      const Cell& c = m.cells[bin];
      if (c.count == 0) continue;
      const double n = c.count;
      brdf::Rgb mean, var;
      for (int ch = 0; ch < 3; ++ch) {
        mean[ch] = c.sum[ch] / n;
        var[ch] = c.count > 1 ? std::max(0.0, (c.sumsq[ch] - c.sum[ch] * c.sum[ch] / n) / (n - 1.0)) : 0.0;
      }
      brdf::Rgb value = mean;
      if (!m.groups.empty()) {
        const GroupCell* g = &m.groups[bin * static_cast<std::size_t>(G)];
        bool all = true;
        for (int q = 0; q < G; ++q) all = all && g[q].count > 0;
        if (all) {  // fewer samples than groups: the mean is all there is
          for (int ch = 0; ch < 3; ++ch) {
            for (int q = 0; q < G; ++q) means[q] = static_cast<double>(g[q].sum[ch]) / g[q].count;
            std::nth_element(means.begin(), means.begin() + G / 2, means.end());
            value[ch] = means[static_cast<std::size_t>(G / 2)];
          }
        }
      }
      const std::uint32_t i = static_cast<std::uint32_t>(bin / detail::kSlice);
      const std::uint32_t j = static_cast<std::uint32_t>((bin / kMerlPhiD) % kMerlThetaD);
      const std::uint32_t k = static_cast<std::uint32_t>(bin % kMerlPhiD);
      const Eigen::Vector3d coords(e.th[i] + c.offset[0] / n, e.td[j] + c.offset[1] / n, e.pd[k] + c.offset[2] / n);
      out.table.set_value(bin, value, brdf::BinState::Measured);
      out.table.set_statistics(bin, c.count, var, coords);
      if (noise)
        for (int ch = 0; ch < 3; ++ch) out.noise_variance[3 * bin + ch] = static_cast<float>(m.noise[3 * bin + ch] / n);
    }
  });
  return out;
}

std::uint32_t sample_bin(double theta_h, double theta_d, double phi_d) {
  if (!detail::angles_valid(theta_h, theta_d, phi_d)) return kNoBin;
  return detail::flat_index(detail::theta_h_index(theta_h), detail::theta_d_index(theta_d),
                            detail::phi_d_index_reduced(detail::reduce_phi_d(phi_d)));
}

// ---------------------------------------------------------------------------------------
// NaiveBinAccumulator

NaiveBinAccumulator::NaiveBinAccumulator() : cells_(kMerlBins) {}

void NaiveBinAccumulator::add(double theta_h, double theta_d, double phi_d, const float rgb[3]) {
  if (!detail::angles_valid(theta_h, theta_d, phi_d) || !values_finite(rgb)) return;
  const brdf::MerlBin b = brdf::merl_bin({theta_h, 0.0, theta_d, phi_d});
  Cell& c = cells_[brdf::merl_flat_index(b)];
  ++c.count;
  const double coord[3] = {theta_h, theta_d, phi_d < 0.0 ? phi_d + detail::kPi : phi_d};
  for (int ch = 0; ch < 3; ++ch) {
    const double delta = rgb[ch] - c.mean[ch];
    c.mean[ch] += delta / c.count;
    c.m2[ch] += delta * (rgb[ch] - c.mean[ch]);
    c.coord[ch] += (coord[ch] - c.coord[ch]) / c.count;
  }
}

brdf::MerlTable NaiveBinAccumulator::finish() const {
  brdf::MerlTable t;
  for (std::size_t bin = 0; bin < kMerlBins; ++bin) {
    const Cell& c = cells_[bin];
    if (c.count == 0) continue;
    brdf::Rgb var = brdf::Rgb::Zero();
    if (c.count > 1)
      for (int ch = 0; ch < 3; ++ch) var[ch] = c.m2[ch] / (c.count - 1.0);
    t.set_value(bin, brdf::Rgb(c.mean[0], c.mean[1], c.mean[2]), brdf::BinState::Measured);
    t.set_statistics(bin, c.count, var, Eigen::Vector3d(c.coord[0], c.coord[1], c.coord[2]));
  }
  return t;
}

}  // namespace paintlab::fit
