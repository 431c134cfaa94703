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
#include <cmath>
#include <vector>

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
