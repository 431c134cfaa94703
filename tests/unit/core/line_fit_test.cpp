// The weighted straight line of the dark frame (level against exposure) and the response's
// noise model (variance against level).
#include "paintlab/core/line_fit.h"

#include <gtest/gtest.h>

#include <cmath>

using paintlab::WeightedLineFit;

TEST(WeightedLineFit, ExactPointsGiveTheirLine) {
  WeightedLineFit f;
  for (double x : {0.5, 1.0, 4.0}) f.add(x, 3.0 + 2.5 * x, 2.0);
  ASSERT_TRUE(f.determined());
  EXPECT_NEAR(f.slope(), 2.5, 1e-12);
  EXPECT_NEAR(f.intercept(), 3.0, 1e-12);
}

// Weights count as repeated points: two points at weight 3 and 1 are the mean of four.
TEST(WeightedLineFit, WeightsActAsRepeatedPoints) {
  WeightedLineFit weighted, repeated;
  weighted.add(0.0, 1.0, 3.0);
  weighted.add(1.0, 2.0, 1.0);
  weighted.add(2.0, 5.0, 1.0);
  for (int i = 0; i < 3; ++i) repeated.add(0.0, 1.0);
  repeated.add(1.0, 2.0);
  repeated.add(2.0, 5.0);
  EXPECT_NEAR(weighted.slope(), repeated.slope(), 1e-12);
  EXPECT_NEAR(weighted.intercept(), repeated.intercept(), 1e-12);
  // By hand for the five points (x mean 0.6, y mean 2): sum (x - 0.6)(y - 2) = 6, sum (x - 0.6)^2 = 3.2.
  EXPECT_NEAR(weighted.slope(), 6.0 / 3.2, 1e-12);
  EXPECT_NEAR(weighted.intercept(), 2.0 - 0.6 * 6.0 / 3.2, 1e-12);
}

TEST(WeightedLineFit, OneDistinctXLeavesTheSlopeZeroAndTheMean) {
  WeightedLineFit f;
  f.add(2.0, 4.0, 1.0);
  f.add(2.0, 6.0, 3.0);
  EXPECT_FALSE(f.determined());
  EXPECT_EQ(f.slope(), 0.0);
  EXPECT_NEAR(f.intercept(), 5.5, 1e-12);
  EXPECT_NEAR(f.mean_y(), 5.5, 1e-12);
  EXPECT_TRUE(std::isnan(WeightedLineFit().mean_y()));
}
