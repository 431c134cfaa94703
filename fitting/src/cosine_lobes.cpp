#include "paintlab/fitting/cosine_lobes.h"

#include <Eigen/Cholesky>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <fmt/format.h>
#include <lemon/lp.h>
#include <limits>
#include <numbers>
#include <numeric>

#include "paintlab/core/config.h"
#include "paintlab/core/error.h"

namespace paintlab::fit {
namespace fs = std::filesystem;

namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kDeg = kPi / 180.0;

// A unit vector at angle `alpha` from `axis`, turned by `beta` about it.
brdf::Vec3 around(const brdf::Vec3& axis, double alpha, double beta) {
  const brdf::Vec3 helper = std::abs(axis.z()) < 0.9 ? brdf::Vec3::UnitZ() : brdf::Vec3::UnitX();
  const brdf::Vec3 u = axis.cross(helper).normalized();
  const brdf::Vec3 v = axis.cross(u);
  return (std::cos(alpha) * axis + std::sin(alpha) * (std::cos(beta) * u + std::sin(beta) * v)).normalized();
}

// The paint's values at the geometries, one column per channel.
Eigen::MatrixXd paint_values(const brdf::Brdf& paint, const std::vector<DirectionPair>& at) {
  Eigen::MatrixXd f(static_cast<Eigen::Index>(at.size()), 3);
  for (std::size_t s = 0; s < at.size(); ++s) {
    const brdf::Rgb v = paint.eval(at[s].wi, at[s].wo);
    for (int c = 0; c < 3; ++c) f(static_cast<Eigen::Index>(s), c) = v[c];
  }
  return f;
}

brdf::CosineLobeParams params_from(const std::vector<double>& exponents, const std::array<Eigen::VectorXd, 3>& x) {
  const std::size_t n = exponents.size();
  brdf::CosineLobeParams p;
  p.exponents = exponents;
  p.kd = brdf::Rgb(x[0][0], x[1][0], x[2][0]);  // the kd column is 1/pi: its weight is the albedo
  p.kg.assign(n, brdf::Rgb::Zero());
  p.kdd.assign(n, brdf::Rgb::Zero());
  for (std::size_t i = 0; i < n; ++i)
    for (int c = 0; c < 3; ++c) {
      p.kg[i][c] = x[static_cast<std::size_t>(c)][static_cast<Eigen::Index>(1 + i)];
      p.kdd[i][c] = x[static_cast<std::size_t>(c)][static_cast<Eigen::Index>(1 + n + i)];
    }
  return p;
}

// Relative errors of the fit `x` (per channel) against the paint's values `f`.
void relative_errors(const Eigen::MatrixXd& A, const Eigen::MatrixXd& f, const std::array<Eigen::VectorXd, 3>& x,
                     double* mean, double* max) {
  double sum = 0, worst = 0;
  for (int c = 0; c < 3; ++c) {
    const Eigen::VectorXd e =
        ((A * x[static_cast<std::size_t>(c)] - f.col(c)).array().abs() / (f.col(c).array() + kCosineErrorFloor)).matrix();
    sum += e.sum();
    worst = std::max(worst, e.maxCoeff());
  }
  *mean = sum / (3.0 * static_cast<double>(f.rows()));
  *max = worst;
}

// The fit of one paint's values (relative errors) with columns A: weights per channel.
std::array<Eigen::VectorXd, 3> fit_values(const Eigen::MatrixXd& A, const Eigen::MatrixXd& f, LobeNorm norm) {
  std::array<Eigen::VectorXd, 3> x;
  for (int c = 0; c < 3; ++c) {
    const Eigen::VectorXd w = (f.col(c).array() + kCosineErrorFloor).inverse().matrix();
    const Eigen::MatrixXd Aw = w.asDiagonal() * A;
    const Eigen::VectorXd bw = w.cwiseProduct(f.col(c));
    x[static_cast<std::size_t>(c)] = norm == LobeNorm::L1 ? nonnegative_l1(Aw, bw) : nnls(Aw, bw);
  }
  return x;
}

std::vector<double> sorted_exponents(const Eigen::VectorXd& log_e) {
  std::vector<double> e(static_cast<std::size_t>(log_e.size()));
  for (Eigen::Index i = 0; i < log_e.size(); ++i)
    e[static_cast<std::size_t>(i)] =
        std::clamp(std::exp(log_e[i]), brdf::kMinLobeExponent, brdf::kMaxLobeExponent);
  std::sort(e.begin(), e.end());
  // Equal exponents are one lobe twice: part them so the set stays strictly increasing, within
  // [kMinLobeExponent, kMaxLobeExponent] (each kept room for the ones below and above it).
  const std::size_t n = e.size();
  for (std::size_t i = 0; i < n; ++i) {
    const double lo = brdf::kMinLobeExponent * std::pow(1.0001, static_cast<double>(i));
    const double hi = brdf::kMaxLobeExponent / std::pow(1.0001, static_cast<double>(n - 1 - i));
    e[i] = std::clamp(e[i], lo, hi);
    if (i > 0) e[i] = std::max(e[i], e[i - 1] * 1.0001);
  }
  return e;
}

// Nelder-Mead (the standard coefficients 1, 2, 0.5, 0.5) from `x0` with initial steps `step`.
Eigen::VectorXd nelder_mead(const std::function<double(const Eigen::VectorXd&)>& f, const Eigen::VectorXd& x0,
                            double step, int max_evaluations, int* evaluations, double* best) {
  const Eigen::Index n = x0.size();
  std::vector<Eigen::VectorXd> x(static_cast<std::size_t>(n + 1), x0);
  std::vector<double> y(static_cast<std::size_t>(n + 1));
  int evals = 0;
  auto eval = [&](const Eigen::VectorXd& p) {
    ++evals;
    return f(p);
  };
  for (Eigen::Index i = 0; i < n; ++i) x[static_cast<std::size_t>(i + 1)][i] += step;
  for (std::size_t i = 0; i < x.size(); ++i) y[i] = eval(x[i]);
  std::vector<std::size_t> order(x.size());
  while (evals < max_evaluations) {
    std::iota(order.begin(), order.end(), 0);
    std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return y[a] < y[b]; });
    const std::size_t lo = order.front(), hi = order.back(), second = order[order.size() - 2];
    if (y[hi] - y[lo] <= 1e-5 * (std::abs(y[lo]) + 1e-12)) break;
    Eigen::VectorXd centroid = Eigen::VectorXd::Zero(n);
    for (std::size_t i = 0; i < x.size(); ++i)
      if (i != hi) centroid += x[i];
    centroid /= static_cast<double>(n);
    const Eigen::VectorXd xr = centroid + (centroid - x[hi]);
    const double yr = eval(xr);
    if (yr < y[lo]) {
      const Eigen::VectorXd xe = centroid + 2.0 * (centroid - x[hi]);
      const double ye = eval(xe);
      if (ye < yr) x[hi] = xe, y[hi] = ye;
      else x[hi] = xr, y[hi] = yr;
    } else if (yr < y[second]) {
      x[hi] = xr, y[hi] = yr;
    } else {
      const bool outside = yr < y[hi];
      const Eigen::VectorXd xc = outside ? Eigen::VectorXd(centroid + 0.5 * (xr - centroid))
                                         : Eigen::VectorXd(centroid + 0.5 * (x[hi] - centroid));
      const double yc = eval(xc);
      if (yc < (outside ? yr : y[hi])) {
        x[hi] = xc, y[hi] = yc;
      } else {  // shrink towards the best
        for (std::size_t i = 0; i < x.size(); ++i) {
          if (i == lo) continue;
          x[i] = x[lo] + 0.5 * (x[i] - x[lo]);
          y[i] = eval(x[i]);
        }
      }
    }
  }
  const std::size_t b = static_cast<std::size_t>(std::min_element(y.begin(), y.end()) - y.begin());
  *evaluations = evals;
  *best = y[b];
  return x[b];
}

}  // namespace

const std::vector<DirectionPair>& cosine_fit_geometries() {
  static const std::vector<DirectionPair> pairs = [] {
    std::vector<DirectionPair> v;
    const double alphas[] = {0.5, 1, 1.5, 2, 3, 4, 6, 8, 11, 15, 20, 27, 35, 45, 60, 80};
    const double min_z = std::cos(70 * kDeg);
    for (double ti = 15; ti <= 65.5; ti += 10) {
      const brdf::Vec3 wi(std::sin(ti * kDeg), 0, std::cos(ti * kDeg));
      const brdf::Vec3 r(-wi.x(), 0, wi.z());
      v.push_back({wi, r});
      // The plane of incidence every 2.5 deg of viewing angle: where multi-angle instruments
      // (and design targets) look (the mirror direction itself is the row above).
      for (double to = -70; to <= 70.1; to += 2.5)
        if (std::abs(to + ti) > 1e-9) v.push_back({wi, brdf::Vec3(std::sin(to * kDeg), 0, std::cos(to * kDeg))});
      // Around r, half a turn from the side away from the normal (beta 90 deg: around()'s second
      // axis points away from it) over the out-of-plane side (0) to the side towards the normal
      // (-90): the paints are symmetric about the plane of incidence, the other half is a mirror.
      for (double a : alphas)
        for (int k = 0; k < 5; ++k) {
          const brdf::Vec3 wo = around(r, a * kDeg, kPi / 2 - k * kPi / 4);
          if (wo.z() >= min_z) v.push_back({wi, wo});
        }
    }
    return v;
  }();
  return pairs;
}

Eigen::MatrixXd cosine_lobe_columns(const std::vector<DirectionPair>& at, const std::vector<double>& exponents) {
  const auto n = static_cast<Eigen::Index>(exponents.size());
  Eigen::MatrixXd A(static_cast<Eigen::Index>(at.size()), 1 + 2 * n);
  for (std::size_t s = 0; s < at.size(); ++s) {
    const auto r = static_cast<Eigen::Index>(s);
    const auto& [wi, wo] = at[s];
    A(r, 0) = 1.0 / kPi;
    for (Eigen::Index i = 0; i < n; ++i) {
      const double c = brdf::cosine_lobe(exponents[static_cast<std::size_t>(i)], wi, wo);
      A(r, 1 + i) = c / wi.z();
      A(r, 1 + n + i) = c;
    }
  }
  return A;
}

Eigen::VectorXd nnls(const Eigen::MatrixXd& A, const Eigen::VectorXd& b) {
  const Eigen::Index m = A.cols();
  // Columns scaled to unit length: the normal equations of the passive set stay well conditioned.
  Eigen::VectorXd scale = A.colwise().norm().transpose();
  for (Eigen::Index j = 0; j < m; ++j) scale[j] = scale[j] > 0 ? 1.0 / scale[j] : 0.0;
  const Eigen::MatrixXd As = A * scale.asDiagonal();
  const Eigen::MatrixXd G = As.transpose() * As;
  const Eigen::VectorXd Atb = As.transpose() * b;
  Eigen::VectorXd x = Eigen::VectorXd::Zero(m);
  std::vector<bool> passive(static_cast<std::size_t>(m), false);
  const double tol = 1e-12 * std::max(1.0, Atb.cwiseAbs().maxCoeff());
  auto solve_passive = [&](Eigen::VectorXd* s) {
    std::vector<Eigen::Index> idx;
    for (Eigen::Index j = 0; j < m; ++j)
      if (passive[static_cast<std::size_t>(j)]) idx.push_back(j);
    const auto k = static_cast<Eigen::Index>(idx.size());
    Eigen::MatrixXd Gp(k, k);
    Eigen::VectorXd bp(k);
    for (Eigen::Index a = 0; a < k; ++a) {
      bp[a] = Atb[idx[static_cast<std::size_t>(a)]];
      for (Eigen::Index c = 0; c < k; ++c) Gp(a, c) = G(idx[static_cast<std::size_t>(a)], idx[static_cast<std::size_t>(c)]);
    }
    const Eigen::VectorXd sp = Gp.ldlt().solve(bp);
    s->setZero(m);
    for (Eigen::Index a = 0; a < k; ++a) (*s)[idx[static_cast<std::size_t>(a)]] = sp[a];
  };
  // A variable that could not enter (its solve came out <= 0 at once: nearly collinear with the
  // passive set) is skipped until another one enters, so the loop cannot pick it forever.
  std::vector<bool> skipped(static_cast<std::size_t>(m), false);
  for (int outer = 0; outer < 3 * m; ++outer) {
    const Eigen::VectorXd grad = Atb - G * x;
    Eigen::Index best = -1;
    for (Eigen::Index j = 0; j < m; ++j)
      if (!passive[static_cast<std::size_t>(j)] && !skipped[static_cast<std::size_t>(j)] && grad[j] > tol &&
          (best < 0 || grad[j] > grad[best]))
        best = j;
    if (best < 0) break;
    passive[static_cast<std::size_t>(best)] = true;
    Eigen::VectorXd s;
    for (int inner = 0; inner < 3 * m; ++inner) {
      solve_passive(&s);
      double alpha = 1.0;
      Eigen::Index blocking = -1;
      for (Eigen::Index j = 0; j < m; ++j)
        if (passive[static_cast<std::size_t>(j)] && s[j] <= 0) {
          const double a = x[j] / (x[j] - s[j]);
          if (blocking < 0 || a < alpha) alpha = a, blocking = j;
        }
      if (blocking < 0) break;
      x += alpha * (s - x);
      // The blocking variable reaches 0 exactly (Lawson and Hanson); others at 0 leave as well.
      x[blocking] = 0;
      for (Eigen::Index j = 0; j < m; ++j)
        if (passive[static_cast<std::size_t>(j)] && x[j] <= 0) passive[static_cast<std::size_t>(j)] = false, x[j] = 0;
    }
    if (!passive[static_cast<std::size_t>(best)]) {
      skipped[static_cast<std::size_t>(best)] = true;
      solve_passive(&s);
    } else {
      std::fill(skipped.begin(), skipped.end(), false);
    }
    x = s.cwiseMax(0.0);
  }
  return x.cwiseProduct(scale);
}

Eigen::VectorXd cosine_lobe_albedo(const std::vector<double>& exponents) {
  const auto n = static_cast<Eigen::Index>(exponents.size());
  Eigen::VectorXd a(1 + 2 * n);
  a[0] = 1.0;
  for (Eigen::Index i = 0; i < n; ++i) a[1 + i] = a[1 + n + i] = 2 * kPi / (exponents[static_cast<std::size_t>(i)] + 2);
  return a;
}

Eigen::VectorXd nonnegative_l1(const Eigen::MatrixXd& A, const Eigen::VectorXd& b, const Eigen::VectorXd& l1_weights,
                               const Eigen::MatrixXd& C, const Eigen::VectorXd& d) {
  // min sum (u + v) + c.x subject to A x - u + v = b; x, u, v >= 0 (u, v: the residual's parts).
  lemon::Lp lp;
  lp.messageLevel(lemon::LpBase::MESSAGE_NOTHING);
  const Eigen::Index m = A.cols(), rows = A.rows();
  // Columns scaled to a largest entry of 1: the simplex's tolerances are absolute.
  // A column 1e-12 of the largest (a narrow lobe far from every row's geometry) is left out: it
  // could only contribute through a weight no paint has.
  Eigen::VectorXd scale(m);
  const double largest = A.cwiseAbs().maxCoeff();
  for (Eigen::Index j = 0; j < m; ++j) {
    const double mx = A.col(j).cwiseAbs().maxCoeff();
    scale[j] = mx > 1e-12 * largest ? 1.0 / mx : 0.0;
  }
  std::vector<lemon::Lp::Col> x(static_cast<std::size_t>(m));
  lemon::Lp::Expr objective;
  for (Eigen::Index j = 0; j < m; ++j) {
    x[static_cast<std::size_t>(j)] = lp.addCol();
    lp.colLowerBound(x[static_cast<std::size_t>(j)], 0);
    if (scale[j] == 0) lp.colUpperBound(x[static_cast<std::size_t>(j)], 0);
    if (l1_weights.size() == m && l1_weights[j] != 0) objective += l1_weights[j] * scale[j] * x[static_cast<std::size_t>(j)];
  }
  for (Eigen::Index r = 0; r < rows; ++r) {
    const auto u = lp.addCol(), v = lp.addCol();
    lp.colLowerBound(u, 0);
    lp.colLowerBound(v, 0);
    objective += u + v;
    lemon::Lp::Expr e;
    for (Eigen::Index j = 0; j < m; ++j)
      if (A(r, j) != 0 && scale[j] != 0) e += A(r, j) * scale[j] * x[static_cast<std::size_t>(j)];
    lp.addRow(e - u + v == b[r]);
  }
  for (Eigen::Index r = 0; r < C.rows(); ++r) {
    lemon::Lp::Expr e;
    for (Eigen::Index j = 0; j < m; ++j)
      if (C(r, j) != 0 && scale[j] != 0) e += C(r, j) * scale[j] * x[static_cast<std::size_t>(j)];
    lp.addRow(e <= d[r]);
  }
  lp.min();
  lp.obj(objective);
  const auto status = lp.solve();
  if (status != lemon::LpBase::SOLVED || lp.primalType() != lemon::Lp::OPTIMAL)
    throw DataError(fmt::format("the L1 linear programme ({} rows, {} weights) was not solved to optimality", rows, m));
  Eigen::VectorXd out(m);
  for (Eigen::Index j = 0; j < m; ++j) out[j] = std::max(0.0, lp.primal(x[static_cast<std::size_t>(j)])) * scale[j];
  return out;
}

CosineLobeFit fit_cosine_lobes(const brdf::Brdf& paint, const std::vector<double>& exponents, LobeNorm norm) {
  brdf::CosineLobeParams probe;
  probe.exponents = exponents;
  probe.kg.assign(exponents.size(), brdf::Rgb::Zero());
  probe.kdd = probe.kg;
  if (const std::string problem = brdf::cosine_lobes_problem(probe); !problem.empty())
    throw UsageError("cosine-lobe basis: " + problem);
  const auto& at = cosine_fit_geometries();
  const Eigen::MatrixXd A = cosine_lobe_columns(at, exponents);
  const Eigen::MatrixXd f = paint_values(paint, at);
  const auto x = fit_values(A, f, norm);
  CosineLobeFit fit;
  fit.params = params_from(exponents, x);
  relative_errors(A, f, x, &fit.mean_error, &fit.max_error);
  return fit;
}

// ---- basis ----

CosineBasis fit_cosine_basis(const std::vector<std::pair<std::string, std::shared_ptr<const brdf::Brdf>>>& paints,
                             const CosineBasisOptions& options) {
  if (paints.empty()) throw UsageError("basis fit: no paints to choose the exponents over");
  const int lo = options.min_lobes, hi = options.max_lobes;
  if (lo < 1 || hi > brdf::kMaxCosineLobes || lo > hi)
    throw UsageError(fmt::format("basis fit: lobe counts {}..{} outside 1..{}", lo, hi, brdf::kMaxCosineLobes));
  if (options.lobes && (*options.lobes < lo || *options.lobes > hi))
    throw UsageError(fmt::format("basis fit: --lobes {} outside the counts tried ({}..{})", *options.lobes, lo, hi));
  const auto& at = cosine_fit_geometries();
  std::vector<Eigen::MatrixXd> values;
  for (const auto& [name, brdf] : paints) values.push_back(paint_values(*brdf, at));

  // Per paint: its mean relative error for exponents e.
  auto errors = [&](const std::vector<double>& e, LobeNorm norm) {
    const Eigen::MatrixXd A = cosine_lobe_columns(at, e);
    std::vector<double> out;
    for (const auto& f : values) {
      double mean = 0, max = 0;
      relative_errors(A, f, fit_values(A, f, norm), &mean, &max);
      out.push_back(mean);
    }
    return out;
  };
  auto criterion = [](const std::vector<double>& e) {
    const double c = std::accumulate(e.begin(), e.end(), 0.0) / static_cast<double>(e.size()) +
                     *std::max_element(e.begin(), e.end());
    return std::isfinite(c) ? c : std::numeric_limits<double>::infinity();  // a failed fit never wins
  };

  CosineBasis basis;
  for (const auto& [name, brdf] : paints) basis.paints.push_back(name);
  for (int n = lo; n <= hi; ++n) {
    // Start: evenly spaced in log from 2 to 5000 (where the source's sets lie), one lobe: 50.
    Eigen::VectorXd x0(n);
    for (int i = 0; i < n; ++i)
      x0[i] = n == 1 ? std::log(50.0) : std::log(2.0) + (std::log(5000.0) - std::log(2.0)) * i / (n - 1);
    // And from the previous count's set with one exponent more in its widest gap (in log): the
    // search runs from both and keeps the better (Nelder-Mead finds a local minimum; the nested
    // start keeps a row from ending above the previous one, the even start finds sets it misses).
    std::vector<Eigen::VectorXd> starts = {x0};
    if (!basis.table.empty()) {
      std::vector<double> prev;
      for (double e : basis.table.back().exponents) prev.push_back(std::log(e));
      prev.insert(prev.begin(), std::log(brdf::kMinLobeExponent));
      prev.push_back(std::log(1e4));
      std::size_t gap = 0;
      for (std::size_t i = 1; i + 1 < prev.size(); ++i)
        if (prev[i + 1] - prev[i] > prev[gap + 1] - prev[gap]) gap = i;
      std::vector<double> inner(prev.begin() + 1, prev.end() - 1);
      inner.insert(inner.begin() + static_cast<std::ptrdiff_t>(gap), 0.5 * (prev[gap] + prev[gap + 1]));
      Eigen::VectorXd nested(n);
      for (int i = 0; i < n; ++i) nested[i] = inner[static_cast<std::size_t>(i)];
      starts.push_back(nested);
    }
    int evals = 0;
    double best = std::numeric_limits<double>::infinity();
    Eigen::VectorXd x;
    for (const Eigen::VectorXd& start : starts) {
      int e = 0;
      double b = 0;
      const Eigen::VectorXd found = nelder_mead(
          [&](const Eigen::VectorXd& p) { return criterion(errors(sorted_exponents(p), LobeNorm::L2)); }, start,
          n == 1 ? 1.0 : 0.5 * (std::log(5000.0) - std::log(2.0)) / (n - 1), options.max_evaluations, &e, &b);
      evals += e;
      if (b < best) best = b, x = found;
    }
    CosineBasisRow row;
    row.lobes = n;
    row.exponents = sorted_exponents(x);
    row.evaluations = evals;
    const std::vector<double> e = errors(row.exponents, LobeNorm::L1);
    row.mean_error = std::accumulate(e.begin(), e.end(), 0.0) / static_cast<double>(e.size());
    const auto worst = std::max_element(e.begin(), e.end());
    row.max_error = *worst;
    row.worst_paint = basis.paints[static_cast<std::size_t>(worst - e.begin())];
    if (options.progress) options.progress(row);
    basis.table.push_back(std::move(row));
  }
  const auto best = std::min_element(basis.table.begin(), basis.table.end(),
                                     [](const auto& a, const auto& b) { return a.criterion() < b.criterion(); });
  const CosineBasisRow* kept = &*best;
  for (const auto& row : basis.table) {
    if (options.lobes ? row.lobes == *options.lobes : row.criterion() <= (1.0 + options.keep_within) * best->criterion()) {
      kept = &row;
      break;
    }
  }
  basis.lobes = kept->lobes;
  basis.exponents = kept->exponents;
  return basis;
}

Json CosineBasis::to_json() const {
  Json rows = Json::array();
  for (const auto& r : table)
    rows.push_back({{"lobes", r.lobes},
                    {"exponents", r.exponents},
                    {"mean_error", r.mean_error},
                    {"max_error", r.max_error},
                    {"criterion", r.criterion()},
                    {"worst_paint", r.worst_paint},
                    {"evaluations", r.evaluations}});
  return {{"format", kCosineBasisFormat},
          {"version", kCosineBasisVersion},
          {"model", "f (n.i) = kd / pi (n.i) + sum_i kg_i (r.o)^E_i + (n.i) sum_i kdd_i (r.o)^E_i"},
          {"error", "mean over geometries and channels of |fit - paint| / (paint + 0.01 / pi)"},
          {"exponents", exponents},
          {"lobes", lobes},
          {"library", library},
          {"paints", paints},
          {"table", rows}};
}

CosineBasis CosineBasis::from_json(const Json& j, const std::string& where) {
  if (!j.is_object()) throw DataError(where + ": expected a JSON object (a cosine-lobe basis)");
  if (const auto f = json_get<std::string>(j, "format", where); f != kCosineBasisFormat)
    throw DataError(fmt::format("{}: key 'format': '{}' is not '{}'", where, f, kCosineBasisFormat));
  if (const auto v = json_get<int>(j, "version", where); v < 1 || v > kCosineBasisVersion)
    throw DataError(fmt::format("{}: key 'version': {} is not 1..{} (written by a newer paintlab?)", where, v,
                                kCosineBasisVersion));
  CosineBasis b;
  b.exponents = json_get<std::vector<double>>(j, "exponents", where);
  b.lobes = static_cast<int>(b.exponents.size());
  b.library = json_get_or<std::string>(j, "library", "", where);
  b.paints = json_get_or<std::vector<std::string>>(j, "paints", {}, where);
  brdf::CosineLobeParams probe;
  probe.exponents = b.exponents;
  probe.kg.assign(b.exponents.size(), brdf::Rgb::Zero());
  probe.kdd = probe.kg;
  if (const std::string problem = brdf::cosine_lobes_problem(probe); !problem.empty())
    throw DataError(where + ": " + problem);
  if (j.contains("table")) {
    const Json& t = j.at("table");
    if (!t.is_array()) throw DataError(where + ": key 'table': expected an array");
    for (std::size_t i = 0; i < t.size(); ++i) {
      const std::string w = fmt::format("{}: table[{}]", where, i);
      CosineBasisRow r;
      r.lobes = json_get<int>(t[i], "lobes", w);
      r.exponents = json_get<std::vector<double>>(t[i], "exponents", w);
      r.mean_error = json_get<double>(t[i], "mean_error", w);
      r.max_error = json_get<double>(t[i], "max_error", w);
      r.worst_paint = json_get_or<std::string>(t[i], "worst_paint", "", w);
      r.evaluations = json_get_or<int>(t[i], "evaluations", 0, w);
      b.table.push_back(std::move(r));
    }
  }
  return b;
}

void write_cosine_basis(const fs::path& path, const CosineBasis& basis) { write_json_file(path, basis.to_json()); }

CosineBasis read_cosine_basis(const fs::path& path) {
  return CosineBasis::from_json(read_json_file(path), path.string());
}

std::string cosine_basis_table(const CosineBasis& basis) {
  std::string s = fmt::format("{:>5}  {:>9}  {:>10}  {:>9}  {}\n", "LOBES", "MEAN ERR", "WORST ERR", "CRITERION",
                              "EXPONENTS (worst paint)");
  for (const auto& r : basis.table) {
    std::string e;
    for (double x : r.exponents) e += fmt::format("{}{:.3g}", e.empty() ? "" : " ", x);
    s += fmt::format("{:>5}  {:>8.2f}%  {:>9.2f}%  {:>8.2f}%  {} ({}){}\n", r.lobes, 100 * r.mean_error,
                     100 * r.max_error, 100 * r.criterion(), e, r.worst_paint, r.lobes == basis.lobes ? "  <- kept" : "");
  }
  return s;
}

// ---- design ----

DesignTargets load_design_targets(const fs::path& file) {
  if (!fs::exists(file)) throw UsageError(fmt::format("targets file {} does not exist", file.string()));
  const ConfigTable t = ConfigTable::parse_file(file);
  DesignTargets d;
  d.name = t.string("name", "designed");
  if (const auto b = t.maybe_string("basis")) d.basis = fs::path(*b).is_absolute() ? fs::path(*b) : file.parent_path() / *b;
  for (const ConfigTable& x : t.tables("target", 1, 32)) {
    DesignTarget target;
    const std::string text = x.string("geometry");
    try {
      target.geometry = parse_geometry(text);
    } catch (const UsageError& e) {
      throw ConfigError(file.string(), x.line("geometry"), x.path("geometry"), e.what());
    }
    const auto lab = x.triple("lab");
    if (!(lab[0] >= 0 && lab[0] <= 150))
      throw ConfigError(file.string(), x.line("lab"), x.path("lab"), fmt::format("L* {} outside [0, 150]", lab[0]));
    for (int k : {1, 2})
      if (!(std::abs(lab[static_cast<std::size_t>(k)]) <= 200))
        throw ConfigError(file.string(), x.line("lab"), x.path("lab"),
                          fmt::format("{} {} outside [-200, 200]", k == 1 ? "a*" : "b*", lab[static_cast<std::size_t>(k)]));
    target.lab = {lab[0], lab[1], lab[2]};
    for (const auto& y : d.targets)
      if (y.geometry.illumination_deg == target.geometry.illumination_deg &&
          y.geometry.aspecular_deg == target.geometry.aspecular_deg)
        throw ConfigError(file.string(), x.line("geometry"), x.path("geometry"),
                          fmt::format("a second target for {}", target.geometry.name));
    x.finish();
    d.targets.push_back(std::move(target));
  }
  t.finish();
  return d;
}

bool DesignResult::all_reached() const {
  return std::all_of(angles.begin(), angles.end(), [](const DesignAngle& a) { return a.reached; });
}

DesignResult design_paint(const std::vector<double>& exponents, const std::vector<DesignTarget>& targets,
                          const brdf::CosineLobeParams* like) {
  if (targets.empty()) throw UsageError("design: no targets");
  if (like && like->exponents != exponents)
    throw UsageError(fmt::format("design: the paint to take unseen lobes from has {} exponents other than the basis's {}",
                                 like->exponents.size(), exponents.size()));
  std::vector<DirectionPair> at;
  for (const auto& t : targets) at.push_back({t.geometry.towards_light(), t.geometry.towards_viewer()});
  // The reflectance factor R = pi f of each column at each target geometry.
  Eigen::MatrixXd A = kPi * cosine_lobe_columns(at, exponents);
  const auto g = static_cast<Eigen::Index>(targets.size());
  const auto n = static_cast<Eigen::Index>(exponents.size());
  Eigen::MatrixXd R(g, 3);
  std::vector<std::string> gamut(targets.size());
  for (Eigen::Index k = 0; k < g; ++k) {
    const colour::Rgb rgb = colour::xyz_to_srgb(colour::lab_to_xyz(targets[static_cast<std::size_t>(k)].lab, colour::d65()));
    for (int c = 0; c < 3; ++c) R(k, c) = std::max(rgb[c], 0.0);
    if ((rgb.array() < 0).any())
      gamut[static_cast<std::size_t>(k)] = fmt::format(
          "outside the sRGB gamut (linear R, G, B {:.3f}, {:.3f}, {:.3f}): non-negative weights cannot make it", rgb[0],
          rgb[1], rgb[2]);
  }
  const Eigen::VectorXd albedo = cosine_lobe_albedo(exponents);
  // Unseen lobes: out of the programme, their weights from `like` (or 0), their contribution at
  // the targets and their albedo taken off what the programme may use.
  std::array<Eigen::VectorXd, 3> fixed;
  for (auto& f : fixed) f = Eigen::VectorXd::Zero(1 + 2 * n);
  std::vector<std::string> notes;
  Eigen::Index seen_lobes = 0;
  for (Eigen::Index i = 0; i < n; ++i) {
    double seen = 0;
    for (const auto& [wi, wo] : at) seen = std::max(seen, brdf::cosine_lobe(exponents[static_cast<std::size_t>(i)], wi, wo));
    if (seen >= kUnseenLobe) {
      ++seen_lobes;
      continue;
    }
    for (int c = 0; c < 3; ++c) {
      if (like) {
        fixed[static_cast<std::size_t>(c)][1 + i] = like->kg[static_cast<std::size_t>(i)][c];
        fixed[static_cast<std::size_t>(c)][1 + n + i] = like->kdd[static_cast<std::size_t>(i)][c];
      }
    }
    notes.push_back(fmt::format("exponent {:.4g}: no target sees its lobe (at most {:.1e} of its peak); {}",
                                exponents[static_cast<std::size_t>(i)], seen,
                                like ? "its weights are the --like paint's"
                                     : "left at 0 (give --like PAINT to keep a measured paint's lobe there, e.g. its "
                                       "clear coat)"));
    A.col(1 + i).setZero();
    A.col(1 + n + i).setZero();
  }
  // At most 1 of albedo at normal incidence per channel, and among equally close solutions the
  // one of least albedo (1e-6 of the objective's scale: it never trades an error for it).
  const Eigen::MatrixXd C = albedo.transpose();
  const Eigen::MatrixXd At = kPi * cosine_lobe_columns(at, exponents);  // with the unseen columns
  const Eigen::VectorXd tie = 1e-6 * albedo;
  const auto start = std::chrono::steady_clock::now();
  std::array<Eigen::VectorXd, 3> x;
  for (int c = 0; c < 3; ++c) {
    const auto cc = static_cast<std::size_t>(c);
    const Eigen::VectorXd target = R.col(c) - At * fixed[cc];
    const Eigen::VectorXd w = (R.col(c).array() + 0.01).inverse().matrix();
    const Eigen::VectorXd room = Eigen::VectorXd::Constant(1, std::max(0.0, 1.0 - albedo.dot(fixed[cc])));
    x[cc] = nonnegative_l1(w.asDiagonal() * A, w.cwiseProduct(target), tie, C, room) + fixed[cc];
  }
  DesignResult r;
  r.solve_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  r.params = params_from(exponents, x);
  r.notes = std::move(notes);
  const brdf::CosineLobes model(r.params);
  for (std::size_t k = 0; k < targets.size(); ++k) {
    DesignAngle a;
    a.target = targets[k];
    const brdf::Rgb f = model.eval(at[k].wi, at[k].wo) * kPi;
    a.achieved = colour::srgb_to_lab(colour::Rgb(f[0], f[1], f[2]));
    a.de00 = colour::delta_e_2000(a.target.lab, a.achieved);
    a.reached = a.de00 <= kDesignToleranceDe00;
    if (!a.reached)
      a.why = !gamut[k].empty()
                  ? gamut[k]
                  : fmt::format("no non-negative combination of the diffuse term and the {} lobe{} these targets see "
                                "comes closer while the other targets are held (a flop across the angles the lobes "
                                "cannot make; a basis of more lobes, basis fit --lobes N, may)",
                                seen_lobes, seen_lobes == 1 ? "" : "s");
    r.angles.push_back(std::move(a));
  }
  return r;
}

std::string design_table(const DesignResult& r) {
  std::string s = fmt::format("{:<9} {:>24}  {:>24}  {:>6}  {}\n", "GEOMETRY", "TARGET L* a* b*", "DESIGN L* a* b*",
                              "dE00", "");
  for (const auto& a : r.angles)
    s += fmt::format("{:<9} {:>7.2f} {:>7.2f} {:>8.2f}  {:>7.2f} {:>7.2f} {:>8.2f}  {:>6.2f}  {}\n",
                     a.target.geometry.name, a.target.lab.L, a.target.lab.a, a.target.lab.b, a.achieved.L, a.achieved.a,
                     a.achieved.b, a.de00, a.reached ? "reached" : "NOT REACHED: " + a.why);
  for (const auto& n : r.notes) s += n + "\n";
  s += fmt::format("solve: {:.2f} ms (three linear programmes, {} lobes)\n", r.solve_ms, r.params.exponents.size());
  return s;
}

Json design_json(const DesignResult& r) {
  Json angles = Json::array();
  for (const auto& a : r.angles) {
    Json j = {{"geometry", a.target.geometry.name},
              {"target", {a.target.lab.L, a.target.lab.a, a.target.lab.b}},
              {"achieved", {a.achieved.L, a.achieved.a, a.achieved.b}},
              {"de00", a.de00},
              {"reached", a.reached}};
    if (!a.reached) j["why"] = a.why;
    angles.push_back(std::move(j));
  }
  return {{"tolerance_de00", kDesignToleranceDe00},
          {"all_reached", r.all_reached()},
          {"solve_ms", r.solve_ms},
          {"exponents", r.params.exponents},
          {"notes", r.notes},
          {"targets", angles}};
}

}  // namespace paintlab::fit
