#include "paintlab/fitting/hole_fill.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "paintlab/brdf/cook_torrance.h"
#include "paintlab/core/error.h"
#include "paintlab/core/image_io.h"
#include "paintlab/fitting/coverage.h"
#include "test_util.h"

namespace paintlab::fit {
namespace {

brdf::CookTorrance silver_ct() {
  return brdf::CookTorrance(brdf::Rgb(0.030, 0.032, 0.035), {{brdf::Rgb(0.060, 0.062, 0.066), 0.38, 0.85},
                                                            {brdf::Rgb(0.045, 0.046, 0.048), 0.16, 0.55},
                                                            {brdf::Rgb(0.15, 0.15, 0.15), 0.015, 0.04}});
}

// The truth table and a copy that keeps a random `keep` fraction of its valid bins.
struct Holey {
  brdf::MerlTable truth;
  brdf::MerlTable table;
};
Holey make_holey(double keep, std::uint64_t seed) {
  Holey h{brdf::tabulate(silver_ct()), {}};
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  for (std::size_t b = 0; b < brdf::kMerlBins; ++b) {
    if (h.truth.state(b) != brdf::BinState::Measured || u(rng) >= keep) continue;
    h.table.set_value(b, h.truth.value(b), brdf::BinState::Measured);
    h.table.set_statistics(b, 5, brdf::Rgb::Zero(), brdf::merl_bin_centre(b));
  }
  return h;
}

TEST(HoleFill, FillsATenPercentTableCloseToTheTruth) {
  Holey h = make_holey(0.10, test::seed());
  const std::size_t measured_before = h.table.count_in_state(brdf::BinState::Measured);
  const HoleFillReport rep = fill_holes(h.table);
  EXPECT_EQ(rep.measured_bins, measured_before);
  EXPECT_GT(rep.filled_mirror, 0u);
  EXPECT_GT(rep.filled_pyramid, 0u);
  EXPECT_EQ(h.table.count_in_state(brdf::BinState::Measured), measured_before);
  // Every valid bin has data now; bins below the horizon stay empty.
  const auto& valid = valid_bin_mask();
  std::vector<double> err_diffuse, err_all;
  for (std::size_t b = 0; b < brdf::kMerlBins; ++b) {
    if (!valid[b]) {
      ASSERT_EQ(h.table.state(b), brdf::BinState::Empty);
      continue;
    }
    ASSERT_NE(h.table.state(b), brdf::BinState::Empty);
    if (h.table.state(b) == brdf::BinState::Measured) {
      ASSERT_EQ(h.table.value(b)[0], h.truth.value(b)[0]);  // untouched
      continue;
    }
    EXPECT_EQ(h.table.count(b), 0u);
    if (h.truth.state(b) != brdf::BinState::Measured) continue;
    const double e = std::abs(std::log(h.table.value(b)[1] / h.truth.value(b)[1]));
    err_all.push_back(e);
    if (region_of_bin(b) == Region::Diffuse) err_diffuse.push_back(e);
  }
  auto median = [](std::vector<double> v) {
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    return v[v.size() / 2];
  };
  const double med_all = median(err_all), med_diffuse = median(err_diffuse);
  std::printf("10%% coverage: median |log error| of filled bins %.4f (all), %.4f (diffuse region)\n", med_all,
              med_diffuse);
  EXPECT_LT(med_all, 0.03);
  EXPECT_LT(med_diffuse, 0.03);
}

TEST(HoleFill, MirrorBinsAreExactForAnIsotropicReciprocalBrdf) {
  Holey h = make_holey(1.0, test::seed());
  // Remove phi_d bins 0..89 of every row: all come back from their mirrors 179..90.
  for (std::size_t b = 0; b < brdf::kMerlBins; ++b)
    if (b % brdf::kMerlPhiD < 90) h.table.set_value(b, brdf::Rgb::Zero(), brdf::BinState::Empty);
  const HoleFillReport rep = fill_holes(h.table);
  EXPECT_EQ(rep.filled_pyramid, 0u);
  std::size_t checked = 0;
  for (std::size_t b = 0; b < brdf::kMerlBins; ++b) {
    if (b % brdf::kMerlPhiD >= 90 || h.truth.state(b) != brdf::BinState::Measured) continue;
    ASSERT_EQ(h.table.state(b), brdf::BinState::Filled);
    ASSERT_NEAR(h.table.value(b)[0], h.truth.value(b)[0], 1e-9 * h.truth.value(b)[0]);
    ++checked;
  }
  EXPECT_GT(checked, 500000u);
}

TEST(HoleFill, AnAllHolesTableIsRejected) {
  brdf::MerlTable t;
  EXPECT_THROW(fill_holes(t), DataError);
  // Measured bins with non-positive values give nothing to fill from either.
  t.set_value(1000, brdf::Rgb(-1e-3, 0, 0), brdf::BinState::Measured);
  EXPECT_THROW(fill_holes(t), DataError);
}

TEST(Coverage, RegionsCountsAndTheMap) {
  Holey h = make_holey(0.25, test::seed());
  const CoverageReport rep = coverage(h.table);
  std::size_t valid = 0, measured = 0;
  for (std::size_t b = 0; b < brdf::kMerlBins; ++b) {
    valid += valid_bin_mask()[b];
    measured += h.table.state(b) == brdf::BinState::Measured;
  }
  EXPECT_EQ(rep.total.valid_bins, valid);
  EXPECT_EQ(rep.total.measured_bins, measured);
  EXPECT_EQ(rep.total.samples, 5 * measured);
  for (const RegionCoverage& r : rep.regions) EXPECT_NEAR(r.measured_fraction(), 0.25, 0.01);
  // Regions go by the bin centre: bin 14 at 2.33 deg (peak), bin 15 at 2.67 deg (glossy).
  EXPECT_EQ(region_of_bin(brdf::merl_flat_index({14, 0, 0})), Region::Peak);
  EXPECT_EQ(region_of_bin(brdf::merl_flat_index({15, 0, 0})), Region::Glossy);
  // Bin centres: bin 46 at 24.0 deg (glossy), bin 47 at 25.1 deg (diffuse).
  EXPECT_EQ(region_of_bin(brdf::merl_flat_index({46, 0, 0})), Region::Glossy);
  EXPECT_EQ(region_of_bin(brdf::merl_flat_index({47, 0, 0})), Region::Diffuse);
  const Json j = rep.to_json();
  EXPECT_EQ(j["total"]["measured_bins"].get<std::size_t>(), measured);
  EXPECT_TRUE(j.contains("peak") && j.contains("glossy") && j.contains("diffuse"));

  test::TempDir dir;
  write_coverage_exr(dir / "coverage.exr", h.table);
  const ExrImage img = read_exr(dir / "coverage.exr");
  EXPECT_EQ(img.width, 1800);
  EXPECT_EQ(img.height, 810);
  for (std::size_t b : {std::size_t{0}, brdf::merl_flat_index({20, 33, 71}), brdf::kMerlBins - 1}) {
    int x, y;
    coverage_pixel(b, x, y);
    EXPECT_EQ(img.plane("count").at(x, y), static_cast<float>(h.table.count(b)));
    EXPECT_EQ(img.plane("state").at(x, y), static_cast<float>(static_cast<int>(h.table.state(b))));
    EXPECT_EQ(img.plane("valid").at(x, y), valid_bin_mask()[b] ? 1.0f : 0.0f);
  }
}

}  // namespace
}  // namespace paintlab::fit
