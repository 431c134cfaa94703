#include "paintlab/core/robust.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <list>
#include <random>
#include <span>
#include <string>
#include <vector>

#include "test_util.h"

using namespace paintlab;

static_assert(NumberRange<std::vector<double>> && NumberRange<const std::vector<float>&> && NumberRange<float[9]>);
static_assert(NumberRange<std::span<const std::uint16_t>>);
static_assert(!NumberRange<std::list<double>> && !NumberRange<std::vector<std::string>>);
static_assert(MutableNumberRange<std::vector<float>&> && MutableNumberRange<std::span<double>>);
static_assert(!MutableNumberRange<const std::vector<float>&> && !MutableNumberRange<std::span<const double>>);

TEST(Robust, MedianOfOddAndEvenCounts) {
  EXPECT_EQ(median(std::vector<double>{5, 1, 3}), 3.0);
  EXPECT_EQ(upper_median(std::vector<double>{5, 1, 3}), 3.0);
  // Even: the mean of the two middle values, or the upper one of them.
  EXPECT_EQ(median(std::vector<double>{4, 1, 3, 2}), 2.5);
  EXPECT_EQ(upper_median(std::vector<double>{4, 1, 3, 2}), 3.0);
  EXPECT_EQ(median(std::vector<double>{2, 7, 2, 2}), 2.0);
  EXPECT_EQ(upper_median(std::vector<double>{7, 2}), 7.0);
  EXPECT_EQ(median(std::vector<double>{7, 2}), 4.5);
  EXPECT_EQ(median(std::vector<double>{-3}), -3.0);
  EXPECT_EQ(upper_median(std::vector<double>{-3}), -3.0);
  // The mean of the middle two does not overflow.
  EXPECT_EQ(median(std::vector<double>{1e308, 1.5e308}), 1.25e308);
  // Integers give a double.
  EXPECT_EQ(median(std::vector<int>{1, 2}), 1.5);
  // Float values come back exactly.
  EXPECT_EQ(upper_median(std::vector<float>{0.3f, 0.1f, 0.2f}), static_cast<double>(0.2f));
}

TEST(Robust, CopyLeavesValuesInplaceReorders) {
  const std::vector<double> original{9, 8, 7, 6, 5, 4, 3};
  std::vector<double> v = original;
  EXPECT_EQ(upper_median(v), 6.0);
  EXPECT_EQ(median(v), 6.0);
  EXPECT_EQ(v, original);
  EXPECT_EQ(upper_median_inplace(v), 6.0);
  EXPECT_EQ(v[3], 6.0);  // std::nth_element's partition
  EXPECT_TRUE(std::all_of(v.begin(), v.begin() + 3, [](double x) { return x <= 6.0; }));
  EXPECT_TRUE(std::all_of(v.begin() + 4, v.end(), [](double x) { return x >= 6.0; }));
  std::vector<double> sorted = v, expect = original;
  std::sort(sorted.begin(), sorted.end());
  std::sort(expect.begin(), expect.end());
  EXPECT_EQ(sorted, expect);

  float nb[9] = {9, 1, 8, 2, 7, 3, 6, 4, 5};  // a 3x3 neighbourhood
  EXPECT_EQ(upper_median_inplace(nb), 5.0);
  std::vector<float> w{4, 3, 2, 1};
  EXPECT_EQ(upper_median_inplace(std::span<float>(w).subspan(1)), 2.0);  // of {3, 2, 1}
  EXPECT_EQ(w[0], 4.0f);
}

TEST(Robust, AgreesWithSortingOnRandomSamples) {
  std::mt19937_64 rng(test::seed());
  std::uniform_int_distribution<int> size(1, 40), value(-5, 5);  // many ties
  for (int trial = 0; trial < 500; ++trial) {
    std::vector<double> v(static_cast<std::size_t>(size(rng)));
    for (double& x : v) x = value(rng);
    std::vector<double> s = v;
    std::sort(s.begin(), s.end());
    const std::size_t n = s.size();
    ASSERT_EQ(upper_median(v), s[n / 2]) << "n = " << n;
    ASSERT_EQ(median(v), n % 2 ? s[n / 2] : 0.5 * (s[n / 2 - 1] + s[n / 2])) << "n = " << n;
    for (double q : {0.0, 0.05, 0.25, 0.5, 0.7, 0.999, 1.0}) {
      const double h = q * static_cast<double>(n - 1);
      const auto j = static_cast<std::size_t>(std::floor(h));
      const double ref = j + 1 < n ? s[j] + (h - static_cast<double>(j)) * (s[j + 1] - s[j]) : s[j];
      ASSERT_DOUBLE_EQ(quantile(v, q), ref) << "n = " << n << ", q = " << q;
      std::vector<double> w = v;
      ASSERT_EQ(lower_quantile_inplace(w, q), s[j]) << "n = " << n << ", q = " << q;
    }
  }
}

TEST(Robust, QuantileRuleAtTheEndsAndBetween) {
  const std::vector<double> v{30, 50, 10, 40, 20};
  EXPECT_EQ(quantile(v, 0.0), 10.0);
  EXPECT_EQ(quantile(v, 1.0), 50.0);
  EXPECT_EQ(quantile(v, 0.5), 30.0);
  EXPECT_DOUBLE_EQ(quantile(v, 0.1), 14.0);    // h = 0.4: 10 + 0.4 (20 - 10)
  EXPECT_DOUBLE_EQ(quantile(v, 0.875), 45.0);  // h = 3.5
  EXPECT_EQ(quantile(std::vector<double>{4, 1, 3, 2}, 0.5), 2.5);
  EXPECT_EQ(quantile(std::vector<double>{7}, 0.3), 7.0);

  // The lower quantile takes the order statistic below: no interpolation.
  std::vector<double> w = v;
  EXPECT_EQ(lower_quantile_inplace(w, 0.0), 10.0);
  EXPECT_EQ(lower_quantile_inplace(w, 0.1), 10.0);   // floor(0.4)
  EXPECT_EQ(lower_quantile_inplace(w, 0.3), 20.0);   // floor(1.2)
  EXPECT_EQ(lower_quantile_inplace(w, 0.99), 40.0);  // floor(3.96)
  EXPECT_EQ(lower_quantile_inplace(w, 1.0), 50.0);
  std::vector<std::uint16_t> raw{4095, 0, 17};
  EXPECT_EQ(lower_quantile_inplace(raw, 0.5), 17.0);
}

TEST(Robust, QuantileOutsideZeroOneIsADataError) {
  const std::vector<double> v{1, 2, 3}, none;
  std::vector<double> w = v;
  for (double q : {-0.01, 1.01, 99.5, std::numeric_limits<double>::quiet_NaN()}) {
    EXPECT_THROW(quantile(v, q), DataError) << q;
    EXPECT_THROW(quantile(none, q), DataError) << q;
    EXPECT_THROW(lower_quantile_inplace(w, q), DataError) << q;
  }
  try {
    quantile(v, 2.0);
    FAIL() << "no DataError";
  } catch (const DataError& e) {
    EXPECT_NE(std::string(e.what()).find("0 <= q <= 1"), std::string::npos) << e.what();
  }
}

TEST(Robust, EmptyInputGivesNaN) {
  const std::vector<double> none;
  std::vector<float> scratch;
  EXPECT_TRUE(std::isnan(median(none)));
  EXPECT_TRUE(std::isnan(upper_median(none)));
  EXPECT_TRUE(std::isnan(upper_median_inplace(scratch)));
  EXPECT_TRUE(std::isnan(upper_mad(none, 0.0)));
  EXPECT_TRUE(std::isnan(upper_mad_inplace(scratch, 1.0)));
  EXPECT_TRUE(std::isnan(quantile(none, 0.5)));
  EXPECT_TRUE(std::isnan(lower_quantile_inplace(scratch, 0.5)));
}

TEST(Robust, MadOfAKnownSample) {
  const std::vector<double> v{1, 2, 3, 4, 100};
  const double centre = upper_median(v);
  ASSERT_EQ(centre, 3.0);
  EXPECT_EQ(upper_mad(v, centre), 1.0);  // |x - 3| = {2, 1, 0, 1, 97}
  EXPECT_EQ(upper_mad(v, 0.0), 3.0);     // about zero: the median of |x|
  std::vector<double> w = v;
  EXPECT_EQ(upper_mad_inplace(w, centre), 1.0);
  std::sort(w.begin(), w.end());
  EXPECT_EQ(w, (std::vector<double>{0, 1, 1, 2, 97}));
  // The differences are formed in the element type: 0.1f - float(0.1) is 0, in double it is not.
  EXPECT_EQ(upper_mad(std::vector<float>{0.1f}, 0.1), 0.0);
  EXPECT_GT(std::abs(static_cast<double>(0.1f) - 0.1), 1e-9);
}

TEST(Robust, MadToSigmaIsTheNormalConsistencyFactor) {
  // Phi^-1(3/4) by bisection on the normal CDF.
  double lo = 0.0, hi = 2.0;
  for (int i = 0; i < 200; ++i) {
    const double mid = 0.5 * (lo + hi);
    (0.5 * std::erfc(-mid / std::sqrt(2.0)) < 0.75 ? lo : hi) = mid;
  }
  EXPECT_NEAR(kMadToSigma, 1.0 / lo, 5e-6);  // 1.482602..., rounded to 4 decimals

  // On a large normal sample, kMadToSigma x MAD estimates sigma (standard error of the
  // estimate 1.17 sigma / sqrt(n) = 0.26 % here).
  std::mt19937_64 rng(test::seed());
  const double sigma = 2.5;
  std::normal_distribution<double> normal(-7.0, sigma);
  std::vector<double> x(200001);
  for (double& v : x) v = normal(rng);
  const double centre = upper_median(x);
  EXPECT_NEAR(centre, -7.0, 0.03);
  EXPECT_THAT(kMadToSigma * upper_mad(x, centre), test::NearRel(sigma, 0.012));
  // Without the factor the MAD is the quartile distance 0.6745 sigma, clearly off.
  EXPECT_THAT(upper_mad(x, centre), ::testing::Not(test::NearRel(sigma, 0.1)));
  // And the quartiles of the same sample are -7 -+ 0.6745 sigma.
  EXPECT_NEAR(quantile(x, 0.75) - quantile(x, 0.25), 2.0 * sigma / kMadToSigma, 0.04);
}
