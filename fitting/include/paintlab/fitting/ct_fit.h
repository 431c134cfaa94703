#pragma once
// Fit of the multi-lobe Cook-Torrance model (Günther et al. 2005, eq. 1; models.md) to a
// binned table with Ceres (docs/fitting.md "Cook-Torrance fit"):
//  - residuals: whitened log residuals (log f(mean coords) - y_bc) / sigma_bc of fit_data.h,
//    or (FitDataOptions::residuals = Linear) (f - v_bc) / (sigma'_bc ref_bc) (fit_data.h),
//    one residual block per chunk of bins (3 residuals per bin); a Huber loss on them;
//  - parameters: per channel (kd_c, ks_1c .. ks_Nc) >= 0, shared (m_l, r_l) with m in
//    [m_min, 1 - 1e-6] and r in [1e-6, 1 - 1e-6] (Ceres bounds, no penalty terms; paint files want (0, 1));
//  - starts: a grid over the lobe roughnesses (m combinations from a fixed log-spaced
//    list, r = 0.5) with kd and ks from a non-negative linear least-squares fit of the
//    relative residuals, the best few grid points plus seeded random perturbations of the
//    best one; every start runs on a deterministic subsample, the best is polished on all
//    bins;
//  - lobes are ordered broadest first (largest m first);
//  - standard deviations from ceres::Covariance at the solution (parameters at a bound are
//    held fixed and get 0), scaled by sqrt(max(1, chi2 / dof)).
// The lobe is brdf::ct_lobe, the same template the simulator evaluates.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "paintlab/brdf/paint.h"
#include "paintlab/core/json.h"
#include "paintlab/fitting/fit_data.h"

namespace paintlab::fit {

struct CtFitOptions : MultiStartOptions {
  // Ceres' convergence test: relative change of the cost per iteration. A model that
  // cannot follow the data (a pearlescent paint with Cook-Torrance lobes) creeps for many
  // iterations at 1e-8; 1e-6 stops it where the parameters no longer matter.
  double function_tolerance = 1e-8;
  // A fit with at most `lobes` lobes (usually one lobe fewer): extra starts keep its lobes
  // and add the missing ones (roughness from the grid, kd and ks re-solved by NNLS), so the
  // N-lobe fit ends at least as good as it on the start subsample.
  std::optional<brdf::CookTorranceParams> warm_start;
  void check() const;             // OptionError naming the first violated rule
};

// One start of the multi-start search.
struct StartReport {
  std::string origin;             // "grid m=0.25,0.09,0.018" or "seed 3"
  double initial_cost = 0;
  double final_cost = 0;
  int iterations = 0;
  bool converged = false;
  Json to_json() const;
};

// What every fit reports (fit.json "summary").
struct FitSummary {
  bool converged = false;          // Ceres terminated with CONVERGENCE
  std::string termination;         // Ceres' termination type and message
  int iterations = 0;              // of the final solve
  double initial_cost = 0;
  double final_cost = 0;           // Ceres cost 1/2 sum rho(r^2)
  std::size_t residual_blocks = 0;
  std::size_t residuals = 0;
  std::size_t parameters = 0;
  double chi2_per_dof = 0;         // 2 cost / (residuals - parameters)
  double time_s = 0;
  std::uint64_t seed = 0;
  std::string residual_form = "log";  // "log" or "linear" (fit_data.h)
  std::vector<StartReport> starts;
  bool covariance_ok = false;
  std::string covariance_message;
  Json to_json() const;
};

// Standard deviations in the shape of the parameters.
struct CookTorranceStddev {
  brdf::Rgb kd = brdf::Rgb::Zero();
  std::vector<brdf::CtLobe> lobes;  // ks, m, r hold standard deviations
  Json to_json() const;             // {"kd": [..], "lobes": [{"ks": [..], "m": .., "r": ..}]}
};

struct CookTorranceFit {
  brdf::CookTorranceParams params;  // lobes broadest first
  CookTorranceStddev stddev;
  ResidualReport residual;
  FitSummary summary;
  // The "fit" object of DESIGN.md plus standard deviations and the summary:
  // {"name", "model": "cook-torrance", "kd", "lobes", "residual", "stddev", "summary"}.
  // brdf::paint_from_json reads it back as a paint.
  Json to_json(const std::string& name) const;
};

// Fits `options.lobes` lobes. Throws DataError when the data cannot be fitted (no usable
// bins, fewer residuals than parameters). A fit that does not converge is returned with
// summary.converged = false (callers decide).
CookTorranceFit fit_cook_torrance(const FitData& data, const CtFitOptions& options = {});

// A fit made in one linear colour space expressed in another, out = `to` (3x3) in: kd and
// every lobe's ks are mapped (the model is linear in them; m and r are shared by the
// channels and stay), their standard deviations as sqrt(to o to var) with the channels
// taken as independent. A channel that comes out negative (a colour outside the target
// space's gamut) is set to 0 and counted in `clipped` when given. The residuals and
// the solver summary stay those of the fit (in the space it was made in).
CookTorranceFit transform_colours(const CookTorranceFit& fit, const Eigen::Matrix3d& to, int* clipped = nullptr);

// The model at every fit bin (3 values per bin, at the mean coordinates).
std::vector<double> evaluate_cook_torrance(const FitData& data, const brdf::CookTorranceParams& params);

}  // namespace paintlab::fit
