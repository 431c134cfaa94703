// The fits' hand-written Jacobians against central differences (tests/support/jacobian_check.h):
// a wrong derivative would still converge somewhere, to the wrong paint, slowly.
#include "paintlab/fitting/cost_functions.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <numbers>
#include <random>
#include <memory>
#include <vector>

#include "paintlab/brdf/carpaint.h"
#include "paintlab/brdf/cook_torrance.h"
#include "synthetic.h"
#include "jacobian_check.h"
#include "test_util.h"

namespace paintlab::fit {
namespace {

struct CtCase {
  FitResiduals residuals;
  std::uint32_t min_samples;
};

class CtChunkCostGradient : public ::testing::TestWithParam<CtCase> {};

TEST_P(CtChunkCostGradient, MatchesCentralDifferences) {
  // A two-lobe metallic seen by a simulated sweep (noisy samples with counts, so pooling and
  // the sample-spread weights of linear residuals have something to work on).
  const brdf::CookTorrance truth(brdf::Rgb(0.03, 0.05, 0.2),
                                 {{brdf::Rgb(0.05, 0.06, 0.07), 0.3, 0.9}, {brdf::Rgb(0.2, 0.2, 0.2), 0.05, 0.05}});
  const brdf::MerlTable table = test_support::binned_sweep(truth, 80, 0.02, test::seed(), 10.0).table;
  FitDataOptions o;
  o.residuals = GetParam().residuals;
  o.min_samples = GetParam().min_samples;
  const FitData data = prepare_fit_data(table, o);
  ASSERT_GT(data.bins.size(), 200u);
  std::vector<const FitBin*> bins;
  for (std::size_t q = 0; q < data.bins.size(); q += data.bins.size() / 200) bins.push_back(&data.bins[q]);
  const std::unique_ptr<ceres::CostFunction> cost(CtChunkCost::Create(&data, bins, 2));

  // Away from the truth (the residuals are not zero) and away from any bound.
  std::array<std::array<double, 3>, 3> lin = {{{0.04, 0.04, 0.25}, {0.06, 0.07, 0.09}, {0.15, 0.25, 0.18}}};
  std::array<double, 4> nl = {0.25, 0.8, 0.07, 0.08};
  std::vector<double*> params = {lin[0].data(), lin[1].data(), lin[2].data(), nl.data()};
  test::expect_jacobians_match_central_differences(*cost, params, 1e-6);
}

INSTANTIATE_TEST_SUITE_P(Residuals, CtChunkCostGradient,
                         ::testing::Values(CtCase{FitResiduals::Log, 1}, CtCase{FitResiduals::Log, 120},
                                           CtCase{FitResiduals::Linear, 1}),
                         [](const auto& info) {
                           return std::string(info.param.residuals == FitResiduals::Log ? "Log" : "Linear") +
                                  (info.param.min_samples > 1 ? "Pooled" : "");
                         });


TEST(AxfAchromaticCost, IsTheLogOfTheCarPaintModelAndItsJacobianCentralDifferences) {
  // Two lobes under a clear coat of eta 1.5: each fit point of one member is log f of
  // brdf::AxfCarPaint with a colour table of ones.
  brdf::AxfCarPaintParams paint;
  paint.ior = 1.5;
  paint.diffuse = 0.08;
  paint.lobes = {{0.6, 0.35, 0.9}, {2.0, 0.08, 0.4}};
  const brdf::AxfCarPaint model(paint);
  std::vector<AchromaticMember> members;
  std::mt19937_64 rng(test::seed());
  std::uniform_real_distribution<double> u(0.0, 1.0);
  while (members.size() < 40) {  // directions above the surface, some near the mirror direction
    const double ti = 1.3 * u(rng), to = 1.3 * u(rng), pi = 6.28 * u(rng), po = pi + std::numbers::pi + 0.6 * (u(rng) - 0.5);
    AchromaticMember m;
    m.wi = brdf::Vec3(std::sin(ti) * std::cos(pi), std::sin(ti) * std::sin(pi), std::cos(ti));
    m.wo = brdf::Vec3(std::sin(to) * std::cos(po), std::sin(to) * std::sin(po), std::cos(to));
    members.push_back(m);
  }
  std::vector<AchromaticBin> bins(members.size());
  std::vector<const AchromaticBin*> chunk;
  for (std::size_t i = 0; i < members.size(); ++i) {
    bins[i].members = &members[i];
    bins[i].member_count = 1;
    bins[i].target = 0.0;
    bins[i].inv_sigma = 1.0;
    chunk.push_back(&bins[i]);
  }
  const std::unique_ptr<ceres::CostFunction> cost(AxfAchromaticCost<2>::Create(&chunk));
  std::array<double, 6> p = {paint.ior, paint.diffuse, 0.6, 0.35, 2.0, 0.08};
  std::array<double, 2> f0 = {0.9, 0.4};
  std::vector<double> r(chunk.size());
  const double* blocks[2] = {p.data(), f0.data()};
  ASSERT_TRUE(cost->Evaluate(blocks, r.data(), nullptr));
  for (std::size_t i = 0; i < members.size(); ++i)
    EXPECT_NEAR(r[i], std::log(model.eval(members[i].wi, members[i].wo)[0]), 1e-9) << i;
  // Away from the paint and from the bounds, with weights and targets of their own.
  for (std::size_t i = 0; i < bins.size(); ++i) {
    bins[i].target = -1.0 + 0.05 * static_cast<double>(i % 7);
    bins[i].inv_sigma = 2.0 + static_cast<double>(i % 3);
  }
  p = {1.62, 0.05, 0.5, 0.3, 1.5, 0.1};
  f0 = {0.8, 0.5};
  test::expect_jacobians_match_central_differences(*cost, {p.data(), f0.data()}, 1e-6);
}

}  // namespace
}  // namespace paintlab::fit
