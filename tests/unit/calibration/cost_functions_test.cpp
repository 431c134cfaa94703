// The chessboard corner model's hand-written Jacobian against central differences
// (tests/support/jacobian_check.h): a wrong derivative would still converge, to a biased corner.
#include "paintlab/calibration/cost_functions.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "jacobian_check.h"
#include "test_util.h"

namespace paintlab::calib {
namespace {

TEST(SaddleCost, JacobianMatchesCentralDifferences) {
  // A window of noise (the Jacobian does not depend on the pixel values) and a corner off
  // the pixel grid with edges neither axis-aligned nor orthogonal, and every gradient and
  // contrast term non-zero, so each of the 12 columns is exercised.
  SaddleWindow w;
  w.h = 5;
  std::mt19937_64 rng(test::seed());
  std::uniform_real_distribution<double> u(0.1, 0.9);
  for (int k = 0; k < (2 * w.h + 1) * (2 * w.h + 1); ++k) w.values.push_back(u(rng));
  const std::unique_ptr<ceres::CostFunction> cost(SaddleCost::Create(&w));
  for (const double log_sigma : {std::log(0.6), std::log(1.5)}) {
    SCOPED_TRACE("sigma " + std::to_string(std::exp(log_sigma)));
    std::array<double, SaddleCost::kParams> p = {0.31, -0.22, 0.12, 1.71, log_sigma, 0.5,
                                                 0.4,  0.03,  0.01, -0.012, 0.006, 0.004};
    test::expect_jacobians_match_central_differences(*cost, {p.data()}, 1e-7);
  }
}

}  // namespace
}  // namespace paintlab::calib
