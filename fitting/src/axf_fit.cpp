#include "paintlab/fitting/axf_fit.h"

#include <ceres/ceres.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <fmt/format.h>
#include <limits>
#include <numbers>
#include <random>

#include "fit_solver.h"
#include "paintlab/fitting/cost_functions.h"
#include "fit_util.h"
#include "paintlab/brdf/cook_torrance.h"
#include "paintlab/brdf/paint.h"
#include "paintlab/brdf/rusinkiewicz.h"
#include "paintlab/core/error.h"
#include "paintlab/core/log.h"

namespace paintlab::fit {

namespace {

constexpr double kAxfHalfPi = std::numbers::pi / 2.0;
constexpr int kMaxAxfLobes = 3;

// Parameters in two blocks: (eta, a, then per lobe s, alpha) and the lobes' F0 (held
// fixed unless AxfFitOptions::fit_f0).
struct AxfVector {
  std::array<double, 2 + 2 * kMaxAxfLobes> main{};
  std::array<double, kMaxAxfLobes> f0{};
  double& eta() { return main[0]; }
  double eta() const { return main[0]; }
  double& a() { return main[1]; }
  double a() const { return main[1]; }
  double& s(int k) { return main[2 + 2 * k]; }
  double s(int k) const { return main[2 + 2 * k]; }
  double& alpha(int k) { return main[3 + 2 * k]; }
  double alpha(int k) const { return main[3 + 2 * k]; }
};

// The achromatic model at one member bin in doubles (for starts, chi and reports).
double achromatic(const AxfVector& p, int K, const AchromaticMember& m, brdf::CoatGeometry<double>* geometry = nullptr) {
  const brdf::CoatGeometry<double> g = brdf::coat_geometry<double>(p.eta(), m.wi, m.wo);
  if (geometry) *geometry = g;
  double f = p.a() * std::numbers::inv_pi;
  for (int k = 0; k < K; ++k)
    f += p.s(k) *
         brdf::ct_lobe<double>(p.alpha(k), p.f0[k], g.n_dot_hbar, g.hbar_dot_obar, g.n_dot_ibar, g.n_dot_obar);
  return f * g.transmittance;
}
// ... averaged over a fit point's members.
double achromatic(const AxfVector& p, int K, const AchromaticBin& b) {
  double f = 0;
  for (std::uint32_t mi = 0; mi < b.member_count; ++mi) f += b.members[mi].weight * achromatic(p, K, b.members[mi]);
  return f;
}

struct Problem {
  ceres::Problem problem;
  std::vector<ceres::ResidualBlockId> ids;
  std::vector<std::vector<const AchromaticBin*>> chunks;  // owned here, referenced by the functors
};

void build(Problem& pr, const std::vector<const AchromaticBin*>& bins, AxfVector& v, int K, const AxfFitOptions& o) {
  double* p = v.main.data();
  double* f0 = v.f0.data();
  const std::size_t chunk = static_cast<std::size_t>(o.chunk_bins);
  pr.chunks.reserve((bins.size() + chunk - 1) / chunk);
  for (std::size_t s = 0; s < bins.size(); s += chunk)
    pr.chunks.emplace_back(bins.begin() + static_cast<std::ptrdiff_t>(s),
                           bins.begin() + static_cast<std::ptrdiff_t>(std::min(bins.size(), s + chunk)));
  for (const auto& c : pr.chunks) {
    ceres::CostFunction* cost = K == 1   ? AxfAchromaticCost<1>::Create(&c)
                                 : K == 2 ? AxfAchromaticCost<2>::Create(&c)
                                          : AxfAchromaticCost<3>::Create(&c);
    ceres::LossFunction* loss = o.huber_scale > 0.0 ? new ceres::HuberLoss(o.huber_scale) : nullptr;
    pr.ids.push_back(pr.problem.AddResidualBlock(cost, loss, p, f0));
  }
  pr.problem.SetParameterLowerBound(p, 0, o.ior_min);
  pr.problem.SetParameterUpperBound(p, 0, o.ior_max);
  pr.problem.SetParameterLowerBound(p, 1, 0.0);
  for (int k = 0; k < K; ++k) {
    pr.problem.SetParameterLowerBound(p, 2 + 2 * k, 0.0);
    pr.problem.SetParameterLowerBound(p, 3 + 2 * k, o.m_min);
    pr.problem.SetParameterUpperBound(p, 3 + 2 * k, detail::kUnitHi);
    pr.problem.SetParameterLowerBound(f0, k, detail::kUnitLo);
    pr.problem.SetParameterUpperBound(f0, k, detail::kUnitHi);
  }
  if (!o.fit_f0) pr.problem.SetParameterBlockConstant(f0);
}

struct AxfSolved {
  AxfVector p{};
  ceres::Solver::Summary summary;
  std::size_t blocks = 0;
};

AxfSolved solve_axf(const std::vector<const AchromaticBin*>& bins, const AxfVector& start, int K, const AxfFitOptions& o,
             int max_iterations) {
  AxfSolved out;
  out.p = start;
  Problem pr;
  build(pr, bins, out.p, K, o);
  ceres::Solver::Options so;
  so.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  so.linear_solver_type = ceres::DENSE_NORMAL_CHOLESKY;
  so.max_num_iterations = max_iterations;
  so.num_threads = detail::thread_count(o.threads);
  so.function_tolerance = 1e-8;
  so.parameter_tolerance = 1e-9;
  so.logging_type = ceres::SILENT;
  ceres::Solve(so, &pr.problem, &out.summary);
  out.blocks = pr.ids.size();
  return out;
}

struct Start {
  AxfVector p{};
  double cost = 0;
  std::string origin;
};

// Grid over the spreads at eta = ior_start and F0 = 0.5; a and s by NNLS on relative
// residuals.
std::vector<Start> grid_starts(const std::vector<const AchromaticBin*>& bins, int K, const AxfFitOptions& o) {
  const std::vector<double> grid = detail::roughness_grid(o.m_min);
  const int G = static_cast<int>(grid.size());
  Eigen::MatrixXd gram = Eigen::MatrixXd::Zero(G + 1, G + 1);
  Eigen::VectorXd rhs = Eigen::VectorXd::Zero(G + 1), phi(G + 1);
  for (const AchromaticBin* b : bins) {
    phi.setZero();
    for (std::uint32_t mi = 0; mi < b->member_count; ++mi) {
      const AchromaticMember& m = b->members[mi];
      const brdf::CoatGeometry<double> g = brdf::coat_geometry<double>(o.ior_start, m.wi, m.wo);
      phi[0] += m.weight * g.transmittance * std::numbers::inv_pi;
      for (int k = 0; k < G; ++k)
        phi[1 + k] += m.weight * g.transmittance *
                      brdf::ct_lobe<double>(grid[k], o.f0, g.n_dot_hbar, g.hbar_dot_obar, g.n_dot_ibar, g.n_dot_obar);
    }
    const double w = b->inv_sigma / b->value;
    gram.selfadjointView<Eigen::Lower>().rankUpdate(phi, w * w);
    rhs += w * w * b->value * phi;
  }
  gram = Eigen::MatrixXd(gram.selfadjointView<Eigen::Lower>());
  std::vector<Start> out;
  detail::for_each_combination(G, K, [&](const std::vector<int>& pick) {
    std::vector<int> cols{0};
    for (int k : pick) cols.push_back(1 + k);
    Eigen::MatrixXd a(K + 1, K + 1);
    Eigen::VectorXd bb(K + 1), x;
    for (int i = 0; i <= K; ++i) {
      bb[i] = rhs[cols[i]];
      for (int j = 0; j <= K; ++j) a(i, j) = gram(cols[i], cols[j]);
    }
    Start s;
    s.cost = detail::nnls_small(a, bb, x);
    s.p.eta() = o.ior_start;
    s.p.a() = x[0];
    std::string ms;
    for (int k = 0; k < K; ++k) {
      s.p.s(k) = x[1 + k];
      s.p.alpha(k) = grid[pick[k]];
      s.p.f0[k] = o.f0;
      ms += fmt::format("{}{:g}", k ? "," : "", grid[pick[k]]);
    }
    s.origin = "grid spread=" + ms;
    out.push_back(s);
  });
  std::sort(out.begin(), out.end(), [](const Start& a, const Start& b) { return a.cost < b.cost; });
  return out;
}

// Normalised Gaussian convolution of (sum of w*ratio, sum of w) on the nh x ni grid.
void convolve(const std::vector<std::array<double, 3>>& num, const std::vector<std::array<double, 3>>& den, int nh,
              int ni, double sigma, std::vector<std::array<double, 3>>& out_num,
              std::vector<std::array<double, 3>>& out_den) {
  const int radius = std::max(1, static_cast<int>(std::ceil(3.0 * sigma)));
  std::vector<double> kernel(static_cast<std::size_t>(2 * radius + 1));
  for (int d = -radius; d <= radius; ++d) kernel[static_cast<std::size_t>(d + radius)] = std::exp(-0.5 * d * d / (sigma * sigma));
  out_num.assign(num.size(), {0, 0, 0});
  out_den.assign(num.size(), {0, 0, 0});
  for (int a = 0; a < nh; ++a)
    for (int b = 0; b < ni; ++b) {
      std::array<double, 3> sn{0, 0, 0}, sd{0, 0, 0};
      for (int da = -radius; da <= radius; ++da) {
        const int x = a + da;
        if (x < 0 || x >= nh) continue;
        for (int db = -radius; db <= radius; ++db) {
          const int y = b + db;
          if (y < 0 || y >= ni) continue;
          const double k = kernel[static_cast<std::size_t>(da + radius)] * kernel[static_cast<std::size_t>(db + radius)];
          const std::size_t t = static_cast<std::size_t>(x * ni + y);
          for (int c = 0; c < 3; ++c) {
            sn[c] += k * num[t][c];
            sd[c] += k * den[t][c];
          }
        }
      }
      out_num[static_cast<std::size_t>(a * ni + b)] = sn;
      out_den[static_cast<std::size_t>(a * ni + b)] = sd;
    }
}

}  // namespace

void AxfFitOptions::check() const {
  auto fail = [](const std::string& key, const std::string& value, const char* rule) {
    throw OptionError("AxfFitOptions::" + key, value, rule);
  };
  check_shared("AxfFitOptions");
  if (!(ior_min >= 1.0 && ior_min < ior_max && ior_max <= 3.0))
    fail("ior_min/ior_max", fmt::format("{}/{}", ior_min, ior_max), "1 <= ior_min < ior_max <= 3");
  if (!(ior_start >= ior_min && ior_start <= ior_max))
    fail("ior_start", fmt::format("{}", ior_start), "in [ior_min, ior_max]");
  if (!(f0 > 0.0 && f0 < 1.0)) fail("f0", fmt::format("{}", f0), "in (0, 1)");
  if (chi_theta_h < 2 || chi_theta_h > 1024) fail("chi_theta_h", std::to_string(chi_theta_h), "2..1024");
  if (chi_theta_i < 2 || chi_theta_i > 1024) fail("chi_theta_i", std::to_string(chi_theta_i), "2..1024");
  if (!(chi_smoothing_texels > 0.0)) fail("chi_smoothing_texels", fmt::format("{}", chi_smoothing_texels), "> 0");
}

Json AxfStddev::to_json() const {
  Json lobes_json = Json::array();
  for (const brdf::AxfLobe& l : lobes)
    lobes_json.push_back({{"coefficient", number_or_null(l.coefficient)},
                          {"spread", number_or_null(l.spread)},
                          {"f0", number_or_null(l.f0)}});
  return {{"ior", number_or_null(ior)}, {"diffuse", number_or_null(diffuse)}, {"lobes", lobes_json}};
}

Json ChiReport::to_json() const { return {{"measured_texels", measured_texels}, {"filled_texels", filled_texels}}; }

Json AxfFit::to_json(const std::string& name) const {
  Json j = brdf::to_json(brdf::PaintSpec{name, params, std::nullopt, {}});
  j["residual"] = residual.to_json();
  j["achromatic_residual"] = achromatic.to_json();
  j["stddev"] = stddev.to_json();
  j["chi_table"] = chi.to_json();
  j["summary"] = summary.to_json();
  return j;
}

std::vector<double> evaluate_axf_carpaint(const FitData& data, const brdf::AxfCarPaintParams& params) {
  const brdf::AxfCarPaint model(params);
  return evaluate_bins(data, brdf::Rgb::Zero(), [&](const FitMember& m) -> brdf::Rgb {
    const brdf::DirectionPair d = brdf::directions_from_half_diff({m.coords[0], 0.0, m.coords[1], m.coords[2]});
    return model.eval(d.wi, d.wo);
  });
}

AxfFit fit_axf_carpaint(const FitData& data, const AxfFitOptions& o) {
  o.check();
  const auto t0 = std::chrono::steady_clock::now();
  const int K = o.lobes;
  const std::size_t n_params = 2 + static_cast<std::size_t>(o.fit_f0 ? 3 : 2) * static_cast<std::size_t>(K);

  // Stage 1 data: bins with all three channels positive.
  std::vector<AchromaticMember> achro_members(data.members.size());
  for (std::size_t i = 0; i < data.members.size(); ++i) {
    const Eigen::Vector3d& c = data.members[i].coords;
    const brdf::DirectionPair d = brdf::directions_from_half_diff({c[0], 0.0, c[1], c[2]});
    achro_members[i] = {d.wi, d.wo, data.members[i].weight};
  }
  std::vector<AchromaticBin> achro;
  achro.reserve(data.bins.size());
  const double floor2 = data.options.relative_floor * data.options.relative_floor;
  for (const FitBin& b : data.bins) {
    if (b.inv_sigma[0] == 0.0 || b.inv_sigma[1] == 0.0 || b.inv_sigma[2] == 0.0) continue;
    AchromaticBin a;
    a.src = &b;
    a.members = achro_members.data() + b.member_begin;
    a.member_count = b.member_count;
    bool above = true;
    for (std::uint32_t mi = 0; mi < a.member_count; ++mi)
      above = above && a.members[mi].wi.z() > 0.0 && a.members[mi].wo.z() > 0.0;
    if (!above) continue;
    a.value = (b.value[0] + b.value[1] + b.value[2]) / 3.0;
    // The channels' log noise, taken as fully correlated (a monochrome camera's are).
    const double s2 = (b.noise_sigma[0] * b.noise_sigma[0] + b.noise_sigma[1] * b.noise_sigma[1] +
                       b.noise_sigma[2] * b.noise_sigma[2]) / 3.0;
    a.noise = std::sqrt(s2);
    // The delta correction as the Cook-Torrance fit's (fit_data.h t2: the samples' spread
    // outside the peak, the flakes' glints included).
    const double t2 = (b.bias_variance[0] + b.bias_variance[1] + b.bias_variance[2]) / 3.0;
    a.target = std::log(a.value) + (data.options.delta_correction ? 0.5 * t2 : 0.0);
    a.inv_sigma = 1.0 / std::sqrt(s2 + floor2);
    achro.push_back(a);
  }
  if (achro.size() <= n_params)
    throw DataError(fmt::format("{} bins with all three channels measured cannot determine the {} parameters of an "
                                "AxF car-paint fit with {} lobes",
                                achro.size(), n_params, K));
  std::vector<const AchromaticBin*> all;
  for (const AchromaticBin& a : achro) all.push_back(&a);
  // Subsample through the FitBins' hash (peak bins favoured).
  std::vector<const AchromaticBin*> sub;
  {
    const std::vector<const FitBin*> picked = detail::subsample(data, o.start_bins);
    std::vector<char> keep(data.bins.size(), 0);
    for (const FitBin* b : picked) keep[static_cast<std::size_t>(b - data.bins.data())] = 1;
    for (const AchromaticBin* a : all)
      if (keep[static_cast<std::size_t>(a->src - data.bins.data())]) sub.push_back(a);
    if (sub.size() <= n_params) sub = all;
  }

  std::vector<Start> starts;
  {
    std::vector<Start> grid = grid_starts(sub, K, o);
    for (int i = 0; i < o.grid_starts && i < static_cast<int>(grid.size()); ++i) starts.push_back(grid[i]);
  }
  std::mt19937_64 rng(o.seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  std::uniform_real_distribution<double> uni(0.05, 0.95), uni_ior(1.3, 1.7);
  for (int s = 0; s < o.random_starts && !starts.empty(); ++s) {
    Start r = starts.front();
    r.p.eta() = std::clamp(uni_ior(rng), o.ior_min, o.ior_max);
    for (int k = 0; k < K; ++k) {
      r.p.alpha(k) = std::clamp(r.p.alpha(k) * std::exp(0.4 * gauss(rng)), o.m_min, detail::kUnitHi);
      if (o.fit_f0) r.p.f0[k] = uni(rng);
    }
    r.origin = fmt::format("seed {} #{}", o.seed, s + 1);
    starts.push_back(r);
  }

  AxfFit fit;
  FitSummary& sum = fit.summary;
  sum.seed = o.seed;
  double mean_value = 0;
  for (const AchromaticBin* a : sub) mean_value += a->value;
  mean_value /= static_cast<double>(sub.size());
  AxfSolved best;
  double best_cost = std::numeric_limits<double>::infinity();
  for (Start& s : starts) {
    s.p.a() = std::max(s.p.a(), 1e-4 * std::numbers::pi * mean_value);  // a positive model everywhere
    AxfSolved r = solve_axf(sub, s.p, K, o, std::max(10, o.max_iterations / 3));
    const StartReport rep = detail::start_report(s.origin, r.summary);
    sum.starts.push_back(rep);
    spdlog::debug("axf fit start {}: cost {:.6g} -> {:.6g} in {} iterations", rep.origin, rep.initial_cost,
                  rep.final_cost, rep.iterations);
    if (r.summary.IsSolutionUsable() && r.summary.final_cost < best_cost) {
      best_cost = r.summary.final_cost;
      best = r;
    }
  }
  if (!std::isfinite(best_cost)) throw JobError("the AxF car-paint fit failed from every start (no usable solution)");

  AxfSolved final_solve = solve_axf(all, best.p, K, o, o.max_iterations);
  const AxfVector p = final_solve.p;
  sum.converged = final_solve.summary.termination_type == ceres::CONVERGENCE;
  sum.termination = fmt::format("{}: {}", ceres::TerminationTypeToString(final_solve.summary.termination_type),
                                final_solve.summary.message);
  sum.iterations = static_cast<int>(final_solve.summary.iterations.size()) - 1;
  sum.initial_cost = final_solve.summary.initial_cost;
  sum.final_cost = final_solve.summary.final_cost;
  sum.residual_blocks = final_solve.blocks;
  sum.residuals = all.size();
  sum.parameters = n_params;
  sum.chi2_per_dof = 2.0 * sum.final_cost / std::max<double>(1.0, static_cast<double>(all.size() - n_params));

  // Standard deviations.
  AxfVector sd;
  sd.main.fill(std::numeric_limits<double>::quiet_NaN());
  sd.f0.fill(std::numeric_limits<double>::quiet_NaN());
  if (o.covariance) {
    AxfVector at = p;
    Problem pr;
    build(pr, all, at, K, o);
    std::vector<detail::CovarianceBlock> blocks(2);
    blocks[0].values = at.main.data();
    blocks[0].size = 2 + 2 * K;
    blocks[1].values = at.f0.data();
    blocks[1].size = K;
    std::vector<int>& fixed = blocks[0].fixed;
    if (detail::at_bound(at.eta(), o.ior_min, o.ior_max)) fixed.push_back(0);
    if (at.a() <= 1e-12) fixed.push_back(1);
    std::vector<bool> dead(static_cast<std::size_t>(K));
    for (int k = 0; k < K; ++k) {
      dead[k] = at.s(k) <= 1e-12;
      if (dead[k]) fixed.push_back(2 + 2 * k);
      if (dead[k] || detail::at_bound(at.alpha(k), o.m_min, detail::kUnitHi)) fixed.push_back(3 + 2 * k);
      if (!o.fit_f0 || dead[k] || detail::at_bound(at.f0[k], detail::kUnitLo, detail::kUnitHi))
        blocks[1].fixed.push_back(k);
    }
    const double scale = std::sqrt(std::max(1.0, sum.chi2_per_dof));
    sum.covariance_ok = detail::covariance_stddev(pr.problem, pr.ids, blocks, scale, sum.covariance_message);
    if (sum.covariance_ok) {
      for (int i = 0; i < 2 + 2 * K; ++i) sd.main[i] = blocks[0].stddev[i];
      for (int k = 0; k < K; ++k) sd.f0[k] = blocks[1].stddev[k];
      for (int k = 0; k < K; ++k)
        if (dead[k]) sd.alpha(k) = sd.f0[k] = std::numeric_limits<double>::quiet_NaN();
    }
  } else {
    sum.covariance_message = "not computed";
  }

  // Parameters, lobes broadest first.
  brdf::AxfCarPaintParams& out = fit.params;
  out.ior = p.eta();
  out.diffuse = p.a();
  fit.stddev.ior = sd.eta();
  fit.stddev.diffuse = sd.a();
  std::vector<int> order(static_cast<std::size_t>(K));
  for (int k = 0; k < K; ++k) order[k] = k;
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return p.alpha(a) > p.alpha(b); });
  for (int k : order) {
    out.lobes.push_back({p.s(k), p.alpha(k), p.f0[k]});
    fit.stddev.lobes.push_back({sd.s(k), sd.alpha(k), sd.f0[k]});
  }

  // Stage 2: the colour table.
  const int nh = o.chi_theta_h, ni = o.chi_theta_i;
  const std::size_t texels = static_cast<std::size_t>(nh) * static_cast<std::size_t>(ni);
  std::vector<std::array<double, 3>> num(texels, {0, 0, 0}), den(texels, {0, 0, 0});
  std::vector<double> achro_model(achro.size());
  for (std::size_t q = 0; q < achro.size(); ++q) {
    const AchromaticBin& a = achro[q];
    const double model = achromatic(p, K, a);
    achro_model[q] = model;
    if (!(model > kMinAxfModelValue)) continue;
    // The point's colour ratio, splatted at each member bin's (theta_hbar, theta_ibar).
    for (std::uint32_t mi = 0; mi < a.member_count; ++mi) {
      const AchromaticMember& m = a.members[mi];
      brdf::CoatGeometry<double> g;
      achromatic(p, K, m, &g);
      const double th = std::acos(std::clamp(g.n_dot_hbar, -1.0, 1.0));
      const double ti = std::acos(std::clamp(g.hbar_dot_obar, -1.0, 1.0));
      const double x = std::clamp(th / kAxfHalfPi * nh - 0.5, 0.0, nh - 1.0);
      const double y = std::clamp(ti / kAxfHalfPi * ni - 0.5, 0.0, ni - 1.0);
      const int x0 = std::min(static_cast<int>(x), nh - 2), y0 = std::min(static_cast<int>(y), ni - 2);
      const double fx = x - x0, fy = y - y0;
      for (int dx = 0; dx < 2; ++dx)
        for (int dy = 0; dy < 2; ++dy) {
          const double w = m.weight * (dx ? fx : 1 - fx) * (dy ? fy : 1 - fy);
          if (w <= 0.0) continue;
          const std::size_t t = static_cast<std::size_t>((x0 + dx) * ni + (y0 + dy));
          for (int c = 0; c < 3; ++c) {
            const double wc = w * a.src->inv_sigma[c] * a.src->inv_sigma[c];
            num[t][c] += wc * a.src->value[c] / model;
            den[t][c] += wc;
          }
        }
    }
  }
  std::vector<char> measured(texels, 0);
  for (std::size_t t = 0; t < texels; ++t) measured[t] = den[t][0] > 0.0 && den[t][1] > 0.0 && den[t][2] > 0.0;
  brdf::ColourTable& chi = out.chi;
  chi.theta_h_samples = nh;
  chi.theta_i_samples = ni;
  chi.scale = 1.0;
  chi.rgb.assign(texels, brdf::Rgb::Ones());
  std::vector<char> done(texels, 0);
  std::vector<std::array<double, 3>> cn, cd;
  // A texel is set from the first (smallest) kernel that reaches enough weight: 1 % of the
  // typical weight of a measured texel.
  double typical = 0;
  int n_meas = 0;
  for (std::size_t t = 0; t < texels; ++t)
    if (measured[t]) {
      typical += den[t][0];
      ++n_meas;
    }
  if (n_meas == 0) throw DataError("no measured bin falls into the AxF colour table");
  typical /= n_meas;
  std::size_t remaining = texels;
  for (double sigma = o.chi_smoothing_texels; remaining > 0; sigma *= 2.0) {
    convolve(num, den, nh, ni, sigma, cn, cd);
    for (std::size_t t = 0; t < texels; ++t) {
      if (done[t]) continue;
      if (!(cd[t][0] > 1e-2 * typical && cd[t][1] > 1e-2 * typical && cd[t][2] > 1e-2 * typical) &&
          sigma < 4.0 * std::max(nh, ni))
        continue;
      for (int c = 0; c < 3; ++c) chi.rgb[t][c] = cd[t][c] > 0.0 ? cn[t][c] / cd[t][c] : 1.0;
      done[t] = 1;
      --remaining;
      if (measured[t])
        ++fit.chi.measured_texels;
      else
        ++fit.chi.filled_texels;
    }
  }

  // Residuals: stage 1 against the channel mean, the whole model against R, G, B.
  {
    FitData achro_data;
    achro_data.has_statistics = data.has_statistics;
    achro_data.noise_source = data.noise_source;
    achro_data.options = data.options;
    std::vector<double> model;
    for (std::size_t q = 0; q < achro.size(); ++q) {
      FitBin b = *achro[q].src;
      for (int c = 0; c < 3; ++c) {
        b.value[c] = achro[q].value;
        b.noise_sigma[c] = achro[q].noise;
        b.inv_sigma[c] = c == 0 ? achro[q].inv_sigma : 0.0;  // one value per bin
        model.push_back(achro_model[q]);
      }
      achro_data.bins.push_back(b);
    }
    achro_data.residuals = achro.size();
    fit.achromatic = residual_report(achro_data, model);
  }
  fit.residual = residual_report(data, evaluate_axf_carpaint(data, out));
  sum.time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return fit;
}

}  // namespace paintlab::fit
