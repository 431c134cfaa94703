#pragma once
// The Ceres cost functions of the fits, named and public so that their derivatives can be
// checked against numeric differentiation (tests/unit/fitting/cost_functions_test.cpp).
#include <ceres/cost_function.h>

#include <vector>

#include "paintlab/fitting/fit_data.h"

namespace paintlab::fit {

// One residual block of the Cook-Torrance fit: the whitened residuals of a chunk of fit
// points, 3 per point (R, G, B: row 3q + c), log (or linear, FitData::linear) in the model
// value kd/pi + sum_l ks_l lobe(m_l, r_l). Parameter blocks: per channel (kd_c, ks_1c ..
// ks_Nc) three times, then (m_1, r_1, .., m_N, r_N). The lobes are evaluated once per point
// for all channels, with a 2-dimensional Jet in (m, r) when Ceres asks for Jacobians; the
// Jacobian of the linear weights is analytic. Evaluate returns false for a model value at or
// below 1e-30 / sr in log mode (a step Ceres must reject).
class CtChunkCost final : public ceres::CostFunction {
 public:
  CtChunkCost(const FitData* data, std::vector<const FitBin*> bins, int lobes);
  static ceres::CostFunction* Create(const FitData* data, std::vector<const FitBin*> bins, int lobes);
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override;

 private:
  const FitData* data_;
  std::vector<const FitBin*> bins_;
  int n_;
  bool linear_;
};

}  // namespace paintlab::fit
