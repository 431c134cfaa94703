#pragma once
// The cost functions of the calibration's solves, named and public so that their values and
// derivatives are checked against independent computations and central differences
// (tests/unit/calibration/cost_functions_test.cpp): the chessboard corner (hand-written
// Jacobian), the corner reprojection of the intrinsics bundle adjustment, the silhouette cone
// of the sphere fit and the LED circle of the light fit (automatic differentiation).
#include <ceres/autodiff_cost_function.h>
#include <ceres/cost_function.h>
#include <ceres/rotation.h>

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include "paintlab/calibration/sphere.h"
#include "paintlab/core/geometry.h"

namespace paintlab::calib {

// Pixel values of a square window of an image, centre (cx, cy) integer, half size h.
struct SaddleWindow {
  int cx = 0, cy = 0, h = 0;
  std::vector<double> values;  // row-major (2h+1)^2
};

// The checker model around one chessboard corner. Parameters (coordinates relative to the
// window centre): x, y, theta1, theta2, log sigma, a, b, c, gx, gy, bx, by:
//   I = a + gx du + gy dv + (b + bx du + by dv) P + c P^2,
//   P = erf(d1 / (sqrt2 sigma)) erf(d2 / (sqrt2 sigma))
// with (du, dv) = (u - x, v - y) and d_i the signed distance from the edge through (x, y)
// at angle theta_i. Illumination that varies over the window scales the contrast too: du P
// is odd about the corner, so without bx, by the fit would absorb it as a corner shift.
// sigma includes the pixel's box integration (sigma^2 = optics^2 + 1/12 for a Gaussian
// PSF). Modelling the box exactly (erf averaged over the pixel square) was measured to
// change corner positions by < 0.001 px on synthetic boards, so the cheaper form is used.
// The Jacobian is analytic: about 4x faster than automatic differentiation with 12-wide
// jets, and the corner fits dominate the cost of a calibration.
class SaddleCost final : public ceres::CostFunction {
 public:
  static constexpr int kParams = 12;
  explicit SaddleCost(const SaddleWindow* window);
  static ceres::CostFunction* Create(const SaddleWindow* window);
  bool Evaluate(double const* const* parameters, double* r, double** jacobians) const override;

 private:
  const SaddleWindow* w_;
};

// limb_profile (sphere.h) for plain numbers and for Ceres' jets, with its own derivative.
inline double limb_h(double x) { return limb_profile(x); }
template <class T, int N>
ceres::Jet<T, N> limb_h(const ceres::Jet<T, N>& x) {
  double d = 0.0;
  const double v = limb_profile(x.a, &d);
  return ceres::Jet<T, N>(v, d * x.v);
}

// A pixel integrates the image over its square, which seen along a profile at angle phi is a
// box of width |cos phi| convolved with one of width |sin phi|: 3 x 3 Gauss-Legendre nodes
// along the profile (offsets in px, weights summing to 1). The default: one node, no box.
struct PixelBox {
  int n = 1;
  double offset[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0};
  double weight[9] = {1, 0, 0, 0, 0, 0, 0, 0, 0};
  static PixelBox along(double phi) {
    PixelBox b;
    const double g[3] = {-std::sqrt(0.6), 0.0, std::sqrt(0.6)}, w[3] = {5.0 / 18.0, 8.0 / 18.0, 5.0 / 18.0};
    const double a = 0.5 * std::abs(std::cos(phi)), c = 0.5 * std::abs(std::sin(phi));
    b.n = 9;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        b.offset[3 * i + j] = a * g[i] + c * g[j];
        b.weight[3 * i + j] = w[i] * w[j];
      }
    return b;
  }
};

// The radial profile of one sector of the sphere's silhouette: values v at radii r (px);
// t = e - r is the distance inside the edge and
//   F(t) = b + (c0 - b) Phi(t/s) + c1 sqrt(s) H(t/s) + c2 s (x Phi(x) + phi(x)),  x = t/s,
// H the limb profile (a sqrt onset blurred by a Gaussian of width s), averaged over the
// pixel's box. Parameters: e, log s, b, c0, c1, c2. Residuals: F - v, one per sample.
struct EdgeProfileCost {
  const std::vector<double>* r;
  const std::vector<double>* v;
  PixelBox box;

  template <class T>
  bool operator()(const T* p, T* res) const {
    using std::erf;
    using std::exp;
    using std::sqrt;
    const T s = exp(p[1]);
    const T sq = sqrt(s);
    for (std::size_t i = 0; i < r->size(); ++i) {
      T acc(0.0);
      for (int k = 0; k < box.n; ++k) {
        const T x = (p[0] - T((*r)[i]) + T(box.offset[k])) / s;
        const T Phi = T(0.5) * (T(1.0) + erf(x * T(M_SQRT1_2)));
        const T phi = exp(T(-0.5) * x * x) * T(1.0 / std::sqrt(2.0 * std::numbers::pi));
        acc += T(box.weight[k]) * ((p[3] - p[2]) * Phi + p[4] * sq * limb_h(x) + p[5] * s * (x * Phi + phi));
      }
      res[i] = p[2] + acc - T((*v)[i]);
    }
    return true;
  }
  // `r` and `v` (same length) must outlive the cost function.
  static ceres::CostFunction* Create(const std::vector<double>* r, const std::vector<double>* v, const PixelBox& box) {
    return new ceres::AutoDiffCostFunction<EdgeProfileCost, ceres::DYNAMIC, 6>(new EdgeProfileCost{r, v, box},
                                                                              static_cast<int>(r->size()));
  }
};

// One pixel of a highlight window as the light fit sees it (camera frame).
struct SpherePixel {
  bool on_sphere = false;
  bool data = false;  // compared with the model (on the sphere, away from the silhouette)
  double value = 0;
  Vec3 normal = Vec3::Zero();
  Vec3 wo = Vec3::Zero();  // towards the camera
  Vec3 point = Vec3::Zero();
};

// A highlight on a glossy sphere: a Beckmann lobe A exp(-tan^2(theta_h) / m^2) / (n . wo) +
// background around the specular normal n_s = normalize(n0 + u e1 + v e2) (the LED at
// `led_distance` along the mirror direction there), on a square grid of `side` x `side`
// pixels, blurred by a separable Gaussian (taps exp(-d^2 / 2 sigma^2) at whole pixels,
// normalised; radius kr, 0: no blur). Parameter blocks: (u, v), log m, A, background,
// log sigma. Residuals: model - value at the grid's data pixels, in grid order.
struct HighlightCost {
  const std::vector<SpherePixel>* grid;
  int side;
  int kr;  // kernel radius (px); 0: no blur
  Vec3 centre, n0, e1, e2;
  double radius, led_distance;
  template <class T>
  bool operator()(const T* uv, const T* logm, const T* amp, const T* bg, const T* logblur, T* res) const {
    using std::exp;
    using std::sqrt;
    std::vector<T> kernel;
    if (kr > 0) {
      const T inv2s2 = T(0.5) * exp(T(-2.0) * logblur[0]);
      T sum(0.0);
      for (int d = -kr; d <= kr; ++d) {
        kernel.push_back(exp(-T(static_cast<double>(d * d)) * inv2s2));
        sum += kernel.back();
      }
      for (T& w : kernel) w /= sum;
    }
    Eigen::Matrix<T, 3, 1> ns = n0.cast<T>() + uv[0] * e1.cast<T>() + uv[1] * e2.cast<T>();
    ns /= sqrt(ns.squaredNorm());
    const Eigen::Matrix<T, 3, 1> X = centre.cast<T>() + T(radius) * ns;
    Eigen::Matrix<T, 3, 1> v = -X;
    v /= sqrt(v.squaredNorm());
    const Eigen::Matrix<T, 3, 1> r = T(2.0) * ns.dot(v) * ns - v;
    const Eigen::Matrix<T, 3, 1> L = X + T(led_distance) * r;
    const T m2 = exp(T(2.0) * logm[0]);
    const std::size_t n = grid->size();
    std::vector<T> model(n), tmp(n);
    for (std::size_t i = 0; i < n; ++i) {
      const SpherePixel& p = (*grid)[i];
      if (!p.on_sphere) {
        model[i] = bg[0];
        continue;
      }
      Eigen::Matrix<T, 3, 1> wi = L - p.point.cast<T>();
      wi /= sqrt(wi.squaredNorm());
      Eigen::Matrix<T, 3, 1> h = wi + p.wo.cast<T>();
      h /= sqrt(h.squaredNorm());
      const T c = h.dot(p.normal.cast<T>());
      const T c2 = c * c;
      const T tan2 = (T(1.0) - c2) / c2;
      model[i] = amp[0] * exp(-tan2 / m2) / T(p.normal.dot(p.wo)) + bg[0];
    }
    const int k = kr;
    if (k > 0) {
      for (int y = 0; y < side; ++y)
        for (int x = 0; x < side; ++x) {
          T s(0.0);
          for (int d = -k; d <= k; ++d) s += kernel[static_cast<std::size_t>(d + k)] * model[static_cast<std::size_t>(y * side + std::clamp(x + d, 0, side - 1))];
          tmp[static_cast<std::size_t>(y * side + x)] = s;
        }
      for (int y = 0; y < side; ++y)
        for (int x = 0; x < side; ++x) {
          T s(0.0);
          for (int d = -k; d <= k; ++d) s += kernel[static_cast<std::size_t>(d + k)] * tmp[static_cast<std::size_t>(std::clamp(y + d, 0, side - 1) * side + x)];
          model[static_cast<std::size_t>(y * side + x)] = s;
        }
    }
    std::size_t j = 0;
    for (std::size_t i = 0; i < n; ++i)
      if ((*grid)[i].data) res[j++] = model[i] - T((*grid)[i].value);
    return true;
  }
  // `grid` must outlive the cost function; `residuals`: its data pixels.
  static ceres::CostFunction* Create(const HighlightCost& c, int residuals) {
    return new ceres::AutoDiffCostFunction<HighlightCost, ceres::DYNAMIC, 2, 1, 1, 1, 1>(new HighlightCost(c), residuals);
  }
};

// Reprojection of one chessboard corner (X, Y, 0) in board coordinates, observed at (u, v)
// px, with OpenCV's camera model. Parameter blocks: the intrinsics (fx, fy, cx, cy, k1, k2,
// p1, p2, k3) and the view's pose (angle-axis rotation, translation; board -> camera).
// Residual: projected minus observed (px).
struct ReprojectionCost {
  double X, Y, u, v;

  template <class T>
  bool operator()(const T* in, const T* pose, T* r) const {
    const T p[3] = {T(X), T(Y), T(0.0)};
    T q[3];
    ceres::AngleAxisRotatePoint(pose, p, q);
    q[0] += pose[3];
    q[1] += pose[4];
    q[2] += pose[5];
    const T x = q[0] / q[2], y = q[1] / q[2];
    const T r2 = x * x + y * y;
    const T radial = T(1.0) + r2 * (in[4] + r2 * (in[5] + r2 * in[8]));
    const T xd = x * radial + T(2.0) * in[6] * x * y + in[7] * (r2 + T(2.0) * x * x);
    const T yd = y * radial + in[6] * (r2 + T(2.0) * y * y) + T(2.0) * in[7] * x * y;
    r[0] = in[0] * xd + in[2] - T(u);
    r[1] = in[1] * yd + in[3] - T(v);
    return true;
  }
  static ceres::CostFunction* Create(double X, double Y, double u, double v) {
    return new ceres::AutoDiffCostFunction<ReprojectionCost, 2, 9, 6>(new ReprojectionCost{X, Y, u, v});
  }
};

// One silhouette ray on the cone of rays that graze a sphere: the cone's axis is
// d0 + a e1 + b e2 (normalised; e1, e2 span the plane normal to d0), its half angle alpha.
// Parameter blocks: (a, b) and (alpha) in rad. Residual: (angle between the ray and the
// axis - alpha) x weight (the weight turns radians into standard deviations).
struct SilhouetteConeCost {
  Vec3 ray;  // unit ray of a silhouette edge point (camera frame)
  Vec3 d0, e1, e2;
  double weight;  // focal length / edge std (px per rad / px)

  template <class T>
  bool operator()(const T* ab, const T* alpha, T* res) const {
    using std::atan2;
    using std::sqrt;
    const T dx = T(d0.x()) + ab[0] * T(e1.x()) + ab[1] * T(e2.x());
    const T dy = T(d0.y()) + ab[0] * T(e1.y()) + ab[1] * T(e2.y());
    const T dz = T(d0.z()) + ab[0] * T(e1.z()) + ab[1] * T(e2.z());
    const T cx = T(ray.y()) * dz - T(ray.z()) * dy;
    const T cy = T(ray.z()) * dx - T(ray.x()) * dz;
    const T cz = T(ray.x()) * dy - T(ray.y()) * dx;
    const T dot = T(ray.x()) * dx + T(ray.y()) * dy + T(ray.z()) * dz;
    const T angle = atan2(sqrt(cx * cx + cy * cy + cz * cz), dot);  // stable near 0 and pi
    res[0] = (angle - alpha[0]) * T(weight);
    return true;
  }
  static ceres::CostFunction* Create(const SilhouetteConeCost& c) {
    return new ceres::AutoDiffCostFunction<SilhouetteConeCost, 1, 2, 1>(new SilhouetteConeCost(c));
  }
};

// One highlight against the LED's circle around the table axis. The axis direction is
// a0 + a e1 + b e2 (normalised), through `centre` offset by u e1 + v e2 (projected onto the
// plane normal to the axis); the LED sits at radius R, height h above that point, at the
// table angle plus `zero`. Parameter blocks: (a, b), (u, v) in m, (R, h, zero) in m, m, rad.
// Residual: the direction from the highlight's sphere point to the LED, in the tangent basis
// (t1, t2) of the observed mirror direction `dir` (0 when they agree; about the angle in rad).
struct LedCircleCost {
  Vec3 point, dir, t1, t2;  // sphere point of the highlight, observed unit mirror direction, its tangent basis
  double angle_rad;         // table angle
  Vec3 centre, a0, e1, e2;  // sphere centre, start axis and its normal plane's basis (camera frame)

  template <class T>
  bool operator()(const T* ab, const T* uv, const T* rhz, T* res) const {
    using std::cos;
    using std::sin;
    using std::sqrt;
    Eigen::Matrix<T, 3, 1> z = a0.cast<T>() + ab[0] * e1.cast<T>() + ab[1] * e2.cast<T>();
    z /= sqrt(z.squaredNorm());
    Eigen::Matrix<T, 3, 1> off = uv[0] * e1.cast<T>() + uv[1] * e2.cast<T>();
    off -= off.dot(z) * z;
    const Eigen::Matrix<T, 3, 1> O = centre.cast<T>() + off;
    Eigen::Matrix<T, 3, 1> x = -O - (-O).dot(z) * z;
    x /= sqrt(x.squaredNorm());
    const Eigen::Matrix<T, 3, 1> y = z.cross(x);
    const T a = T(angle_rad) + rhz[2];
    const Eigen::Matrix<T, 3, 1> L = O + rhz[0] * (cos(a) * x + sin(a) * y) + rhz[1] * z;
    Eigen::Matrix<T, 3, 1> w = L - point.cast<T>();
    w /= sqrt(w.squaredNorm());
    res[0] = w.dot(t1.cast<T>());
    res[1] = w.dot(t2.cast<T>());
    return true;
  }
  static ceres::CostFunction* Create(const LedCircleCost& c) {
    return new ceres::AutoDiffCostFunction<LedCircleCost, 2, 2, 2, 3>(new LedCircleCost(c));
  }
};

}  // namespace paintlab::calib
