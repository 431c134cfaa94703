#pragma once
// Pieces both Ceres fits (Cook-Torrance, AxF-like car paint) use: the roughness grid and
// non-negative least squares of the starts, deterministic subsampling, and standard
// deviations from ceres::Covariance on a compact form of a big problem.
#include <ceres/ceres.h>

#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "paintlab/fitting/ct_fit.h"
#include "paintlab/fitting/fit_data.h"

namespace paintlab::fit::detail {

// Bounds of parameters that paint files require in the open interval (0, 1) (m, r, spread,
// F0): the fits keep them this far inside, so every fit reads back as a paint.
inline constexpr double kUnitLo = 1e-6;
inline constexpr double kUnitHi = 1.0 - 1e-6;
// Whether a fitted value sits on its bound (it is then held fixed for the covariance).
inline bool at_bound(double v, double lo, double hi) { return v <= lo + 1e-9 * (1.0 + lo) || v >= hi - 1e-9; }

// Log-spaced lobe roughnesses (broadest first) not below m_min.
std::vector<double> roughness_grid(double m_min);

// Calls fn with every strictly increasing tuple of n indices from [0, count).
void for_each_combination(int count, int n, const std::function<void(const std::vector<int>&)>& fn);

// min x'Ax - 2b'x over x >= 0 for a handful of unknowns, by enumerating the active sets
// (convex: the best feasible stationary point of a face is the optimum). Returns the
// cost without the constant term; x = 0 when nothing is feasible.
double nnls_small(const Eigen::MatrixXd& a, const Eigen::VectorXd& b, Eigen::VectorXd& x);

// A deterministic subsample of about `target` fit bins (a hash of the bin index), peak
// bins four times as likely as others (they alone constrain narrow lobes).
std::vector<const FitBin*> subsample(const FitData& data, std::size_t target);

int thread_count(int requested);  // 0 -> all cores

// What fit.json records of one start: its costs, iterations and whether it converged.
StartReport start_report(const std::string& origin, const ceres::Solver::Summary& summary);

// One parameter block of a solved problem for covariance_stddev(): the coordinates held
// fixed (at a bound, or undetermined) and, on return, the standard deviations (0 for fixed
// coordinates).
struct CovarianceBlock {
  double* values = nullptr;
  int size = 0;
  std::vector<int> fixed;
  std::vector<double> stddev;
};

// Standard deviations at the current parameter values of `problem` from ceres::Covariance
// (DENSE_SVD), scaled by `scale`. The covariance is computed on a compact problem with the
// same Gram matrix: each residual block's loss-corrected Jacobian J is replaced by the R of
// its QR factorisation (R'R = J'J), so the cost is a fraction of a solve. Returns false
// with a message when the Jacobian is rank deficient.
bool covariance_stddev(const ceres::Problem& problem, const std::vector<ceres::ResidualBlockId>& ids,
                       std::vector<CovarianceBlock>& blocks, double scale, std::string& message);

}  // namespace paintlab::fit::detail
