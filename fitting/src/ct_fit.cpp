#include "paintlab/fitting/ct_fit.h"

#include <ceres/ceres.h>
#include <ceres/jet.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <ctime>
#include <cmath>
#include <fmt/format.h>
#include <functional>
#include <memory>
#include <numbers>
#include <random>
#include <thread>

#include "fit_solver.h"
#include "fit_util.h"
#include "paintlab/fitting/cost_functions.h"
#include "paintlab/core/error.h"
#include "paintlab/core/log.h"

namespace paintlab::fit {

namespace {

using detail::for_each_combination;
using detail::nnls_small;
using detail::roughness_grid;
using detail::start_report;
using detail::subsample;
using detail::thread_count;

constexpr int kMaxLobes = 3;
constexpr double kMinModelValue = 1e-30;  // 1/sr

}  // namespace

CtChunkCost::CtChunkCost(const FitData* data, std::vector<const FitBin*> bins, int lobes)
    : data_(data), bins_(std::move(bins)), n_(lobes), linear_(data->linear) {
  set_num_residuals(3 * static_cast<int>(bins_.size()));
  for (int c = 0; c < 3; ++c) mutable_parameter_block_sizes()->push_back(n_ + 1);
  mutable_parameter_block_sizes()->push_back(2 * n_);
}

ceres::CostFunction* CtChunkCost::Create(const FitData* data, std::vector<const FitBin*> bins, int lobes) {
  return new CtChunkCost(data, std::move(bins), lobes);
}

bool CtChunkCost::Evaluate(double const* const* parameters, double* residuals, double** jacobians) const {
  using Jet = ceres::Jet<double, 2>;
  const double* nl = parameters[3];
  const int nlin = n_ + 1, nnl = 2 * n_;
  const bool want_jacobian = jacobians != nullptr;
  for (std::size_t q = 0; q < bins_.size(); ++q) {
    const FitBin& b = *bins_[q];
    // The lobes averaged over the point's member bins (one for an unpooled bin).
    std::array<double, kMaxLobes> value{}, dm{}, dr{};
    for (const FitMember* mb = members_begin(*data_, b); mb != members_end(*data_, b); ++mb)
      for (int l = 0; l < n_; ++l) {
        if (want_jacobian) {
          const Jet lobe = brdf::ct_lobe(Jet(nl[2 * l], 0), Jet(nl[2 * l + 1], 1), mb->geometry);
          value[l] += mb->weight * lobe.a;
          dm[l] += mb->weight * lobe.v[0];
          dr[l] += mb->weight * lobe.v[1];
        } else {
          value[l] += mb->weight * brdf::ct_lobe(nl[2 * l], nl[2 * l + 1], mb->geometry);
        }
      }
    for (int c = 0; c < 3; ++c) {
      const std::size_t row = 3 * q + static_cast<std::size_t>(c);
      const double* lin = parameters[c];
      const double w = b.inv_sigma[c];
      double f = 0.0, g = 0.0;  // g: d residual / d f
      if (w != 0.0) {
        f = lin[0] * std::numbers::inv_pi;
        for (int l = 0; l < n_; ++l) f += lin[1 + l] * value[l];
        if (linear_) {
          if (!std::isfinite(f)) return false;
          g = b.linear_weight[c];
          residuals[row] = (f - b.value[c]) * g;
        } else {
          // A model value this small (all of a channel's terms at their bound or underflowed)
          // is no BRDF: the step is rejected, and 1/f cannot overflow the Jacobian.
          if (!(f > kMinModelValue) || !std::isfinite(f)) return false;
          residuals[row] = (std::log(f) - b.target[c]) * w;
          g = w / f;
        }
      } else {
        residuals[row] = 0.0;
      }
      if (!want_jacobian) continue;
      for (int cb = 0; cb < 3; ++cb) {
        if (!jacobians[cb]) continue;
        double* jl = jacobians[cb] + row * nlin;
        if (cb != c || g == 0.0) {
          std::fill(jl, jl + nlin, 0.0);
          continue;
        }
        jl[0] = std::numbers::inv_pi * g;
        for (int l = 0; l < n_; ++l) jl[1 + l] = value[l] * g;
      }
      if (jacobians[3]) {
        double* jn = jacobians[3] + row * nnl;
        for (int l = 0; l < n_; ++l) {
          jn[2 * l] = lin[1 + l] * dm[l] * g;
          jn[2 * l + 1] = lin[1 + l] * dr[l] * g;
        }
      }
    }
  }
  return true;
}

namespace {

// Parameters in the layout of the Ceres problem: per channel (kd_c, ks_1c .. ks_Nc), and
// (m_1, r_1, .., m_N, r_N).
struct CtParams {
  int lobes = 0;
  std::array<std::array<double, kMaxLobes + 1>, 3> lin{};
  std::array<double, 2 * kMaxLobes> nl{};

  brdf::CookTorranceParams to_params() const {
    brdf::CookTorranceParams p;
    for (int c = 0; c < 3; ++c) p.kd[c] = lin[c][0];
    for (int l = 0; l < lobes; ++l) {
      brdf::CtLobe lobe;
      for (int c = 0; c < 3; ++c) lobe.ks[c] = lin[c][1 + l];
      lobe.m = nl[2 * l];
      lobe.r = nl[2 * l + 1];
      p.lobes.push_back(lobe);
    }
    return p;
  }
};

struct Solved {
  CtParams params;
  ceres::Solver::Summary summary;
  std::size_t residual_blocks = 0;
};

struct ProblemHolder {
  ceres::Problem problem;
  std::size_t residual_blocks = 0;
  std::vector<ceres::ResidualBlockId> ids;
};

void build_problem(ProblemHolder& h, const FitData& data, const std::vector<const FitBin*>& bins, CtParams& p,
                   const CtFitOptions& o) {
  ceres::Problem& problem = h.problem;
  const int n = p.lobes;
  for (int c = 0; c < 3; ++c) problem.AddParameterBlock(p.lin[c].data(), n + 1);
  problem.AddParameterBlock(p.nl.data(), 2 * n);
  const std::size_t chunk = static_cast<std::size_t>(o.chunk_bins);
  for (std::size_t s = 0; s < bins.size(); s += chunk) {
    const std::size_t e = std::min(bins.size(), s + chunk);
    std::vector<const FitBin*> part(bins.begin() + static_cast<std::ptrdiff_t>(s),
                                    bins.begin() + static_cast<std::ptrdiff_t>(e));
    ceres::LossFunction* loss = o.huber_scale > 0.0 ? new ceres::HuberLoss(o.huber_scale) : nullptr;
    h.ids.push_back(problem.AddResidualBlock(
        CtChunkCost::Create(&data, std::move(part), n), loss,
        std::vector<double*>{p.lin[0].data(), p.lin[1].data(), p.lin[2].data(), p.nl.data()}));
    ++h.residual_blocks;
  }
  for (int c = 0; c < 3; ++c)
    for (int k = 0; k <= n; ++k) problem.SetParameterLowerBound(p.lin[c].data(), k, 0.0);
  for (int l = 0; l < n; ++l) {
    problem.SetParameterLowerBound(p.nl.data(), 2 * l, o.m_min);
    problem.SetParameterUpperBound(p.nl.data(), 2 * l, detail::kUnitHi);
    problem.SetParameterLowerBound(p.nl.data(), 2 * l + 1, detail::kUnitLo);
    problem.SetParameterUpperBound(p.nl.data(), 2 * l + 1, detail::kUnitHi);
  }
}

Solved solve(const FitData& data, const std::vector<const FitBin*>& bins, CtParams start, const CtFitOptions& o,
             int max_iterations) {
  Solved out;
  out.params = start;
  ProblemHolder h;
  build_problem(h, data, bins, out.params, o);
  ceres::Solver::Options so;
  so.minimizer_type = ceres::TRUST_REGION;
  so.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  so.linear_solver_type = ceres::DENSE_NORMAL_CHOLESKY;
  so.max_num_iterations = max_iterations;
  so.num_threads = thread_count(o.threads);
  so.function_tolerance = o.function_tolerance;
  so.parameter_tolerance = 1e-9;
  so.logging_type = ceres::SILENT;
  so.minimizer_progress_to_stdout = false;
  ceres::Solve(so, &h.problem, &out.summary);
  out.residual_blocks = h.residual_blocks;
  return out;
}

// The weight of (f - v) in the linear least-squares problems of the starts: the linear
// residual's weight, or for log residuals their linearisation (f - v) / (sigma v).
double linear_weight(const FitData& data, const FitBin& b, int c) {
  return data.linear ? b.linear_weight[c] : b.inv_sigma[c] / b.value[c];
}

struct GridStart {
  CtParams params;
  double cost = 0;
  std::string origin;
};

// Grid starts: every combination of N distinct roughnesses from a log-spaced list, r = 0.5,
// with kd and ks from NNLS on relative residuals (the linear part of the model).
std::vector<GridStart> grid_starts(const FitData& data, const std::vector<const FitBin*>& bins, const CtFitOptions& o) {
  const std::vector<double> grid = roughness_grid(o.m_min);
  const int G = static_cast<int>(grid.size());
  const int N = o.lobes;
  // Basis values: column 0 the diffuse 1/pi, column 1 + g the lobe of roughness grid[g].
  // Gram matrices per channel over the subsample with weights (inv_sigma / v)^2.
  std::array<Eigen::MatrixXd, 3> gram;
  std::array<Eigen::VectorXd, 3> rhs;
  for (int c = 0; c < 3; ++c) {
    gram[c] = Eigen::MatrixXd::Zero(G + 1, G + 1);
    rhs[c] = Eigen::VectorXd::Zero(G + 1);
  }
  Eigen::VectorXd phi(G + 1);
  for (const FitBin* b : bins) {
    phi[0] = std::numbers::inv_pi;
    for (int g = 0; g < G; ++g) {
      phi[1 + g] = 0.0;
      for (const FitMember* mb = members_begin(data, *b); mb != members_end(data, *b); ++mb)
        phi[1 + g] += mb->weight * brdf::ct_lobe(grid[g], 0.5, mb->geometry);
    }
    for (int c = 0; c < 3; ++c) {
      if (b->inv_sigma[c] == 0.0) continue;
      const double w = linear_weight(data, *b, c);
      const double w2 = w * w;
      gram[c].selfadjointView<Eigen::Lower>().rankUpdate(phi, w2);
      rhs[c] += w2 * b->value[c] * phi;
    }
  }
  for (int c = 0; c < 3; ++c) gram[c] = gram[c].selfadjointView<Eigen::Lower>();

  std::vector<GridStart> out;
  for_each_combination(G, N, [&](const std::vector<int>& pick) {
    GridStart s;
    s.params.lobes = N;
    std::vector<int> cols{0};
    for (int l = 0; l < N; ++l) cols.push_back(1 + pick[l]);
    double cost = 0;
    for (int c = 0; c < 3; ++c) {
      Eigen::MatrixXd A(N + 1, N + 1);
      Eigen::VectorXd bb(N + 1), x;
      for (int a = 0; a <= N; ++a) {
        bb[a] = rhs[c][cols[a]];
        for (int e = 0; e <= N; ++e) A(a, e) = gram[c](cols[a], cols[e]);
      }
      cost += nnls_small(A, bb, x);
      for (int a = 0; a <= N; ++a) s.params.lin[c][a] = x[a];
    }
    std::string ms;
    for (int l = 0; l < N; ++l) {
      s.params.nl[2 * l] = grid[pick[l]];
      s.params.nl[2 * l + 1] = 0.5;
      ms += fmt::format("{}{:g}", l ? "," : "", grid[pick[l]]);
    }
    s.cost = cost;
    s.origin = "grid m=" + ms;
    out.push_back(s);
  });
  std::sort(out.begin(), out.end(), [](const GridStart& a, const GridStart& b) { return a.cost < b.cost; });
  return out;
}

// Warm starts: the lobes of `warm` kept (m, r as fitted), each combination of the missing
// lobes' roughnesses from the grid added with r = 0.5, and kd and all ks re-solved by NNLS.
// Since ks = 0 for the new lobes is feasible, the best of them is never worse than `warm`.
std::vector<GridStart> warm_starts(const FitData& data, const std::vector<const FitBin*>& bins,
                                   const brdf::CookTorranceParams& warm, const CtFitOptions& o) {
  const std::vector<double> grid = roughness_grid(o.m_min);
  const int G = static_cast<int>(grid.size());
  const int W = static_cast<int>(warm.lobes.size());
  const int missing = o.lobes - W;
  // Columns: 1/pi, the W warm lobes, the G grid lobes.
  const int cols_total = 1 + W + G;
  std::array<Eigen::MatrixXd, 3> gram;
  std::array<Eigen::VectorXd, 3> rhs;
  for (int c = 0; c < 3; ++c) {
    gram[c] = Eigen::MatrixXd::Zero(cols_total, cols_total);
    rhs[c] = Eigen::VectorXd::Zero(cols_total);
  }
  Eigen::VectorXd phi(cols_total);
  for (const FitBin* b : bins) {
    phi.setZero();
    phi[0] = std::numbers::inv_pi;
    for (const FitMember* mb = members_begin(data, *b); mb != members_end(data, *b); ++mb) {
      for (int l = 0; l < W; ++l) phi[1 + l] += mb->weight * brdf::ct_lobe(warm.lobes[l].m, warm.lobes[l].r, mb->geometry);
      for (int g = 0; g < G; ++g) phi[1 + W + g] += mb->weight * brdf::ct_lobe(grid[g], 0.5, mb->geometry);
    }
    for (int c = 0; c < 3; ++c) {
      if (b->inv_sigma[c] == 0.0) continue;
      const double w = linear_weight(data, *b, c);
      gram[c].selfadjointView<Eigen::Lower>().rankUpdate(phi, w * w);
      rhs[c] += w * w * b->value[c] * phi;
    }
  }
  for (int c = 0; c < 3; ++c) gram[c] = gram[c].selfadjointView<Eigen::Lower>();
  std::vector<GridStart> out;
  auto add = [&](const std::vector<int>& pick) {
    std::vector<int> cols{0};
    std::vector<std::pair<double, double>> nl;  // (m, r) per lobe
    for (int l = 0; l < W; ++l) {
      cols.push_back(1 + l);
      nl.emplace_back(warm.lobes[l].m, warm.lobes[l].r);
    }
    std::string ms;
    for (int g : pick) {
      cols.push_back(1 + W + g);
      nl.emplace_back(grid[g], 0.5);
      ms += fmt::format("{}{:g}", ms.empty() ? "" : ",", grid[g]);
    }
    const int n = static_cast<int>(cols.size());
    GridStart s;
    s.params.lobes = o.lobes;
    double cost = 0;
    std::array<Eigen::VectorXd, 3> x;
    for (int c = 0; c < 3; ++c) {
      Eigen::MatrixXd A(n, n);
      Eigen::VectorXd bb(n);
      for (int a = 0; a < n; ++a) {
        bb[a] = rhs[c][cols[a]];
        for (int e = 0; e < n; ++e) A(a, e) = gram[c](cols[a], cols[e]);
      }
      cost += nnls_small(A, bb, x[c]);
    }
    // Lobes broadest first, as the fit keeps them.
    std::vector<int> order(static_cast<std::size_t>(o.lobes));
    for (int l = 0; l < o.lobes; ++l) order[l] = l;
    std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return nl[a].first > nl[b].first; });
    for (int c = 0; c < 3; ++c) {
      s.params.lin[c][0] = x[c][0];
      for (int l = 0; l < o.lobes; ++l) s.params.lin[c][1 + l] = x[c][1 + order[l]];
    }
    for (int l = 0; l < o.lobes; ++l) {
      s.params.nl[2 * l] = std::clamp(nl[order[l]].first, o.m_min, detail::kUnitHi);
      s.params.nl[2 * l + 1] = std::clamp(nl[order[l]].second, detail::kUnitLo, detail::kUnitHi);
    }
    s.cost = cost;
    s.origin = fmt::format("warm {} lobe{}{}", W, W == 1 ? "" : "s", ms.empty() ? "" : " + m=" + ms);
    out.push_back(s);
  };
  if (missing == 0)
    add({});
  else
    for_each_combination(G, missing, add);
  std::sort(out.begin(), out.end(), [](const GridStart& a, const GridStart& b) { return a.cost < b.cost; });
  return out;
}

// Keeps every channel's model positive where it has data: a small diffuse part.
void ensure_positive(CtParams& p, const std::vector<const FitBin*>& bins) {
  for (int c = 0; c < 3; ++c) {
    double mean = 0;
    int n = 0;
    for (const FitBin* b : bins)
      if (b->inv_sigma[c] != 0.0) {
        mean += b->value[c];
        ++n;
      }
    if (n > 0) p.lin[c][0] = std::max(p.lin[c][0], 1e-4 * std::numbers::pi * mean / n);
  }
}

std::string termination_text(const ceres::Solver::Summary& s) {
  return fmt::format("{}: {}", ceres::TerminationTypeToString(s.termination_type), s.message);
}

}  // namespace

void CtFitOptions::check() const {
  auto fail = [](const std::string& key, const std::string& value, const char* rule) {
    throw OptionError("CtFitOptions::" + key, value, rule);
  };
  check_shared("CtFitOptions");
  if (!(function_tolerance > 0.0 && function_tolerance < 1e-3))
    fail("function_tolerance", fmt::format("{}", function_tolerance), "in (0, 1e-3)");
  if (warm_start) {
    if (warm_start->lobes.empty() || static_cast<int>(warm_start->lobes.size()) > lobes)
      fail("warm_start", fmt::format("a fit of {} lobes", warm_start->lobes.size()), "1..lobes lobes");
    for (const brdf::CtLobe& l : warm_start->lobes)
      if (!(l.m > 0.0 && l.m < 1.0 && l.r > 0.0 && l.r < 1.0))
        fail("warm_start", fmt::format("a lobe with m = {}, r = {}", l.m, l.r), "m and r in (0, 1)");
  }
}

Json StartReport::to_json() const {
  return {{"origin", origin},
          {"initial_cost", initial_cost},
          {"final_cost", final_cost},
          {"iterations", iterations},
          {"converged", converged}};
}

Json FitSummary::to_json() const {
  Json s = Json::array();
  for (const StartReport& r : starts) s.push_back(r.to_json());
  return {{"converged", converged},
          {"termination", termination},
          {"iterations", iterations},
          {"initial_cost", initial_cost},
          {"final_cost", final_cost},
          {"residual_blocks", residual_blocks},
          {"residuals", residuals},
          {"parameters", parameters},
          {"chi2_per_dof", chi2_per_dof},
          {"time_s", time_s},
          {"seed", seed},
          {"residuals", residual_form},
          {"starts", s},
          {"covariance_ok", covariance_ok},
          {"covariance_message", covariance_message}};
}

Json CookTorranceStddev::to_json() const {
  Json lobes_json = Json::array();
  for (const brdf::CtLobe& l : lobes)
    lobes_json.push_back({{"ks", rgb_to_json(l.ks)}, {"m", number_or_null(l.m)}, {"r", number_or_null(l.r)}});
  return {{"kd", rgb_to_json(kd)}, {"lobes", lobes_json}};
}

Json CookTorranceFit::to_json(const std::string& name) const {
  Json j = brdf::to_json(brdf::PaintSpec{name, params, std::nullopt, {}});
  j["residual"] = residual.to_json();
  j["stddev"] = stddev.to_json();
  j["summary"] = summary.to_json();
  return j;
}

CookTorranceFit transform_colours(const CookTorranceFit& fit, const Eigen::Matrix3d& to, int* clipped) {
  CookTorranceFit out = fit;
  const Eigen::Matrix3d to2 = to.cwiseProduct(to);
  int n = 0;
  auto map = [&](const brdf::Rgb& v, const brdf::Rgb& sd, brdf::Rgb& v_out, brdf::Rgb& sd_out) {
    v_out = (to * v.matrix()).array();
    sd_out = (to2 * (sd * sd).matrix()).array().sqrt();
    for (int c = 0; c < 3; ++c)
      if (v_out[c] < 0.0) {
        v_out[c] = 0.0;
        ++n;
      }
  };
  map(fit.params.kd, fit.stddev.kd, out.params.kd, out.stddev.kd);
  for (std::size_t l = 0; l < fit.params.lobes.size(); ++l)
    map(fit.params.lobes[l].ks, fit.stddev.lobes[l].ks, out.params.lobes[l].ks, out.stddev.lobes[l].ks);
  if (clipped) *clipped = n;
  return out;
}

std::vector<double> evaluate_cook_torrance(const FitData& data, const brdf::CookTorranceParams& p) {
  return evaluate_bins(data, p.kd * std::numbers::inv_pi, [&](const FitMember& m) {
    brdf::Rgb f = brdf::Rgb::Zero();
    for (const brdf::CtLobe& l : p.lobes) f += l.ks * brdf::ct_lobe(l.m, l.r, m.geometry);
    return f;
  });
}

CookTorranceFit fit_cook_torrance(const FitData& data, const CtFitOptions& o) {
  o.check();
  const auto t0 = std::chrono::steady_clock::now();
  const int N = o.lobes;
  const std::size_t n_params = 3 * static_cast<std::size_t>(N + 1) + 2 * static_cast<std::size_t>(N);
  if (data.residuals <= n_params)
    throw DataError(fmt::format("{} measured values cannot determine the {} parameters of a {}-lobe Cook-Torrance fit",
                                data.residuals, n_params, N));

  std::vector<const FitBin*> all;
  all.reserve(data.bins.size());
  for (const FitBin& b : data.bins) all.push_back(&b);
  const std::vector<const FitBin*> sub = subsample(data, o.start_bins);

  // Starts.
  const std::clock_t cpu0 = std::clock();
  auto elapsed = [&] {
    return fmt::format("{:.2f} s, cpu {:.2f} s", std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(),
                       static_cast<double>(std::clock() - cpu0) / CLOCKS_PER_SEC);
  };
  std::vector<GridStart> candidates = grid_starts(data, sub, o);
  spdlog::debug("cook-torrance fit: {} grid starts on {} of {} bins in {}", candidates.size(), sub.size(),
                all.size(), elapsed());
  std::vector<GridStart> starts(candidates.begin(),
                                candidates.begin() + std::min<std::ptrdiff_t>(o.grid_starts, candidates.size()));
  if (o.warm_start) {
    const std::vector<GridStart> warm = warm_starts(data, sub, *o.warm_start, o);
    starts.insert(starts.end(), warm.begin(), warm.begin() + std::min<std::ptrdiff_t>(2, warm.size()));
  }
  std::mt19937_64 rng(o.seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  std::uniform_real_distribution<double> uni(0.05, 0.95);
  for (int s = 0; s < o.random_starts && !starts.empty(); ++s) {
    GridStart r = starts.front();
    for (int l = 0; l < N; ++l) {
      r.params.nl[2 * l] = std::clamp(r.params.nl[2 * l] * std::exp(0.4 * gauss(rng)), o.m_min, detail::kUnitHi);
      r.params.nl[2 * l + 1] = uni(rng);
    }
    r.origin = fmt::format("seed {} #{}", o.seed, s + 1);
    starts.push_back(r);
  }

  CookTorranceFit fit;
  fit.summary.seed = o.seed;
  fit.summary.residual_form = data.linear ? "linear" : "log";
  Solved best;
  double best_cost = std::numeric_limits<double>::infinity();
  for (GridStart& s : starts) {
    ensure_positive(s.params, sub);
    Solved r = solve(data, sub, s.params, o, std::max(10, o.max_iterations / 3));
    const StartReport rep = start_report(s.origin, r.summary);
    fit.summary.starts.push_back(rep);
    spdlog::debug("  start {}: cost {:.6g} -> {:.6g} in {} iterations ({})", rep.origin, rep.initial_cost,
                  rep.final_cost, rep.iterations, elapsed());
    if (r.summary.IsSolutionUsable() && r.summary.final_cost < best_cost) {
      best_cost = r.summary.final_cost;
      best = r;
    }
  }
  if (!std::isfinite(best_cost)) throw JobError("the Cook-Torrance fit failed from every start (no usable solution)");

  // Polish on all bins.
  Solved final_solve = solve(data, all, best.params, o, o.max_iterations);
  CtParams p = final_solve.params;
  spdlog::debug("  polish on all bins: {} iterations ({})", final_solve.summary.iterations.size() - 1, elapsed());
  FitSummary& sum = fit.summary;
  sum.converged = final_solve.summary.termination_type == ceres::CONVERGENCE;
  sum.termination = termination_text(final_solve.summary);
  sum.iterations = static_cast<int>(final_solve.summary.iterations.size()) - 1;
  sum.initial_cost = final_solve.summary.initial_cost;
  sum.final_cost = final_solve.summary.final_cost;
  sum.residual_blocks = final_solve.residual_blocks;
  sum.residuals = data.residuals;
  sum.parameters = n_params;
  sum.chi2_per_dof = 2.0 * sum.final_cost / std::max<double>(1.0, static_cast<double>(sum.residuals - n_params));

  // Standard deviations.
  CtParams sd;
  sd.lobes = N;
  for (auto& ch : sd.lin) ch.fill(std::numeric_limits<double>::quiet_NaN());
  sd.nl.fill(std::numeric_limits<double>::quiet_NaN());
  if (o.covariance) {
    const double scale = std::sqrt(std::max(1.0, sum.chi2_per_dof));
    CtParams at = p;
    ProblemHolder h;
    build_problem(h, data, all, at, o);
    std::vector<detail::CovarianceBlock> blocks(4);
    for (int c = 0; c < 3; ++c) {
      blocks[c].values = at.lin[c].data();
      blocks[c].size = N + 1;
      for (int k = 0; k <= N; ++k)
        if (at.lin[c][k] <= 1e-12) blocks[c].fixed.push_back(k);
    }
    blocks[3].values = at.nl.data();
    blocks[3].size = 2 * N;
    std::vector<bool> dead(N);
    for (int l = 0; l < N; ++l) {
      // A lobe without weight leaves its m and r undetermined.
      dead[l] = at.lin[0][1 + l] <= 1e-12 && at.lin[1][1 + l] <= 1e-12 && at.lin[2][1 + l] <= 1e-12;
      const double m = at.nl[2 * l], r = at.nl[2 * l + 1];
      if (dead[l] || detail::at_bound(m, o.m_min, detail::kUnitHi)) blocks[3].fixed.push_back(2 * l);
      if (dead[l] || detail::at_bound(r, detail::kUnitLo, detail::kUnitHi)) blocks[3].fixed.push_back(2 * l + 1);
    }
    sum.covariance_ok = detail::covariance_stddev(h.problem, h.ids, blocks, scale, sum.covariance_message);
    if (sum.covariance_ok) {
      for (int c = 0; c < 3; ++c)
        for (int k = 0; k <= N; ++k) sd.lin[c][k] = blocks[c].stddev[k];
      for (int k = 0; k < 2 * N; ++k) sd.nl[k] = blocks[3].stddev[k];
      for (int l = 0; l < N; ++l)
        if (dead[l]) sd.nl[2 * l] = sd.nl[2 * l + 1] = std::numeric_limits<double>::quiet_NaN();
    }
  } else {
    sum.covariance_message = "not computed";
  }
  spdlog::debug("  covariance: {} ({})", sum.covariance_message, elapsed());
  // Lobes broadest first, standard deviations along.
  brdf::CookTorranceParams params = p.to_params();
  brdf::CookTorranceParams sdp = sd.to_params();
  std::vector<int> order(N);
  for (int l = 0; l < N; ++l) order[l] = l;
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return params.lobes[a].m > params.lobes[b].m; });
  fit.params.kd = params.kd;
  fit.stddev.kd = sdp.kd;
  for (int l : order) {
    fit.params.lobes.push_back(params.lobes[l]);
    fit.stddev.lobes.push_back(sdp.lobes[l]);
  }
  fit.residual = residual_report(data, evaluate_cook_torrance(data, fit.params));
  sum.time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return fit;
}

}  // namespace paintlab::fit
