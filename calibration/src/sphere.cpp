#include "paintlab/calibration/sphere.h"

#include <ceres/ceres.h>

#include <Eigen/Dense>
#include <algorithm>
#include <functional>
#include <cmath>
#include <fmt/format.h>
#include <opencv2/imgproc.hpp>
#include <random>

#include "paintlab/calibration/cost_functions.h"
#include "paintlab/core/error.h"
#include "paintlab/core/robust.h"
#include "dense_solve.h"

namespace paintlab::calib {

void SphereOptions::check() const {
  if (!(radius_m > 0.0)) throw UsageError("sphere: the sphere radius must be > 0 m (rig.toml geometry.sphere_radius_m)");
  if (!(sector_arc_px >= 1.0 && sector_arc_px <= 50.0)) throw UsageError("sphere: sector_arc_px must be in [1, 50]");
  if (!(band_inside_px >= 4.0 && band_outside_px >= 3.0)) throw UsageError("sphere: the profile band is too narrow");
  if (!(min_snr > 0.0)) throw UsageError("sphere: min_snr must be > 0");
  if (!(min_step_frac >= 0.0 && min_step_frac <= 1.0)) throw UsageError("sphere: min_step_frac must be in [0, 1]");
  if (!(outlier_sigmas >= 2.0)) throw UsageError("sphere: outlier_sigmas must be >= 2");
  if (!(image_blur_var_px2 >= 0.0 && image_blur_var_px2 <= 25.0))
    throw OptionError("SphereOptions::image_blur_var_px2", fmt::format("{}", image_blur_var_px2), "[0, 25] px^2");
}

// ---- the limb profile H(x) = int_0^inf sqrt(u) phi(x - u) du ----

namespace {

constexpr double kTableLo = -8.0, kTableHi = 40.0, kTableStep = 1.0 / 32.0;

struct LimbTable {
  std::vector<double> h, dh;
  LimbTable() {
    const int n = static_cast<int>(std::lround((kTableHi - kTableLo) / kTableStep)) + 1;
    h.resize(static_cast<std::size_t>(n));
    dh.resize(static_cast<std::size_t>(n));
    const double inv_sqrt_2pi = 1.0 / std::sqrt(2.0 * kPi);
    for (int i = 0; i < n; ++i) {
      const double x = kTableLo + i * kTableStep;
      // u = v^2 removes the square root: H = int_0^inf 2 v^2 phi(x - v^2) dv,
      // H' = int_0^inf 2 v^2 (v^2 - x) phi(x - v^2) dv. Simpson's rule.
      const double vmax = std::sqrt(std::max(x, 0.0) + 10.0);
      const int m = 4000;
      const double dv = vmax / m;
      double sh = 0, sd = 0;
      for (int k = 0; k <= m; ++k) {
        const double v = k * dv, z = x - v * v;
        const double f = 2.0 * v * v * std::exp(-0.5 * z * z) * inv_sqrt_2pi;
        const double w = (k == 0 || k == m) ? 1.0 : (k % 2 ? 4.0 : 2.0);
        sh += w * f;
        sd += w * f * (-z);
      }
      h[static_cast<std::size_t>(i)] = sh * dv / 3.0;
      dh[static_cast<std::size_t>(i)] = sd * dv / 3.0;
    }
  }
};

const LimbTable& limb_table() {
  static const LimbTable table;
  return table;
}

}  // namespace

double limb_profile(double x, double* derivative) {
  if (x <= kTableLo) {
    if (derivative) *derivative = 0.0;
    return 0.0;
  }
  if (x >= kTableHi) {  // E[sqrt(x + Z)] ~ sqrt(x) - 1 / (8 x^1.5)
    if (derivative) *derivative = 0.5 / std::sqrt(x) + 3.0 / (16.0 * std::pow(x, 2.5));
    return std::sqrt(x) - 1.0 / (8.0 * std::pow(x, 1.5));
  }
  const LimbTable& t = limb_table();
  const double s = (x - kTableLo) / kTableStep;
  const std::size_t i = std::min(static_cast<std::size_t>(s), t.h.size() - 2);
  const double u = s - static_cast<double>(i);
  // Cubic Hermite with the tabulated derivatives: C1 in x, consistent value and slope.
  const double h0 = t.h[i], h1 = t.h[i + 1], m0 = t.dh[i] * kTableStep, m1 = t.dh[i + 1] * kTableStep;
  const double u2 = u * u, u3 = u2 * u;
  const double v = (2 * u3 - 3 * u2 + 1) * h0 + (u3 - 2 * u2 + u) * m0 + (-2 * u3 + 3 * u2) * h1 + (u3 - u2) * m1;
  if (derivative)
    *derivative = ((6 * u2 - 6 * u) * h0 + (3 * u2 - 4 * u + 1) * m0 + (-6 * u2 + 6 * u) * h1 + (3 * u2 - 2 * u) * m1) /
                  kTableStep;
  return v;
}

namespace {

double profile_value(const double* p, double t) {
  const double s = std::exp(p[1]), x = t / s;
  const double Phi = 0.5 * (1.0 + std::erf(x * M_SQRT1_2));
  const double phi = std::exp(-0.5 * x * x) / std::sqrt(2.0 * kPi);
  return p[2] + (p[3] - p[2]) * Phi + p[4] * std::sqrt(s) * limb_profile(x) + p[5] * s * (x * Phi + phi);
}

struct SectorEdge {
  bool ok = false;
  double e = 0, std = 0, sigma = 0, psf_sigma = 0, step = 0, strength = 0;
};

SectorEdge fit_sector(const std::vector<double>& r, const std::vector<double>& v, double r0, double phi,
                      const SphereOptions& o, std::optional<double> c1_fixed = std::nullopt) {
  SectorEdge out;
  if (r.size() < 16) return out;
  // Start: background outside, level inside near the edge, edge where the profile crosses
  // halfway between them.
  std::vector<double> outside, inside;
  for (std::size_t i = 0; i < r.size(); ++i) {
    if (r[i] > r0 + 2.5) outside.push_back(v[i]);
    if (r[i] < r0 - 1.0 && r[i] > r0 - 4.0) inside.push_back(v[i]);
  }
  if (outside.size() < 4 || inside.size() < 4) return out;
  const double b0 = upper_median(outside), c00 = upper_median(inside);
  double e0 = r0;
  {
    // The best sharp step between the two levels.
    double best = 1e300;
    for (double e = r0 - 3.0; e <= r0 + 3.0; e += 0.25) {
      double cost = 0;
      for (std::size_t i = 0; i < r.size(); ++i) {
        if (std::abs(r[i] - e) > 3.0) continue;
        const double model = r[i] < e ? c00 : b0;
        cost += (v[i] - model) * (v[i] - model);
      }
      if (cost < best) {
        best = cost;
        e0 = e;
      }
    }
  }
  double p[6] = {e0, 0.0, b0, c00, c1_fixed ? *c1_fixed : 0.0, 0.0};
  const int n = static_cast<int>(r.size());
  ceres::CostFunction* cost = EdgeProfileCost::Create(&r, &v, o.pixel_box ? PixelBox::along(phi) : PixelBox{});
  std::unique_ptr<ceres::CostFunction> owned(cost);
  ceres::Problem::Options po;
  po.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(po);
  problem.AddResidualBlock(cost, nullptr, p);
  if (c1_fixed) problem.SetManifold(p, new ceres::SubsetManifold(6, {4}));
  // With the pixel's box the optics may be sharper than the pixel (s at its bound).
  const double s_min = o.pixel_box ? 0.05 : 0.1;
  problem.SetParameterLowerBound(p, 1, std::log(s_min));
  problem.SetParameterUpperBound(p, 1, std::log(8.0));
  const ceres::Solver::Summary summary = solve_dense(problem, 80, 1e-12, 1e-10);
  if (summary.termination_type == ceres::FAILURE) return out;
  const double sigma = std::exp(p[1]);
  if (!std::isfinite(p[0]) || p[0] < r0 - o.band_inside_px + 2.0 || p[0] > r0 + o.band_outside_px - 2.0) return out;
  const bool sharp = o.pixel_box && sigma < 1.1 * s_min;  // the box alone: s is not a parameter
  if (!((sharp || sigma > 1.1 * s_min) && sigma < 7.9)) return out;

  std::vector<double> res(static_cast<std::size_t>(n)), jac(static_cast<std::size_t>(n) * 6);
  const double* params[1] = {p};
  double* jacs[1] = {jac.data()};
  if (!cost->Evaluate(params, res.data(), jacs)) return out;
  Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, 6, Eigen::RowMajor>> J6(jac.data(), n, 6);
  // Free parameters: all six, but c1 when it is held and s when it sits at its bound.
  const int nf = 6 - (c1_fixed ? 1 : 0) - (sharp ? 1 : 0);
  Eigen::MatrixXd J(n, nf);
  for (int k = 0, j = 0; k < 6; ++k)
    if (!((c1_fixed && k == 4) || (sharp && k == 1))) J.col(j++) = J6.col(k);
  double rss = 0;
  for (double x : res) rss += x * x;
  const double s2 = rss / std::max(1, n - nf);
  const Eigen::MatrixXd JtJ = J.transpose() * J;
  const Eigen::MatrixXd cov = JtJ.ldlt().solve(Eigen::MatrixXd::Identity(nf, nf)) * s2;
  if (!(cov(0, 0) > 0) || !std::isfinite(cov(0, 0))) return out;
  // Edge strength: the model just inside the edge against the background.
  double strength = 0;
  for (double t = 1.0; t <= 3.0; t += 0.5) strength = std::max(strength, std::abs(profile_value(p, t) - p[2]));
  if (!(strength > o.min_snr * std::sqrt(s2))) return out;
  if (std::abs(p[3] - p[2]) < o.min_step_frac * std::abs(profile_value(p, 3.0) - p[2])) return out;
  out.ok = true;
  out.e = p[0];
  out.std = std::sqrt(cov(0, 0));
  out.psf_sigma = sigma;
  out.sigma = o.pixel_box ? std::sqrt(sigma * sigma + 1.0 / 12.0) : sigma;
  out.step = p[3] - p[2];
  out.strength = strength;
  return out;
}

// Circle through three points; false when they are (nearly) collinear.
bool circle_through(const Vec2& a, const Vec2& b, const Vec2& c, Vec2* centre, double* radius) {
  const Vec2 ab = b - a, ac = c - a;
  const double d = 2.0 * (ab.x() * ac.y() - ab.y() * ac.x());
  if (std::abs(d) < 1e-9 * ab.squaredNorm() * ac.squaredNorm() + 1e-12) return false;
  const double b2 = ab.squaredNorm(), c2 = ac.squaredNorm();
  const Vec2 o((ac.y() * b2 - ab.y() * c2) / d, (ab.x() * c2 - ac.x() * b2) / d);
  *centre = a + o;
  *radius = o.norm();
  return true;
}

// Least-squares (algebraic) circle through points: x^2 + y^2 + D x + E y + F = 0.
bool fit_circle(const std::vector<Vec2>& pts, Vec2* centre, double* radius) {
  if (pts.size() < 3) return false;
  Vec2 m = Vec2::Zero();
  for (const Vec2& p : pts) m += p / static_cast<double>(pts.size());
  Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
  Eigen::Vector3d rhs = Eigen::Vector3d::Zero();
  for (const Vec2& p : pts) {
    const Vec2 q = p - m;  // centred: a well-conditioned system
    const Eigen::Vector3d row(q.x(), q.y(), 1.0);
    A += row * row.transpose();
    rhs -= row * q.squaredNorm();
  }
  const Eigen::Vector3d s = A.ldlt().solve(rhs);
  const double r2 = 0.25 * (s(0) * s(0) + s(1) * s(1)) - s(2);
  if (!s.allFinite() || !(r2 > 0.0)) return false;
  *centre = m + Vec2(-0.5 * s(0), -0.5 * s(1));
  *radius = std::sqrt(r2);
  return true;
}

// Coarse circle: the outline of the largest bright blob. Lit from the side, the blob is only
// the lit part of the disc, cut off by the terminator (where the shading drops below the
// threshold): its enclosing circle is then centred on that cut, up to a fifth of the radius
// off, and the edge search around it misses most of the lit limb. So the circle is fitted
// to the part of the outline that is a circular arc (the limb), found by consensus over
// circles through three outline points; the enclosing circle remains the fallback.
bool coarse_circle(const ImageF& img, Vec2* centre, double* radius) {
  cv::Mat m(img.height(), img.width(), CV_32F, const_cast<float*>(img.data()));
  std::vector<float> sample;
  for (int y = 0; y < m.rows; y += 2)
    for (int x = 0; x < m.cols; x += 2) sample.push_back(m.at<float>(y, x));
  const double lo = lower_quantile_inplace(sample, 0.05), hi = lower_quantile_inplace(sample, 0.999);
  if (!(hi > lo)) return false;
  cv::Mat mask = m > static_cast<float>(lo + 0.12 * (hi - lo));
  cv::Mat labels, stats, centroids;
  const int n = cv::connectedComponentsWithStats(mask, labels, stats, centroids, 8, CV_32S);
  int best = -1, area = 0;
  for (int i = 1; i < n; ++i)
    if (stats.at<int>(i, cv::CC_STAT_AREA) > area) {
      area = stats.at<int>(i, cv::CC_STAT_AREA);
      best = i;
    }
  if (best < 0 || area < 50) return false;
  cv::Mat blob = labels == best;
  std::vector<std::vector<cv::Point>> contours;
  cv::findContours(blob, contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
  if (contours.empty()) return false;
  std::size_t big = 0;
  for (std::size_t i = 1; i < contours.size(); ++i)
    if (contours[i].size() > contours[big].size()) big = i;
  cv::Point2f c;
  float r = 0;
  cv::minEnclosingCircle(contours[big], c, r);
  *centre = Vec2(c.x, c.y);
  *radius = r;

  // The outline without the stretches along the image border (not the sphere's).
  std::vector<Vec2> outline;
  for (const cv::Point& p : contours[big])
    if (p.x > 0 && p.y > 0 && p.x < img.width() - 1 && p.y < img.height() - 1) outline.emplace_back(p.x, p.y);
  if (outline.size() < 20) return true;
  const double tol = 1.5;  // px: the threshold crossing follows the blurred limb within a pixel
  auto inliers_of = [&](const Vec2& cc, double rr, std::vector<Vec2>* keep) {
    int count = 0;
    for (const Vec2& p : outline)
      if (std::abs((p - cc).norm() - rr) <= tol) {
        ++count;
        if (keep) keep->push_back(p);
      }
    return count;
  };
  std::mt19937 rng(12345);  // fixed: the same image always gives the same circle
  std::uniform_int_distribution<std::size_t> pick(0, outline.size() - 1);
  Vec2 best_c = Vec2::Zero();
  double best_r = 0.0;
  int best_count = 0;
  for (int it = 0; it < 400; ++it) {
    const Vec2 &a = outline[pick(rng)], &b = outline[pick(rng)], &d = outline[pick(rng)];
    // Points close together give an ill-defined circle.
    const double spread = 0.25 * r;
    if ((a - b).norm() < spread || (a - d).norm() < spread || (b - d).norm() < spread) continue;
    Vec2 cc;
    double rr = 0.0;
    if (!circle_through(a, b, d, &cc, &rr) || rr < 0.5 * r || rr > 3.0 * r) continue;
    const int count = inliers_of(cc, rr, nullptr);
    if (count > best_count) {
      best_count = count;
      best_c = cc;
      best_r = rr;
    }
  }
  // The limb must make up a good part of the outline (a lit half disc: about 60 %).
  if (best_count < std::max(20, static_cast<int>(outline.size() / 4))) return true;
  for (int round = 0; round < 2; ++round) {
    std::vector<Vec2> arc;
    inliers_of(best_c, best_r, &arc);
    Vec2 cc;
    double rr = 0.0;
    if (!fit_circle(arc, &cc, &rr) || !(rr > 0.5 * r && rr < 3.0 * r)) break;
    best_c = cc;
    best_r = rr;
  }
  *centre = best_c;
  *radius = best_r;
  return true;
}

// Edge points of one image around a centre, with the expected edge radius per angle.
std::vector<EdgePoint> find_edges(const ImageF& img, const Vec2& c, const std::function<double(double)>& r0_of,
                                  double r_max, const SphereOptions& o, int image_index, std::optional<double> onset) {
  const int K = std::max(32, static_cast<int>(std::lround(2.0 * kPi * r_max / o.sector_arc_px)));
  std::vector<std::vector<double>> rs(static_cast<std::size_t>(K)), vs(static_cast<std::size_t>(K));
  std::vector<double> r0(static_cast<std::size_t>(K));
  for (int k = 0; k < K; ++k) r0[static_cast<std::size_t>(k)] = r0_of(-kPi + (k + 0.5) * 2.0 * kPi / K);
  const double reach = r_max + o.band_outside_px + 1.0;
  const int x0 = std::max(0, static_cast<int>(std::floor(c.x() - reach)));
  const int x1 = std::min(img.width() - 1, static_cast<int>(std::ceil(c.x() + reach)));
  const int y0 = std::max(0, static_cast<int>(std::floor(c.y() - reach)));
  const int y1 = std::min(img.height() - 1, static_cast<int>(std::ceil(c.y() + reach)));
  for (int y = y0; y <= y1; ++y)
    for (int x = x0; x <= x1; ++x) {
      const double dx = x - c.x(), dy = y - c.y();
      const double r = std::hypot(dx, dy);
      const double phi = std::atan2(dy, dx);
      int k = static_cast<int>(std::floor((phi + kPi) / (2.0 * kPi) * K));
      k = std::clamp(k, 0, K - 1);
      const double rk = r0[static_cast<std::size_t>(k)];
      if (r < rk - o.band_inside_px || r > rk + o.band_outside_px) continue;
      rs[static_cast<std::size_t>(k)].push_back(r);
      vs[static_cast<std::size_t>(k)].push_back(img.at(x, y));
    }
  // A sector that reaches the image border has a truncated profile: skip it.
  std::vector<SectorEdge> fits(static_cast<std::size_t>(K));
  for (int k = 0; k < K; ++k) {
    const double phi = -kPi + (k + 0.5) * 2.0 * kPi / K;
    const double rk = r0[static_cast<std::size_t>(k)];
    const Vec2 far = c + (rk + o.band_outside_px + 1.0) * Vec2(std::cos(phi), std::sin(phi));
    if (far.x() < 0 || far.y() < 0 || far.x() > img.width() - 1 || far.y() > img.height() - 1) continue;
    SectorEdge& f = fits[static_cast<std::size_t>(k)];
    f = fit_sector(rs[static_cast<std::size_t>(k)], vs[static_cast<std::size_t>(k)], rk, phi, o);
    // A step edge with a free onset (the test that leaves out dark limbs) is fitted again
    // with the onset the disc's shading gives.
    if (f.ok && onset) f = fit_sector(rs[static_cast<std::size_t>(k)], vs[static_cast<std::size_t>(k)], rk, phi, o, onset);
  }
  std::vector<EdgePoint> out;
  for (int k = 0; k < K; ++k) {
    const double phi = -kPi + (k + 0.5) * 2.0 * kPi / K;
    const SectorEdge& s = fits[static_cast<std::size_t>(k)];
    if (!s.ok) continue;
    EdgePoint e;
    e.px = c + s.e * Vec2(std::cos(phi), std::sin(phi));
    e.angle_rad = phi;
    e.std_px = std::max(s.std, 0.005);
    e.sigma_px = s.sigma;
    e.psf_sigma_px = s.psf_sigma;
    e.step = s.step;
    e.image = image_index;
    out.push_back(e);
  }
  return out;
}

// The sqrt(t) onset of a lit limb's shading, from the shading of the whole disc. Near the
// limb cos(theta_i) = (u . w)(1 - t/R) + (v . w) sqrt(2 t / R) (t px inside the edge of a
// silhouette of R px, u the outward direction in the image, v towards the camera, w towards
// the light): the onset A (v . w) sqrt(2 / R) is one figure for the whole outline. The disc's
// lit pixels give A w: value = g . n + b over them (n the sphere normal at the pixel, g = A w).
// Fitted per sector instead, the onset also soaks up any difference between the true blur
// and the edge model's, on the inside only, and the edge moves (0.012 px outwards with the
// simulator's sampled 0.5 px PSF: 0.05 mm of sphere depth). Nothing when the disc does not
// look like a lit Lambertian sphere.
std::optional<double> limb_onset(const ImageF& img, const CameraModel& camera, const Vec3& centre, double radius,
                                 double rho_px) {
  const Vec2 cpx = camera.project(centre);
  const int step = std::max(1, static_cast<int>(rho_px / 60.0));
  struct Px {
    Vec3 n;
    double v;
  };
  std::vector<Px> px;
  double vmax = 0;
  for (int y = static_cast<int>(cpx.y() - rho_px); y <= static_cast<int>(cpx.y() + rho_px); y += step)
    for (int x = static_cast<int>(cpx.x() - rho_px); x <= static_cast<int>(cpx.x() + rho_px); x += step) {
      if (x < 0 || y < 0 || x >= img.width() || y >= img.height()) continue;
      if ((Vec2(x, y) - cpx).norm() > 0.9 * rho_px) continue;
      auto X = intersect_sphere(camera.ray(Vec2(x, y)), centre, radius);
      const double v = img.at(x, y);
      if (!X || !std::isfinite(v)) continue;
      px.push_back({(*X - centre) / radius, v});
      vmax = std::max(vmax, v);
    }
  if (px.size() < 100 || !(vmax > 0)) return std::nullopt;
  Vec3 g = Vec3::Zero();
  for (int round = 0; round < 4; ++round) {
    Eigen::Matrix4d A = Eigen::Matrix4d::Zero();
    Eigen::Vector4d rhs = Eigen::Vector4d::Zero();
    int n = 0;
    for (const Px& p : px) {
      const bool lit = round == 0 ? p.v > 0.3 * vmax : g.dot(p.n) > 0.15 * g.norm();
      if (!lit) continue;
      const Eigen::Vector4d a(p.n.x(), p.n.y(), p.n.z(), 1.0);
      A += a * a.transpose();
      rhs += a * p.v;
      ++n;
    }
    if (n < 50) return std::nullopt;
    const Eigen::Vector4d sol = A.ldlt().solve(rhs);
    g = sol.head<3>();
    if (!g.allFinite() || !(g.norm() > 0)) return std::nullopt;
  }
  const Vec3 v = (-centre).normalized();
  return g.dot(v) * std::sqrt(2.0 / rho_px);
}

// ---- cone fit ----


// The cone's axis is d0 + a e1 + b e2 (normalised) around a start axis d0.
struct Cone {
  Vec3 d = Vec3::UnitZ();
  double alpha = 0;
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();  // of (a, b, alpha)
  Vec3 d0 = Vec3::UnitZ(), e1 = Vec3::UnitX(), e2 = Vec3::UnitY();
  double a = 0, b = 0;
  bool ok = false;
};

void tangent_basis(const Vec3& d, Vec3* e1, Vec3* e2) {
  *e1 = d.unitOrthogonal();
  *e2 = d.cross(*e1);
}

Cone fit_cone(const std::vector<Vec3>& rays, const std::vector<double>& weights, const Vec3& d_start,
              double alpha_start) {
  Cone c;
  const Vec3 d0 = d_start.normalized();
  c.d0 = d0;
  tangent_basis(d0, &c.e1, &c.e2);
  double ab[2] = {0.0, 0.0};
  double alpha = alpha_start;
  ceres::Problem problem;
  for (std::size_t i = 0; i < rays.size(); ++i)
    problem.AddResidualBlock(
        SilhouetteConeCost::Create({rays[i], d0, c.e1, c.e2, weights[i]}),
        new ceres::HuberLoss(3.0), ab, &alpha);
  const ceres::Solver::Summary summary = solve_dense(problem, 100, 1e-14, 1e-14);
  if (summary.termination_type == ceres::FAILURE) return c;
  ceres::Covariance::Options co;
  ceres::Covariance cov(co);
  std::vector<std::pair<const double*, const double*>> blocks = {{ab, ab}, {ab, &alpha}, {&alpha, &alpha}};
  if (cov.Compute(blocks, &problem)) {
    double cab[4], caa[2], cal[1];
    cov.GetCovarianceBlock(ab, ab, cab);
    cov.GetCovarianceBlock(ab, &alpha, caa);
    cov.GetCovarianceBlock(&alpha, &alpha, cal);
    c.cov << cab[0], cab[1], caa[0], cab[2], cab[3], caa[1], caa[0], caa[1], cal[0];
    // Scale by the reduced chi-square: the edge standard deviations are only estimates.
    const double dof = std::max<double>(1.0, static_cast<double>(rays.size()) - 3.0);
    c.cov *= std::max(1.0, 2.0 * summary.final_cost / dof);
  }
  c.a = ab[0];
  c.b = ab[1];
  c.d = (d0 + ab[0] * c.e1 + ab[1] * c.e2).normalized();
  c.alpha = alpha;
  c.ok = true;
  return c;
}

Vec3 cone_centre(const Vec3& d0, const Vec3& e1, const Vec3& e2, double a, double b, double alpha, double radius) {
  return (d0 + a * e1 + b * e2).normalized() * (radius / std::sin(alpha));
}

}  // namespace

std::optional<Vec3> intersect_sphere(const Vec3& dir, const Vec3& centre, double radius) {
  const Vec3 d = dir.normalized();
  const double b = d.dot(centre);
  const double c = centre.squaredNorm() - radius * radius;
  const double disc = b * b - c;
  if (disc < 0) return std::nullopt;
  const double t = b - std::sqrt(disc);
  if (t <= 0) return std::nullopt;
  return d * t;
}

std::vector<Vec2> silhouette_points(const CameraModel& camera, const Vec3& centre_cam, double radius, int n) {
  const double D = centre_cam.norm();
  const Vec3 d = centre_cam / D;
  const double alpha = std::asin(std::min(1.0, radius / D));
  Vec3 e1, e2;
  tangent_basis(d, &e1, &e2);
  std::vector<Vec2> out;
  for (int i = 0; i < n; ++i) {
    const double t = 2.0 * kPi * i / n;
    const Vec3 r = std::cos(alpha) * d + std::sin(alpha) * (std::cos(t) * e1 + std::sin(t) * e2);
    out.push_back(camera.project(r));
  }
  return out;
}

SphereFit fit_sphere(const std::vector<SphereImage>& images, const CameraModel& camera, const SphereOptions& options) {
  options.check();
  if (images.empty()) throw UsageError("sphere: no images given");
  SphereFit fit;
  fit.radius_m = options.radius_m;
  const double f = 0.5 * (camera.fx() + camera.fy());

  // Pass 1: coarse circle per image, edges around it, cone fit.
  std::vector<EdgePoint> edges;
  std::vector<Vec2> centres;
  std::vector<double> radii;
  for (std::size_t i = 0; i < images.size(); ++i) {
    const ImageF& img = images[i].pixels;
    if (img.channels() != 1) throw DataError("sphere: image '" + images[i].name + "' must have 1 channel");
    if (img.width() != camera.width_px || img.height() != camera.height_px)
      throw DataError(fmt::format("sphere: image '{}' is {}x{}, the camera {}x{}", images[i].name, img.width(),
                                  img.height(), camera.width_px, camera.height_px));
    Vec2 c = options.approx_centre_px;
    double r = options.approx_radius_px;
    if (!(r > 0) && !coarse_circle(img, &c, &r))
      throw CalibrationError("sphere: no bright sphere found in '" + images[i].name + "' (is the LED on, the exposure long enough?)");
    centres.push_back(c);
    radii.push_back(r);
    auto more = find_edges(img, c, [r](double) { return r; }, r, options, static_cast<int>(i), std::nullopt);
    edges.insert(edges.end(), more.begin(), more.end());
  }

  auto solve = [&](std::vector<EdgePoint>& pts, Cone* cone) {
    // Start: the mean ray and the mean angle to it.
    for (int round = 0; round < 3; ++round) {
      std::vector<Vec3> rays;
      std::vector<double> w;
      std::vector<std::size_t> idx;
      for (std::size_t i = 0; i < pts.size(); ++i) {
        if (round > 0 && !pts[i].used) continue;
        rays.push_back(camera.ray(pts[i].px));
        w.push_back(f / pts[i].std_px);
        idx.push_back(i);
      }
      if (rays.size() < 12) return false;
      Vec3 d_start = round == 0 ? Vec3::Zero() : cone->d;
      double alpha_start = round == 0 ? 0.0 : cone->alpha;
      if (round == 0) {
        for (const Vec3& r : rays) d_start += r;
        d_start.normalize();
        for (const Vec3& r : rays) alpha_start += angle_between(r, d_start) / rays.size();
      }
      *cone = fit_cone(rays, w, d_start, alpha_start);
      if (!cone->ok) return false;
      // Residuals in px (+ outside) and robust outlier rejection.
      std::vector<double> absres;
      for (std::size_t i = 0; i < pts.size(); ++i) {
        pts[i].residual_px = (angle_between(camera.ray(pts[i].px), cone->d) - cone->alpha) * f;
        absres.push_back(std::abs(pts[i].residual_px));
      }
      const double robust = std::max(kMadToSigma * upper_median(absres), 0.01);
      for (auto& p : pts) p.used = std::abs(p.residual_px) <= options.outlier_sigmas * robust;
    }
    return true;
  };

  Cone cone;
  for (auto& e : edges) e.used = true;
  if (!solve(edges, &cone))
    throw CalibrationError(fmt::format("sphere: only {} silhouette edge points found (need >= 12): the sphere must "
                                       "stand out from the background along its outline",
                                       edges.size()));

  // Pass 2: sectors around the fitted silhouette (expected edge radius per angle).
  const Vec3 centre1 = cone.d * (options.radius_m / std::sin(cone.alpha));
  std::vector<Vec2> sil = silhouette_points(camera, centre1, options.radius_m, 2048);
  Vec2 sc = Vec2::Zero();
  for (const Vec2& p : sil) sc += p / static_cast<double>(sil.size());
  std::vector<std::pair<double, double>> polar;  // angle, radius
  double rmax = 0;
  for (const Vec2& p : sil) {
    polar.emplace_back(std::atan2(p.y() - sc.y(), p.x() - sc.x()), (p - sc).norm());
    rmax = std::max(rmax, (p - sc).norm());
  }
  std::sort(polar.begin(), polar.end());
  auto r_of = [&polar](double phi) {
    auto it = std::lower_bound(polar.begin(), polar.end(), std::make_pair(phi, -1.0));
    const auto& hi = it == polar.end() ? polar.front() : *it;
    const auto& lo = it == polar.begin() ? polar.back() : *(it - 1);
    double span = hi.first - lo.first;
    if (span <= 0) span += 2.0 * kPi;
    double t = phi - lo.first;
    if (t < 0) t += 2.0 * kPi;
    return lo.second + (hi.second - lo.second) * std::clamp(t / span, 0.0, 1.0);
  };
  edges.clear();
  const double rho_px = f * std::tan(cone.alpha);
  for (std::size_t i = 0; i < images.size(); ++i) {
    std::optional<double> onset;
    if (options.limb_onset_from_shading) onset = limb_onset(images[i].pixels, camera, centre1, options.radius_m, rho_px);
    auto more = find_edges(images[i].pixels, sc, r_of, rmax, options, static_cast<int>(i), onset);
    edges.insert(edges.end(), more.begin(), more.end());
  }
  for (auto& e : edges) e.used = true;
  if (!solve(edges, &cone)) throw CalibrationError("sphere: the refined silhouette lost its edge points");

  // Results.
  fit.axis = cone.d;
  fit.half_angle_rad = cone.alpha;
  fit.centre_cam_m = cone.d * (options.radius_m / std::sin(cone.alpha));
  {
    // Covariance of the centre: numeric Jacobian of (a, b, alpha) -> centre at the solution.
    Eigen::Matrix3d J;
    const double h = 1e-7;
    for (int k = 0; k < 3; ++k) {
      double dp[3] = {0, 0, 0};
      dp[k] = h;
      Vec3 plus = cone_centre(cone.d0, cone.e1, cone.e2, cone.a + dp[0], cone.b + dp[1], cone.alpha + dp[2], options.radius_m);
      dp[k] = -h;
      Vec3 minus = cone_centre(cone.d0, cone.e1, cone.e2, cone.a + dp[0], cone.b + dp[1], cone.alpha + dp[2], options.radius_m);
      J.col(k) = (plus - minus) / (2 * h);
    }
    fit.centre_cov_m2 = J * cone.cov * J.transpose();
  }
  std::vector<double> sig_strong, sig_all;
  double ss = 0;
  for (const auto& e : edges) {
    ++fit.edges_total;
    if (!e.used) continue;
    ++fit.edges_used;
    ss += e.residual_px * e.residual_px;
    fit.max_px = std::max(fit.max_px, std::abs(e.residual_px));
    sig_all.push_back(e.sigma_px);
  }
  fit.rms_px = std::sqrt(ss / std::max(1, fit.edges_used));
  // Focus: the blur of edges that are steps (the inside value at the edge carries most of
  // the contrast), else of all edges.
  double max_step = 0;
  for (const auto& e : edges)
    if (e.used) max_step = std::max(max_step, std::abs(e.step));
  for (const auto& e : edges)
    if (e.used && std::abs(e.step) >= 0.5 * max_step) sig_strong.push_back(e.sigma_px);
  fit.edge_sigma_px = upper_median(sig_strong.size() >= 8 ? sig_strong : sig_all);
  {
    std::vector<double> psf_strong, psf_all;
    for (const auto& e : edges) {
      if (!e.used) continue;
      psf_all.push_back(e.psf_sigma_px);
      if (std::abs(e.step) >= 0.5 * max_step) psf_strong.push_back(e.psf_sigma_px);
    }
    fit.psf_sigma_px = upper_median(psf_strong.size() >= 8 ? psf_strong : psf_all);
  }
  if (options.image_blur_var_px2 > 0) {  // the camera's blur, without the processing's
    fit.edge_sigma_px = std::sqrt(std::max(fit.edge_sigma_px * fit.edge_sigma_px - options.image_blur_var_px2, 0.0));
    fit.psf_sigma_px = std::sqrt(std::max(fit.psf_sigma_px * fit.psf_sigma_px - options.image_blur_var_px2, 0.0));
  }
  fit.edge_width_px = 2.5631 * fit.edge_sigma_px;
  // Coverage: fraction of 5-degree bins around the outline with a used point.
  std::vector<bool> bins(72, false);
  for (const auto& e : edges)
    if (e.used) bins[static_cast<std::size_t>(std::clamp(static_cast<int>((e.angle_rad + kPi) / (2 * kPi) * 72), 0, 71))] = true;
  fit.coverage = static_cast<double>(std::count(bins.begin(), bins.end(), true)) / 72.0;

  // Free ellipse in the undistorted image (shape diagnostic).
  std::vector<cv::Point2f> und;
  for (const auto& e : edges) {
    if (!e.used) continue;
    Vec2 n = camera.normalized(e.px);
    und.emplace_back(static_cast<float>(camera.fx() * n.x() + camera.cx()), static_cast<float>(camera.fy() * n.y() + camera.cy()));
  }
  if (und.size() >= 6) {
    cv::RotatedRect el = cv::fitEllipseDirect(und);
    const double a = 0.5 * el.size.width, b = 0.5 * el.size.height, th = deg_to_rad(el.angle);
    fit.ellipse_centre_px = Vec2(el.center.x, el.center.y);
    fit.ellipse_axes_px = Vec2(a, b);
    fit.ellipse_angle_deg = el.angle;
    double es = 0;
    for (const auto& p : und) {
      const double dx = p.x - el.center.x, dy = p.y - el.center.y;
      const double x = std::cos(th) * dx + std::sin(th) * dy, y = -std::sin(th) * dx + std::cos(th) * dy;
      const double k = std::sqrt(x * x / (a * a) + y * y / (b * b));
      const double gx = x / (a * a * k), gy = y / (b * b * k);
      const double d = (k - 1.0) / std::hypot(gx, gy);
      es += d * d;
    }
    fit.ellipse_rms_px = std::sqrt(es / und.size());
  }
  fit.edges = std::move(edges);
  fit.provenance = Provenance::make("sphere", {});
  return fit;
}

Vec3 SphereFit::centre_std_m() const {
  return Vec3(std::sqrt(std::max(0.0, centre_cov_m2(0, 0))), std::sqrt(std::max(0.0, centre_cov_m2(1, 1))),
              std::sqrt(std::max(0.0, centre_cov_m2(2, 2))));
}

Json SphereFit::to_json() const {
  Json j = {{"radius_m", radius_m},
          {"centre_cam_m", vector3_to_json(centre_cam_m)},
          {"centre_std_m", vector3_to_json(centre_std_m())},
          {"centre_cov_m2", matrix_to_json(centre_cov_m2)},
          {"axis", vector3_to_json(axis)},
          {"half_angle_deg", rad_to_deg(half_angle_rad)},
          {"rms_px", rms_px},
          {"max_px", max_px},
          {"ellipse",
           {{"rms_px", ellipse_rms_px},
            {"centre_px", Json::array({ellipse_centre_px.x(), ellipse_centre_px.y()})},
            {"semi_axes_px", Json::array({ellipse_axes_px.x(), ellipse_axes_px.y()})},
            {"angle_deg", ellipse_angle_deg}}},
          {"edges_used", edges_used},
          {"edges_total", edges_total},
          {"coverage", coverage},
          {"provenance", provenance.to_json()}};
  // Figures a fit could not measure (no strong edges) are left out, not written as null.
  if (std::isfinite(edge_sigma_px)) j["edge_sigma_px"] = edge_sigma_px;
  if (std::isfinite(edge_width_px)) j["edge_width_px"] = edge_width_px;
  if (std::isfinite(psf_sigma_px)) j["psf_sigma_px"] = psf_sigma_px;
  return j;
}

SphereFit SphereFit::from_json(const Json& j, const std::string& where) {
  SphereFit s;
  s.radius_m = json_get<double>(j, "radius_m", where);
  if (!j.contains("centre_cam_m")) throw DataError(where + ": missing key 'centre_cam_m'");
  s.centre_cam_m = vector3_from_json(j.at("centre_cam_m"), where + ": key 'centre_cam_m'");
  if (j.contains("centre_cov_m2")) {
    // Found fuzzing: a matrix of another shape assigned to the 3 x 3 covariance.
    const Eigen::MatrixXd cov = matrix_from_json(j.at("centre_cov_m2"), where + ": key 'centre_cov_m2'");
    if (cov.rows() != 3 || cov.cols() != 3)
      throw DataError(where + ": key 'centre_cov_m2': expected a 3 x 3 matrix, got " + std::to_string(cov.rows()) +
                      " x " + std::to_string(cov.cols()));
    s.centre_cov_m2 = cov;
  }
  s.axis = s.centre_cam_m.normalized();
  s.half_angle_rad = std::asin(std::min(1.0, s.radius_m / s.centre_cam_m.norm()));
  s.rms_px = json_get<double>(j, "rms_px", where);
  s.max_px = json_get_or<double>(j, "max_px", 0.0, where);
  if (j.contains("ellipse")) s.ellipse_rms_px = json_get_or<double>(j.at("ellipse"), "rms_px", 0.0, where);
  // Absent, or null as earlier versions wrote an unmeasured figure: NaN.
  const auto optional_figure = [&](const char* key) {
    const auto it = j.find(key);
    return it == j.end() || it->is_null() ? std::numeric_limits<double>::quiet_NaN() : json_get<double>(j, key, where);
  };
  s.edge_sigma_px = optional_figure("edge_sigma_px");
  s.edge_width_px = optional_figure("edge_width_px");
  s.psf_sigma_px = optional_figure("psf_sigma_px");
  s.edges_used = json_get_or<int>(j, "edges_used", 0, where);
  s.edges_total = json_get_or<int>(j, "edges_total", 0, where);
  s.coverage = json_get_or<double>(j, "coverage", 0.0, where);
  if (!(s.radius_m > 0) || !(s.centre_cam_m.z() > s.radius_m))
    throw DataError(where + ": the sphere must lie in front of the camera (centre z > radius)");
  if (j.contains("provenance")) s.provenance = Provenance::from_json(j.at("provenance"), where);
  return s;
}

void SphereFit::save(const std::filesystem::path& path) const { write_json_file(path, to_json()); }

SphereFit SphereFit::load(const std::filesystem::path& path) { return from_json(read_json_file(path), path.string()); }

}  // namespace paintlab::calib
