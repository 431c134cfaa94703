// The fits' hand-written Jacobians against central differences (tests/support/jacobian_check.h):
// a wrong derivative would still converge somewhere, to the wrong paint, slowly.
#include "paintlab/fitting/cost_functions.h"

#include <gtest/gtest.h>

#include <array>
#include <memory>
#include <vector>

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

}  // namespace
}  // namespace paintlab::fit
