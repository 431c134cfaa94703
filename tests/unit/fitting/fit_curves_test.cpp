// The measured-against-fitted curves a residual report carries for `paintlab report`
// (fit_data.h FitCurve): points near each theta_d grouped by their theta_h bin, measured and
// model values averaged over the same points and used channels.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <numbers>

#include "paintlab/fitting/fit_data.h"

using namespace paintlab;
using namespace paintlab::fit;

namespace {
constexpr double kRad = std::numbers::pi / 180.0;

FitBin point(double theta_h_deg, double theta_d_deg, std::array<double, 3> value, std::array<double, 3> inv_sigma) {
  FitBin b;
  b.coords = {theta_h_deg * kRad, theta_d_deg * kRad, 90.0 * kRad};
  b.value = value;
  b.inv_sigma = inv_sigma;
  b.noise_sigma = {0.01, 0.01, 0.01};
  return b;
}
}  // namespace

TEST(FitCurves, PointsNearEachThetaDAreAveragedPerThetaHBinOverTheirUsedChannels) {
  FitData data;
  std::vector<double> model;
  // theta_d 30 (+-2.5): four theta_h groups; the first holds two points, one of them with
  // only its green channel used (a filter-array site).
  data.bins.push_back(point(1.0, 29.0, {2.0, 4.0, 6.0}, {1, 1, 1}));
  model.insert(model.end(), {1.0, 2.0, 3.0});
  data.bins.push_back(point(1.01, 31.0, {0.0, 10.0, 0.0}, {0, 1, 0}));
  model.insert(model.end(), {5.0, 8.0, 5.0});
  for (double th : {10.0, 20.0, 40.0}) {
    data.bins.push_back(point(th, 30.0, {1.0, 1.0, 1.0}, {1, 1, 1}));
    model.insert(model.end(), {0.5, 0.5, 0.5});
  }
  // Outside every slice's window (theta_d 35 is 5 deg from 30): not on any curve.
  data.bins.push_back(point(5.0, 35.0, {9.0, 9.0, 9.0}, {1, 1, 1}));
  model.insert(model.end(), {9.0, 9.0, 9.0});
  // theta_d 5: only two groups, too few for a curve.
  data.bins.push_back(point(3.0, 5.0, {1.0, 1.0, 1.0}, {1, 1, 1}));
  data.bins.push_back(point(30.0, 5.0, {1.0, 1.0, 1.0}, {1, 1, 1}));
  model.insert(model.end(), {1, 1, 1, 1, 1, 1});

  const ResidualReport r = residual_report(data, model);
  ASSERT_EQ(r.curves.size(), 1u);
  const FitCurve& c = r.curves[0];
  EXPECT_DOUBLE_EQ(c.theta_d_deg, 30.0);
  ASSERT_EQ(c.theta_h_deg.size(), 4u);
  EXPECT_NEAR(c.theta_h_deg[0], 1.005, 1e-9);
  EXPECT_EQ(c.points[0], 2u);
  // (2 + 4 + 6 + 10) / 4 channel values; the model over the same four: (1 + 2 + 3 + 8) / 4.
  EXPECT_DOUBLE_EQ(c.measured[0], 22.0 / 4.0);
  EXPECT_DOUBLE_EQ(c.model[0], 14.0 / 4.0);
  EXPECT_DOUBLE_EQ(c.measured[3], 1.0);
  EXPECT_DOUBLE_EQ(c.model[3], 0.5);
  EXPECT_NEAR(c.theta_h_deg[3], 40.0, 1e-9);
  // The coverage map: every point's samples in its (theta_h, theta_d) cell (no statistics
  // here: 1 a point); the first group's two points lie in two theta_d bins.
  ASSERT_EQ(r.coverage.size(), 90u * 90u);
  std::uint32_t total = 0;
  for (std::uint32_t c : r.coverage) total += c;
  EXPECT_EQ(total, data.bins.size());
  const auto cell = [](double th, double td) {
    return static_cast<std::size_t>(brdf::merl_theta_h_index(th * kRad)) * 90 +
           static_cast<std::size_t>(brdf::merl_theta_d_index(td * kRad));
  };
  EXPECT_EQ(r.coverage[cell(1.0, 29.0)] + r.coverage[cell(1.01, 31.0)], 2u);
  EXPECT_EQ(r.coverage[cell(40.0, 30.0)], 1u);
  const Json j = r.to_json();
  EXPECT_EQ(j.at("coverage").at("cells").size(), 8u);  // the 9 points in 8 cells
  ASSERT_EQ(j.at("curves").size(), 1u);
  EXPECT_EQ(j["curves"][0]["theta_h_deg"].size(), 4u);
}
