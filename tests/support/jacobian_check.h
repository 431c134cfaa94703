#pragma once
// Checks a Ceres cost function's Jacobians against central differences, column by column:
// the largest difference in a column must be within `tolerance` of the column's largest
// entry, and no column may be zero. Why not ceres::GradientChecker: its Ridders' method
// starts from an absolute step of at least 0.01, which on a clear-coat lobe of roughness
// 0.05 crosses the whole peak and fails to extrapolate, and it judges entry by entry, so
// an entry of 1e-10 that is off by 1e-14 fails. Central differences with a step of 1e-6
// of each parameter are accurate to about 1e-9 here.
#include <ceres/cost_function.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

namespace paintlab::test {

inline void expect_jacobians_match_central_differences(const ceres::CostFunction& cost,
                                                       const std::vector<double*>& params, double tolerance) {
  const auto& sizes = cost.parameter_block_sizes();
  ASSERT_EQ(sizes.size(), params.size());
  const int m = cost.num_residuals();
  std::vector<double> r(static_cast<std::size_t>(m)), rp(r), rm(r);
  std::vector<std::vector<double>> jac(sizes.size());
  std::vector<double*> jac_ptr;
  for (std::size_t b = 0; b < sizes.size(); ++b) {
    jac[b].resize(static_cast<std::size_t>(m * sizes[b]));
    jac_ptr.push_back(jac[b].data());
  }
  ASSERT_TRUE(cost.Evaluate(params.data(), r.data(), jac_ptr.data())) << "the cost function failed at the point";
  for (std::size_t b = 0; b < sizes.size(); ++b)
    for (int k = 0; k < sizes[b]; ++k) {
      double& x = params[b][k];
      const double keep = x, h = 1e-6 * std::max(std::abs(keep), 1e-3);
      x = keep + h;
      ASSERT_TRUE(cost.Evaluate(params.data(), rp.data(), nullptr)) << "block " << b << " column " << k << " + h";
      x = keep - h;
      ASSERT_TRUE(cost.Evaluate(params.data(), rm.data(), nullptr)) << "block " << b << " column " << k << " - h";
      x = keep;
      double scale = 0.0, worst = 0.0, analytic = 0.0, numeric = 0.0;
      int worst_row = 0;
      for (int i = 0; i < m; ++i) {
        const double a = jac[b][static_cast<std::size_t>(i * sizes[b] + k)];
        const double n = (rp[static_cast<std::size_t>(i)] - rm[static_cast<std::size_t>(i)]) / (2 * h);
        scale = std::max(scale, std::abs(a));
        if (std::abs(a - n) > worst) {
          worst = std::abs(a - n);
          worst_row = i;
          analytic = a;
          numeric = n;
        }
      }
      EXPECT_GT(scale, 0.0) << "block " << b << " column " << k << " is zero";
      EXPECT_LE(worst, tolerance * scale) << "block " << b << " column " << k << ": row " << worst_row << " analytic "
                                          << analytic << ", central difference " << numeric;
    }
}

}  // namespace paintlab::test
