#include "paintlab/fitting/binning.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <numbers>
#include <random>
#include <sstream>

#include "paintlab/brdf/merl.h"
#include "paintlab/brdf/rusinkiewicz.h"
#include "paintlab/core/error.h"
#include "test_util.h"

namespace paintlab::fit {
namespace {

constexpr double kPi = std::numbers::pi;

// A batch of random angles over the whole table with RGB values and noise variances.
SampleBatch random_batch(std::size_t n, std::uint64_t seed, bool with_variance = true) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  SampleBatch b;
  b.reserve(n, with_variance);
  for (std::size_t s = 0; s < n; ++s) {
    const float rgb[3] = {static_cast<float>(u(rng)), static_cast<float>(2 * u(rng)), static_cast<float>(u(rng) + 1)};
    const float var[3] = {0.01f, 0.02f, 0.03f};
    const double th = u(rng) * kPi / 2, td = u(rng) * kPi / 2, pd = (2 * u(rng) - 1) * kPi;
    if (with_variance)
      b.push_back(th, td, pd, rgb, var);
    else
      b.push_back(th, td, pd, rgb[0], rgb[1], rgb[2]);
  }
  return b;
}

TEST(Binning, SampleBinMatchesTheReferenceRows) {
  const auto path = test::data_dir() / "merl-reference/merl_index_vectors.csv";
  std::ifstream in(path);
  ASSERT_TRUE(in.good()) << path;
  std::string line;
  std::getline(in, line);
  int rows = 0;
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    std::replace(line.begin(), line.end(), ',', ' ');
    std::istringstream s(line);
    double ti, pi_, to, po, th, ph, td, pd;
    long index;
    s >> ti >> pi_ >> to >> po >> th >> ph >> td >> pd >> index;
    ASSERT_FALSE(s.fail()) << line;
    const brdf::HalfDiff hd = brdf::half_diff_from_spherical(ti * kPi / 180, pi_ * kPi / 180, to * kPi / 180, po * kPi / 180);
    EXPECT_EQ(sample_bin(hd.theta_h, hd.theta_d, hd.phi_d), static_cast<std::uint32_t>(index)) << line;
    ++rows;
  }
  EXPECT_EQ(rows, 1215);
}

TEST(Binning, SampleBinMatchesMerlBinOnRandomAndEdgeAngles) {
  std::mt19937_64 rng(test::seed());
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int s = 0; s < 200000; ++s) {
    const double th = u(rng) * kPi / 2, td = u(rng) * kPi / 2, pd = (2 * u(rng) - 1) * kPi;
    ASSERT_EQ(sample_bin(th, td, pd), brdf::merl_flat_index(brdf::merl_bin({th, 0, td, pd})));
  }
  // Exactly on bin edges and the ends of the ranges.
  for (int i = 0; i <= 90; ++i) {
    const double th = brdf::merl_theta_h_centre(0) * 0 + (i / 90.0) * (i / 90.0) * kPi / 2;
    const double td = i / 90.0 * kPi / 2;
    for (double pd : {-kPi, -kPi / 2, -0.0, 0.0, kPi / 180 * i, kPi}) {
      ASSERT_EQ(sample_bin(th, td, pd), brdf::merl_flat_index(brdf::merl_bin({th, 0, td, pd})))
          << th << " " << td << " " << pd;
    }
  }
  EXPECT_EQ(sample_bin(std::nan(""), 0.1, 0.1), kNoBin);
  EXPECT_EQ(sample_bin(1.7, 0.1, 0.1), kNoBin);   // h below the horizon
  EXPECT_EQ(sample_bin(0.1, -0.1, 0.1), kNoBin);
  EXPECT_EQ(sample_bin(0.1, 0.1, 4.0), kNoBin);
}

TEST(Binning, MeanVarianceCountAndMeanCoordinatesOfOneBin) {
  std::mt19937_64 rng(test::seed());
  std::normal_distribution<double> noise(0.0, 1.0);
  // Samples spread inside bin (10, 40, 100).
  const double th0 = 10.0 / 90, th1 = 11.0 / 90;
  const double th_lo = th0 * th0 * kPi / 2, th_hi = th1 * th1 * kPi / 2;
  const double td_lo = 40 * kPi / 180, pd_lo = 100 * kPi / 180;
  std::uniform_real_distribution<double> u(0.05, 0.95);
  SampleBatch b;
  double sum_th = 0, sum_td = 0, sum_pd = 0, sum = 0, sumsq = 0;
  const int n = 500;
  for (int s = 0; s < n; ++s) {
    const double th = th_lo + u(rng) * (th_hi - th_lo), td = td_lo + u(rng) * kPi / 180, pd = pd_lo + u(rng) * kPi / 180;
    const float v = static_cast<float>(2.0 + 0.1 * noise(rng));
    // phi_d given as its negative twin half of the time: the same bin.
    b.push_back(th, td, s % 2 ? pd - kPi : pd, v, 2 * v, 3 * v);
    sum_th += th;
    sum_td += td;
    sum_pd += pd;
    sum += v;
    sumsq += static_cast<double>(v) * v;
  }
  BinAccumulator acc;
  acc.add(b);
  const BinnedTable t = acc.finish();
  const std::size_t bin = brdf::merl_flat_index({10, 40, 100});
  ASSERT_EQ(t.table.state(bin), brdf::BinState::Measured);
  EXPECT_EQ(t.table.count(bin), static_cast<std::uint32_t>(n));
  EXPECT_EQ(t.table.count_in_state(brdf::BinState::Measured), 1u);
  const double mean = sum / n, var = (sumsq - sum * sum / n) / (n - 1);
  EXPECT_NEAR(t.table.value(bin)[0], mean, 1e-9);
  EXPECT_NEAR(t.table.value(bin)[2], 3 * mean, 1e-8);
  EXPECT_NEAR(t.table.variance(bin)[0], var, 1e-6 * var);
  EXPECT_NEAR(t.table.variance(bin)[1], 4 * var, 4e-6 * var);
  const Eigen::Vector3d c = t.table.mean_coords(bin);
  EXPECT_NEAR(c[0], sum_th / n, 1e-7);
  EXPECT_NEAR(c[1], sum_td / n, 1e-7);
  EXPECT_NEAR(c[2], sum_pd / n, 1e-7);
  EXPECT_TRUE(t.noise_variance.empty());  // the samples carried none
  EXPECT_EQ(t.samples_binned, static_cast<std::uint64_t>(n));
}

TEST(Binning, RejectsNonFiniteValuesAndAnglesOutsideTheTable) {
  SampleBatch b;
  b.push_back(0.1, 0.2, 0.3, 1.0f, 1.0f, 1.0f);
  b.push_back(0.1, 0.2, 0.3, std::nanf(""), 1.0f, 1.0f);
  b.push_back(0.1, 0.2, 0.3, 1.0f, INFINITY, 1.0f);
  b.push_back(2.0, 0.2, 0.3, 1.0f, 1.0f, 1.0f);
  b.push_back(0.1, std::nan(""), 0.3, 1.0f, 1.0f, 1.0f);
  BinAccumulator acc;
  acc.add(b);
  EXPECT_EQ(acc.samples_binned(), 1u);
  EXPECT_EQ(acc.samples_rejected(), 4u);
  const BinnedTable t = acc.finish();
  EXPECT_EQ(t.table.count_in_state(brdf::BinState::Measured), 1u);
}

TEST(Binning, ParallelIsBitIdenticalToSerialAndNaiveAgrees) {
  BinningOptions opt;
  opt.threads = 2;
  BinAccumulator serial(opt), parallel(opt);
  NaiveBinAccumulator naive;
  for (int batch = 0; batch < 3; ++batch) {
    const SampleBatch b = random_batch(300000, test::seed() + batch);
    serial.add(b);
    parallel.add_parallel(b);
    for (std::size_t s = 0; s < b.size(); ++s) naive.add(b.theta_h[s], b.theta_d[s], b.phi_d[s], &b.value[3 * s]);
  }
  const BinnedTable ts = serial.finish(), tp = parallel.finish();
  const brdf::MerlTable tn = naive.finish();
  ASSERT_TRUE(serial.has_noise_variance());
  std::size_t measured = 0;
  for (std::size_t bin = 0; bin < brdf::kMerlBins; ++bin) {
    ASSERT_EQ(ts.table.state(bin), tp.table.state(bin));
    ASSERT_EQ(ts.table.state(bin), tn.state(bin));
    if (ts.table.state(bin) != brdf::BinState::Measured) continue;
    ++measured;
    ASSERT_EQ(ts.table.count(bin), tp.table.count(bin));
    ASSERT_EQ(ts.table.count(bin), tn.count(bin));
    for (int c = 0; c < 3; ++c) {
      ASSERT_EQ(ts.table.value(bin)[c], tp.table.value(bin)[c]);
      ASSERT_EQ(ts.table.variance(bin)[c], tp.table.variance(bin)[c]);
      ASSERT_EQ(ts.table.mean_coords(bin)[c], tp.table.mean_coords(bin)[c]);
      ASSERT_NEAR(ts.table.value(bin)[c], tn.value(bin)[c], 1e-12);
      ASSERT_NEAR(ts.table.variance(bin)[c], tn.variance(bin)[c], 1e-5 * (1 + tn.variance(bin)[c]));
      ASSERT_NEAR(ts.table.mean_coords(bin)[c], tn.mean_coords(bin)[c], 2e-6);
    }
    ASSERT_NEAR(ts.noise(bin)[2], 0.03, 1e-6);
  }
  EXPECT_GT(measured, 400000u);
}

// Per-bin sparkle statistics as the simulator makes them (models.md "Sparkle"; sim's
// sparkle factor (K + eps) / (lambda + eps) with K ~ Poisson(lambda), mean 1, eps = 0.1)
// on the flake part of a bin's value, plus 2 % pixel noise. Each table row is one
// (lambda, flake share) case; every bin gets 13 samples, the median count of a full
// simulated sweep. Returns the mean relative error of the bin values against the truth.
double sparkle_bias(BinEstimator estimator, double lambda, double flake, int samples_per_bin, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::poisson_distribution<int> poisson(lambda);
  std::normal_distribution<double> gauss(0.0, 1.0);
  const double eps = 0.1, base = 1.0, truth = base + flake;
  BinningOptions opt;
  opt.estimator = estimator;
  BinAccumulator acc(opt);
  SampleBatch b;
  const int bins = brdf::kMerlThetaD * brdf::kMerlPhiD;  // one theta_h row
  // Bins along theta_d and phi_d of theta_h row 30: distinct bins, samples interleaved the
  // way an image delivers them (each bin receives its samples spread over the batch).
  for (int s = 0; s < samples_per_bin; ++s)
    for (int bin = 0; bin < bins; ++bin) {
      const int j = bin / 180, k = bin % 180;
      const double v = base * (1 + 0.02 * gauss(rng)) + flake * (poisson(rng) + eps) / (lambda + eps);
      const float f = static_cast<float>(v);
      b.push_back(brdf::merl_theta_h_centre(30), brdf::merl_theta_d_centre(j), brdf::merl_phi_d_centre(k), f, f, f);
    }
  acc.add(b);
  const BinnedTable t = acc.finish();
  double err = 0;
  int n = 0;
  for (std::size_t bin = 0; bin < brdf::kMerlBins; ++bin)
    if (t.table.state(bin) == brdf::BinState::Measured) {
      err += t.table.value(bin)[0] / truth - 1.0;
      ++n;
    }
  EXPECT_EQ(n, bins);
  return err / n;
}

TEST(Binning, MeanIsUnbiasedUnderSparkleMedianOfMeansIsNot) {
  // The figures docs/fitting.md quotes.
  for (double lambda : {0.05, 0.2}) {
    for (double flake : {0.3, 3.0}) {
      const double mean_bias = sparkle_bias(BinEstimator::Mean, lambda, flake, 13, test::seed());
      const double mom_bias = sparkle_bias(BinEstimator::MedianOfMeans, lambda, flake, 13, test::seed());
      std::printf("sparkle lambda %.2f flake share %.1f, 13 samples/bin: bias mean %+.2f%%, median-of-means %+.2f%%\n",
                  lambda, flake, 100 * mean_bias, 100 * mom_bias);
      EXPECT_LT(std::abs(mean_bias), 0.004);
      EXPECT_LT(mom_bias, -0.01);
    }
  }
}

TEST(Binning, MedianOfMeansBoundsTheInfluenceOfASingleOutlier) {
  // 30 samples of 1.0 +- 2 % in one bin and one hot pixel of 1000: the mean moves by 30x,
  // median-of-means stays within the noise.
  std::mt19937_64 rng(test::seed());
  std::normal_distribution<double> gauss(0.0, 1.0);
  for (BinEstimator e : {BinEstimator::Mean, BinEstimator::MedianOfMeans}) {
    BinningOptions opt;
    opt.estimator = e;
    BinAccumulator acc(opt);
    SampleBatch b;
    for (int s = 0; s < 31; ++s) {
      const float v = s == 17 ? 1000.0f : static_cast<float>(1.0 + 0.02 * gauss(rng));
      b.push_back(0.3, 0.4, 0.5, v, v, v);
    }
    acc.add(b);
    const BinnedTable t = acc.finish();
    const double v = t.table.value(sample_bin(0.3, 0.4, 0.5))[0];
    if (e == BinEstimator::Mean)
      EXPECT_GT(v, 30.0);
    else
      EXPECT_NEAR(v, 1.0, 0.02);
  }
}

TEST(Binning, OptionsAreChecked) {
  BinningOptions opt;
  opt.groups = 4;
  EXPECT_THROW(opt.check(), OptionError);
  opt.groups = 3;
  opt.threads = -1;
  EXPECT_THROW(BinAccumulator{opt}, OptionError);
  EXPECT_EQ(bin_estimator_from_string("median-of-means", "test"), BinEstimator::MedianOfMeans);
  EXPECT_THROW(bin_estimator_from_string("median", "test"), DataError);
}

TEST(Binning, MemoryDoesNotGrowWithSamples) {
  BinAccumulator acc;
  const std::size_t before = acc.memory_bytes();
  acc.add(random_batch(100000, 7));
  EXPECT_EQ(acc.memory_bytes(), before);
  EXPECT_LT(before, 130u * 1000 * 1000);
}

}  // namespace
}  // namespace paintlab::fit
