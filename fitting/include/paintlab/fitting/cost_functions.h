#pragma once
// The Ceres cost functions of the fits, named and public so that their values and
// derivatives are checked against the paint models and central differences
// (tests/unit/fitting/cost_functions_test.cpp).
#include <ceres/autodiff_cost_function.h>
#include <ceres/cost_function.h>

#include <cmath>
#include <cstdint>
#include <numbers>
#include <vector>

#include "paintlab/brdf/carpaint.h"
#include "paintlab/brdf/cook_torrance.h"
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

// A model value at or below this (1/sr) has no logarithm a fit can use.
inline constexpr double kMinAxfModelValue = 1e-30;

// One member bin of a fit point in the AxF car-paint fit's achromatic stage: its mean
// directions and its share of the point's samples.
struct AchromaticMember {
  brdf::Vec3 wi = brdf::Vec3::UnitZ(), wo = brdf::Vec3::UnitZ();
  double weight = 1.0;
};
// One fit point of the achromatic stage: the mean of its channels, its log target and weight.
struct AchromaticBin {
  const FitBin* src = nullptr;
  const AchromaticMember* members = nullptr;  // the fit point's member bins (FitData::members)
  std::uint32_t member_count = 0;
  double value = 0;      // mean of R, G, B
  double target = 0;     // log(value) + delta-method correction
  double inv_sigma = 0;  // 1 / sigma of log(value)
  double noise = 0;      // sigma of log(value) from the noise alone
};

// One residual block of the AxF car paint's achromatic stage with K lobes: per fit point,
// (log f - target) / sigma with f the weighted mean over its members of
//   (a / pi + sum_k s_k lobe(alpha_k, F0_k)) x the clear coat's transmittances
// in the refracted directions (brdf::AxfCarPaint with chi = 1). Parameter blocks: (eta, a,
// s_1, alpha_1, .., s_K, alpha_K) and (F0_1 .. F0_K). Returns false for f at or below
// kMinAxfModelValue (a step Ceres must reject).
template <int K>
struct AxfAchromaticCost {
  const std::vector<const AchromaticBin*>* bins;

  template <class T>
  bool operator()(const T* p, const T* f0, T* residuals) const {
    using std::log;
    for (std::size_t q = 0; q < bins->size(); ++q) {
      const AchromaticBin& b = *(*bins)[q];
      T f(0.0);
      for (std::uint32_t mi = 0; mi < b.member_count; ++mi) {
        const AchromaticMember& m = b.members[mi];
        const brdf::CoatGeometry<T> g = brdf::coat_geometry<T>(p[0], m.wi, m.wo);
        T fm = p[1] * T(std::numbers::inv_pi);
        for (int k = 0; k < K; ++k)
          fm += p[2 + 2 * k] *
                brdf::ct_lobe<T>(p[3 + 2 * k], f0[k], g.n_dot_hbar, g.hbar_dot_obar, g.n_dot_ibar, g.n_dot_obar);
        f += T(m.weight) * fm * g.transmittance;
      }
      if (!(f > T(kMinAxfModelValue))) return false;
      residuals[q] = (log(f) - T(b.target)) * T(b.inv_sigma);
    }
    return true;
  }
  // `bins` must outlive the cost function.
  static ceres::CostFunction* Create(const std::vector<const AchromaticBin*>* bins) {
    return new ceres::AutoDiffCostFunction<AxfAchromaticCost<K>, ceres::DYNAMIC, 2 + 2 * K, K>(
        new AxfAchromaticCost<K>{bins}, static_cast<int>(bins->size()));
  }
};

}  // namespace paintlab::fit
