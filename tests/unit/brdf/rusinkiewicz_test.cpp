// Half/difference coordinates: round trips both ways and the definition of models.md.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

#include "paintlab/brdf/rusinkiewicz.h"
#include "test_util.h"

using namespace paintlab;
using namespace paintlab::brdf;

namespace {

Eigen::Vector3d random_hemisphere_direction(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(0, 1);
  const double z = u(rng), phi = 2 * std::numbers::pi * u(rng);
  const double s = std::sqrt(1 - z * z);
  return {s * std::cos(phi), s * std::sin(phi), z};
}
}  // namespace

TEST(Rusinkiewicz, DirectionsRoundTrip) {
  std::mt19937_64 rng(test::seed());
  for (int n = 0; n < 20000; ++n) {
    const Eigen::Vector3d wi = random_hemisphere_direction(rng), wo = random_hemisphere_direction(rng);
    const HalfDiff hd = half_diff_from_directions(wi, wo);
    const DirectionPair back = directions_from_half_diff(hd);
    ASSERT_LT((back.wi - wi).norm(), 1e-9) << n;
    ASSERT_LT((back.wo - wo).norm(), 1e-9) << n;
  }
}

TEST(Rusinkiewicz, AnglesRoundTrip) {
  std::mt19937_64 rng(test::seed() + 1);
  std::uniform_real_distribution<double> u(0, 1);
  for (int n = 0; n < 20000; ++n) {
    HalfDiff hd{0.05 + 1.4 * u(rng), -3.0 + 6.0 * u(rng), 0.05 + 1.4 * u(rng), -3.0 + 6.0 * u(rng)};
    const DirectionPair d = directions_from_half_diff(hd);
    const HalfDiff back = half_diff_from_directions(d.wi, d.wo);
    ASSERT_NEAR(back.theta_h, hd.theta_h, 1e-9);
    ASSERT_NEAR(back.theta_d, hd.theta_d, 1e-9);
    ASSERT_NEAR(std::remainder(back.phi_h - hd.phi_h, 2 * std::numbers::pi), 0.0, 1e-9);
    ASSERT_NEAR(std::remainder(back.phi_d - hd.phi_d, 2 * std::numbers::pi), 0.0, 1e-9);
  }
}

TEST(Rusinkiewicz, MatchesTheDefinition) {
  std::mt19937_64 rng(test::seed() + 2);
  for (int n = 0; n < 2000; ++n) {
    const Eigen::Vector3d wi = random_hemisphere_direction(rng), wo = random_hemisphere_direction(rng);
    const HalfDiff hd = half_diff_from_directions(wi, wo);
    const Eigen::Vector3d h = (wi + wo).normalized();
    EXPECT_NEAR(hd.theta_h, std::acos(h.z()), 1e-9);
    EXPECT_NEAR(hd.theta_d, std::acos(std::clamp(h.dot(wi), -1.0, 1.0)), 1e-7);
    // Swapping wi and wo turns phi_d by pi (reciprocity).
    const HalfDiff sw = half_diff_from_directions(wo, wi);
    EXPECT_NEAR(sw.theta_h, hd.theta_h, 1e-12);
    EXPECT_NEAR(sw.theta_d, hd.theta_d, 1e-9);
    EXPECT_NEAR(std::abs(std::remainder(sw.phi_d - hd.phi_d, 2 * std::numbers::pi)), std::numbers::pi, 1e-7);
    // The templated cosines agree with the directions.
    const auto c = cosines_from_half_diff(hd.theta_h, hd.theta_d, hd.phi_d);
    EXPECT_NEAR(c.n_dot_h, h.z(), 1e-12);
    EXPECT_NEAR(c.h_dot_wo, h.dot(wo), 1e-9);
    EXPECT_NEAR(c.n_dot_wi, wi.z(), 1e-9);
    EXPECT_NEAR(c.n_dot_wo, wo.z(), 1e-9);
  }
}

TEST(Rusinkiewicz, SpecularConfigurationHasZeroThetaH) {
  const double t = 0.6;
  const HalfDiff hd = half_diff_from_spherical(t, 0.3, t, 0.3 + std::numbers::pi);
  EXPECT_NEAR(hd.theta_h, 0.0, 1e-7);
  EXPECT_NEAR(hd.theta_d, t, 1e-7);
}
