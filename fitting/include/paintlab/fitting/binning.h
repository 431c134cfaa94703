#pragma once
// Half-vector binning: streams BRDF samples into the MERL layout (models.md "Half-vector
// table": 90 theta_h (nonlinear) x 90 theta_d x 180 phi_d) and keeps, per bin, the sample
// count, the per-channel sum and sum of squares (-> mean and variance), the mean
// (theta_h, theta_d, phi_d) of the samples (fits evaluate models there, not at the bin
// centre) and the mean per-sample noise variance. Memory is fixed (about 111 MB for the
// mean estimator) whatever the number of samples or images: callers stream one image's
// samples at a time.
//
// Estimator (docs/fitting.md "Binning"): the default is the sample MEAN. Sparkle is not
// contamination here: the flakes' glints average to the paint's glitter lobe (models.md
// "Sparkle"), so every robust location estimator (median, Huber, trimmed mean,
// median-of-means) estimates a different, lower quantity. Measured on the simulator's
// sparkle statistics (tests/unit/fitting/binning_test.cpp, docs/fitting.md) the median
// is up to 50 % low, median-of-means 2-14 % low at the typical 13 samples per bin, while
// the mean is unbiased and, with the delta-method correction the fit applies
// (log of mean + var / (2 n mean^2)), unbiased in log space too. Robustness to sparkle
// comes from where it belongs: the fit weighs bins by a pooled (not per-bin) relative
// variance, so a bin whose glints happen to be few or many is not weighted by its own
// luck, and uses a robust loss on the whitened log residuals. Median-of-means (samples
// dealt round-robin into G groups, median of the group means) is available for tables
// meant to hold the glint-free base reflectance.
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "paintlab/brdf/merl.h"
#include "paintlab/fitting/samples.h"

namespace paintlab::fit {

enum class BinEstimator {
  Mean,           // sample mean (unbiased for the BRDF including its sparkle average)
  MedianOfMeans,  // median of G group means (samples dealt round-robin per bin) (bounded influence of single samples)
};
const char* to_string(BinEstimator e);
// "mean" or "median-of-means"; DataError naming `where` otherwise.
BinEstimator bin_estimator_from_string(std::string_view s, std::string_view where);

struct BinningOptions {
  BinEstimator estimator = BinEstimator::Mean;
  int groups = 3;   // median-of-means groups: odd, 3..9
  int threads = 0;  // add_parallel(): worker threads, 0 = all cores
  // DataError naming the first violated rule ("BinningOptions::groups = 4. Violated
  // constraint: odd, 3..9").
  void check() const;
};

// The finished table and what the MERL layout cannot hold.
struct BinnedTable {
  brdf::MerlTable table;              // Measured bins: value, count, variance, mean coordinates
  std::vector<float> noise_variance;  // 3 per bin: mean per-sample noise variance; empty when unknown
  std::uint64_t samples_binned = 0;
  std::uint64_t samples_rejected = 0;  // non-finite values or angles outside the table
  BinEstimator estimator = BinEstimator::Mean;

  // Noise variance of bin `bin` (zero when unknown or empty).
  brdf::Rgb noise(std::size_t bin) const;
};

// Accumulates samples. add() and add_parallel() give identical results for the same
// sequence of batches (each bin sums its samples in batch order), so tables are
// reproducible bit for bit whatever the thread count.
class BinAccumulator {
 public:
  explicit BinAccumulator(BinningOptions options = {});
  ~BinAccumulator();
  BinAccumulator(BinAccumulator&&) noexcept;
  BinAccumulator& operator=(BinAccumulator&&) noexcept;

  // Bins a batch on the calling thread.
  void add(const SampleBatch& batch);
  // Bins a batch with options.threads workers: bin indices in parallel chunks, then each
  // worker accumulates one range of theta_h rows over the whole batch.
  void add_parallel(const SampleBatch& batch);

  std::uint64_t samples_binned() const;
  std::uint64_t samples_rejected() const;
  bool has_noise_variance() const;
  std::size_t memory_bytes() const;
  const BinningOptions& options() const;

  // Every bin with at least one sample becomes Measured; the others stay Empty.
  BinnedTable finish() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Flat MERL index of one sample, exactly as brdf::merl_bin() rounds (the reference
// reader), or kNoBin when an angle is not finite or outside its range (theta_h, theta_d
// in [0, pi/2], phi_d in [-pi, pi]).
inline constexpr std::uint32_t kNoBin = 0xFFFFFFFFu;
std::uint32_t sample_bin(double theta_h, double theta_d, double phi_d);

// The textbook way, for comparison (bench, tests): one sample at a time through
// brdf::merl_bin() and a Welford mean/variance update in an array of per-bin structs.
// Only the mean estimator and no noise variance. Same values as BinAccumulator to
// rounding.
class NaiveBinAccumulator {
 public:
  NaiveBinAccumulator();
  void add(double theta_h, double theta_d, double phi_d, const float rgb[3]);
  brdf::MerlTable finish() const;

 private:
  struct Cell {
    std::uint32_t count = 0;
    double mean[3] = {0, 0, 0};
    double m2[3] = {0, 0, 0};
    double coord[3] = {0, 0, 0};
  };
  std::vector<Cell> cells_;
};

}  // namespace paintlab::fit
