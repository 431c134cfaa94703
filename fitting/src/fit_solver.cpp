#include "fit_solver.h"

#include <Eigen/Cholesky>
#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <fmt/format.h>
#include <limits>
#include <map>
#include <thread>

#include "fit_util.h"

namespace paintlab::fit::detail {

std::vector<double> roughness_grid(double m_min) {
  std::vector<double> grid;
  for (double m : {0.6, 0.4, 0.25, 0.15, 0.09, 0.05, 0.03, 0.018, 0.01, 0.006, 0.0035, 0.002})
    if (m >= m_min) grid.push_back(m);
  return grid;
}

void for_each_combination(int count, int n, const std::function<void(const std::vector<int>&)>& fn) {
  std::vector<int> pick(static_cast<std::size_t>(n));
  std::function<void(int, int)> rec = [&](int depth, int from) {
    if (depth == n) {
      fn(pick);
      return;
    }
    for (int g = from; g < count; ++g) {
      pick[static_cast<std::size_t>(depth)] = g;
      rec(depth + 1, g + 1);
    }
  };
  rec(0, 0);
}

double nnls_small(const Eigen::MatrixXd& a, const Eigen::VectorXd& b, Eigen::VectorXd& x) {
  const int n = static_cast<int>(b.size());
  double best = std::numeric_limits<double>::infinity();
  x = Eigen::VectorXd::Zero(n);
  for (int mask = 0; mask < (1 << n); ++mask) {
    std::vector<int> idx;
    for (int k = 0; k < n; ++k)
      if (mask & (1 << k)) idx.push_back(k);
    Eigen::VectorXd sol = Eigen::VectorXd::Zero(n);
    if (!idx.empty()) {
      const int m = static_cast<int>(idx.size());
      Eigen::MatrixXd as(m, m);
      Eigen::VectorXd bs(m);
      for (int i = 0; i < m; ++i) {
        bs[i] = b[idx[i]];
        for (int j = 0; j < m; ++j) as(i, j) = a(idx[i], idx[j]);
      }
      const Eigen::LDLT<Eigen::MatrixXd> ldlt(as);
      if (ldlt.info() != Eigen::Success) continue;
      const Eigen::VectorXd xs = ldlt.solve(bs);
      if (!xs.allFinite() || (xs.array() < 0.0).any()) continue;
      for (int i = 0; i < m; ++i) sol[idx[i]] = xs[i];
    }
    const double cost = sol.dot(a * sol) - 2.0 * b.dot(sol);
    if (cost < best) {
      best = cost;
      x = sol;
    }
  }
  return best;
}

std::vector<const FitBin*> subsample(const FitData& data, std::size_t target) {
  std::vector<const FitBin*> all;
  all.reserve(data.bins.size());
  for (const FitBin& b : data.bins) all.push_back(&b);
  if (all.size() <= target) return all;
  std::size_t peak = 0;
  for (const FitBin& b : data.bins) peak += b.region == Region::Peak;
  const double p_other = static_cast<double>(target) / (static_cast<double>(all.size() - peak) + 4.0 * peak);
  const double p_peak = std::min(1.0, 4.0 * p_other);
  std::vector<const FitBin*> out;
  for (const FitBin* b : all) {
    const double u = static_cast<double>(splitmix64(b->bin) >> 11) * 0x1.0p-53;
    if (u < (b->region == Region::Peak ? p_peak : p_other)) out.push_back(b);
  }
  return out;
}

StartReport start_report(const std::string& origin, const ceres::Solver::Summary& summary) {
  StartReport r;
  r.origin = origin;
  r.initial_cost = summary.initial_cost;
  r.final_cost = summary.final_cost;
  r.iterations = static_cast<int>(summary.iterations.size()) - 1;
  r.converged = summary.termination_type == ceres::CONVERGENCE;
  return r;
}

int thread_count(int requested) {
  return requested > 0 ? requested : std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
}

namespace {

// r = R (x - x0) over the concatenated parameter blocks: a residual block with a fixed
// Jacobian R.
class LinearizedCost final : public ceres::CostFunction {
 public:
  LinearizedCost(Eigen::MatrixXd r, std::vector<int> sizes, Eigen::VectorXd x0)
      : r_(std::move(r)), x0_(std::move(x0)), sizes_(std::move(sizes)) {
    set_num_residuals(static_cast<int>(r_.rows()));
    for (int s : sizes_) mutable_parameter_block_sizes()->push_back(s);
  }
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    Eigen::VectorXd dx(x0_.size());
    int off = 0;
    for (std::size_t b = 0; b < sizes_.size(); ++b) {
      for (int k = 0; k < sizes_[b]; ++k) dx[off + k] = parameters[b][k] - x0_[off + k];
      off += sizes_[b];
    }
    Eigen::Map<Eigen::VectorXd>(residuals, r_.rows()) = r_ * dx;
    if (!jacobians) return true;
    off = 0;
    for (std::size_t b = 0; b < sizes_.size(); ++b) {
      if (jacobians[b])
        for (Eigen::Index i = 0; i < r_.rows(); ++i)
          for (int k = 0; k < sizes_[b]; ++k) jacobians[b][i * sizes_[b] + k] = r_(i, off + k);
      off += sizes_[b];
    }
    return true;
  }

 private:
  Eigen::MatrixXd r_;
  Eigen::VectorXd x0_;
  std::vector<int> sizes_;
};

}  // namespace

bool covariance_stddev(const ceres::Problem& problem, const std::vector<ceres::ResidualBlockId>& ids,
                       std::vector<CovarianceBlock>& blocks, double scale, std::string& message) {
  std::map<const double*, int> column_of;
  std::vector<int> sizes;
  int total = 0;
  for (const CovarianceBlock& b : blocks) {
    column_of[b.values] = total;
    sizes.push_back(b.size);
    total += b.size;
  }
  Eigen::VectorXd x0(total);
  for (std::size_t k = 0, off = 0; k < blocks.size(); off += static_cast<std::size_t>(blocks[k].size), ++k)
    for (int i = 0; i < blocks[k].size; ++i) x0[static_cast<Eigen::Index>(off) + i] = blocks[k].values[i];

  // The compact problem has its own copy of the parameters.
  std::vector<std::vector<double>> storage;
  for (const CovarianceBlock& b : blocks) storage.emplace_back(b.values, b.values + b.size);
  std::vector<double*> compact_blocks;
  for (auto& s : storage) compact_blocks.push_back(s.data());
  ceres::Problem compact;

  for (ceres::ResidualBlockId id : ids) {
    std::vector<double*> params;
    problem.GetParameterBlocksForResidualBlock(id, &params);
    const int rows = problem.GetCostFunctionForResidualBlock(id)->num_residuals();
    std::vector<std::vector<double>> jac(params.size());
    std::vector<double*> jac_ptr(params.size());
    for (std::size_t p = 0; p < params.size(); ++p) {
      jac[p].assign(static_cast<std::size_t>(rows) * problem.ParameterBlockSize(params[p]), 0.0);
      // Ceres computes no Jacobian for a constant block; its columns stay zero (fixed).
      jac_ptr[p] = problem.IsParameterBlockConstant(params[p]) ? nullptr : jac[p].data();
    }
    std::vector<double> residuals(static_cast<std::size_t>(rows));
    double cost = 0;
    if (!problem.EvaluateResidualBlock(id, true, &cost, residuals.data(), jac_ptr.data())) {
      message = "the Jacobian could not be evaluated at the solution";
      return false;
    }
    Eigen::MatrixXd j = Eigen::MatrixXd::Zero(rows, total);
    for (std::size_t p = 0; p < params.size(); ++p) {
      const auto it = column_of.find(params[p]);
      if (it == column_of.end()) continue;  // a block not asked for
      const int size = problem.ParameterBlockSize(params[p]);
      j.middleCols(it->second, size) =
          Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(jac[p].data(), rows,
                                                                                                   size);
    }
    const Eigen::HouseholderQR<Eigen::MatrixXd> qr(j);
    const Eigen::Index kept = std::min<Eigen::Index>(rows, total);
    Eigen::MatrixXd r = qr.matrixQR().topRows(kept).triangularView<Eigen::Upper>();
    compact.AddResidualBlock(new LinearizedCost(std::move(r), sizes, x0), nullptr, compact_blocks);
  }
  if (ids.empty()) {
    message = "no residuals";
    return false;
  }

  std::vector<std::pair<const double*, const double*>> wanted;
  std::vector<bool> free(blocks.size());
  for (std::size_t k = 0; k < blocks.size(); ++k) {
    const CovarianceBlock& b = blocks[k];
    if (static_cast<int>(b.fixed.size()) >= b.size) {
      compact.SetParameterBlockConstant(compact_blocks[k]);
      free[k] = false;
      continue;
    }
    if (!b.fixed.empty()) compact.SetManifold(compact_blocks[k], new ceres::SubsetManifold(b.size, b.fixed));
    free[k] = true;
    wanted.emplace_back(compact_blocks[k], compact_blocks[k]);
  }
  ceres::Covariance::Options co;
  co.algorithm_type = ceres::DENSE_SVD;
  co.num_threads = 1;
  ceres::Covariance cov(co);
  if (!cov.Compute(wanted, &compact)) {
    message = "ceres::Covariance::Compute failed: the Jacobian is rank deficient at the solution";
    return false;
  }
  for (std::size_t k = 0; k < blocks.size(); ++k) {
    CovarianceBlock& b = blocks[k];
    b.stddev.assign(static_cast<std::size_t>(b.size), 0.0);
    if (!free[k]) continue;
    std::vector<double> m(static_cast<std::size_t>(b.size * b.size), 0.0);
    cov.GetCovarianceBlock(compact_blocks[k], compact_blocks[k], m.data());
    for (int i = 0; i < b.size; ++i)
      b.stddev[static_cast<std::size_t>(i)] = std::sqrt(std::max(0.0, m[static_cast<std::size_t>(i * b.size + i)])) * scale;
  }
  message = fmt::format(
      "ceres::Covariance (DENSE_SVD) on the per-block R factors of the loss-corrected Jacobian; parameters at a "
      "bound held fixed; scaled by sqrt(max(1, chi2/dof)) = {:.3g}",
      scale);
  return true;
}

}  // namespace paintlab::fit::detail
