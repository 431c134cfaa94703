// The chessboard corner model's hand-written Jacobian against central differences
// (tests/support/jacobian_check.h): a wrong derivative would still converge, to a biased corner.
#include "paintlab/calibration/cost_functions.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <array>
#include <cmath>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "jacobian_check.h"
#include "paintlab/calibration/camera_model.h"
#include "test_util.h"

namespace paintlab::calib {
namespace {

TEST(SaddleCost, JacobianMatchesCentralDifferences) {
  // A window of noise (the Jacobian does not depend on the pixel values) and a corner off
  // the pixel grid with edges neither axis-aligned nor orthogonal, and every gradient and
  // contrast term non-zero, so each of the 12 columns is exercised.
  SaddleWindow w;
  w.h = 5;
  std::mt19937_64 rng(test::seed());
  std::uniform_real_distribution<double> u(0.1, 0.9);
  for (int k = 0; k < (2 * w.h + 1) * (2 * w.h + 1); ++k) w.values.push_back(u(rng));
  const std::unique_ptr<ceres::CostFunction> cost(SaddleCost::Create(&w));
  for (const double log_sigma : {std::log(0.6), std::log(1.5)}) {
    SCOPED_TRACE("sigma " + std::to_string(std::exp(log_sigma)));
    std::array<double, SaddleCost::kParams> p = {0.31, -0.22, 0.12, 1.71, log_sigma, 0.5,
                                                 0.4,  0.03,  0.01, -0.012, 0.006, 0.004};
    test::expect_jacobians_match_central_differences(*cost, {p.data()}, 1e-7);
  }
}


TEST(ReprojectionCost, MatchesTheCameraModelAndItsJacobianCentralDifferences) {
  CameraModel cam;
  cam.K << 2400.0, 0.0, 690.0, 0.0, 2410.0, 505.0, 0.0, 0.0, 1.0;
  // Tangential terms larger than a real lens's: the central differences step with each
  // parameter (1e-6 of it), and a step of 1e-9 would drown in the rounding of the pixel values.
  cam.dist = {-0.12, 0.35, 0.012, -0.008, -0.4};
  const Vec3 rot(0.21, -0.34, 0.05);  // angle-axis, board -> camera
  const Vec3 t(-0.03, 0.02, 0.9);
  const Vec3 X(0.25, 0.18, 0.0);  // a board corner far off the axis: every distortion term counts
  const Vec3 p_cam = Eigen::AngleAxisd(rot.norm(), rot.normalized()) * X + t;
  const Vec2 px = cam.project(p_cam);
  std::array<double, 9> in = {cam.fx(), cam.fy(), cam.cx(), cam.cy(), cam.dist[0], cam.dist[1], cam.dist[2],
                              cam.dist[3], cam.dist[4]};
  std::array<double, 6> pose = {rot.x(), rot.y(), rot.z(), t.x(), t.y(), t.z()};
  // Observed 0.3 px right of and 0.2 px above the projection: the residual says so.
  const std::unique_ptr<ceres::CostFunction> cost(ReprojectionCost::Create(X.x(), X.y(), px.x() + 0.3, px.y() - 0.2));
  double r[2];
  const double* blocks[2] = {in.data(), pose.data()};
  ASSERT_TRUE(cost->Evaluate(blocks, r, nullptr));
  EXPECT_NEAR(r[0], -0.3, 1e-8);
  EXPECT_NEAR(r[1], 0.2, 1e-8);
  test::expect_jacobians_match_central_differences(*cost, {in.data(), pose.data()}, 1e-6);
}

TEST(SilhouetteConeCost, ResidualIsTheAngleOffTheConeInStdsAndItsJacobianCentralDifferences) {
  const Vec3 d0 = Vec3::UnitZ(), e1 = Vec3::UnitX(), e2 = Vec3::UnitY();
  const Vec3 ray = Vec3(0.06, 0.08, 1.0).normalized();  // 0.0997 rad off the z axis
  const double off = std::atan2(std::hypot(0.06, 0.08), 1.0);
  const std::unique_ptr<ceres::CostFunction> cost(SilhouetteConeCost::Create({ray, d0, e1, e2, 2000.0}));
  double ab[2] = {0.0, 0.0}, alpha = 0.08, r = 0.0;
  const double* blocks[2] = {ab, &alpha};
  ASSERT_TRUE(cost->Evaluate(blocks, &r, nullptr));
  EXPECT_NEAR(r, (off - 0.08) * 2000.0, 1e-9);
  // The axis tilted onto the ray: the ray is 0 rad off the axis.
  ab[0] = 0.06;
  ab[1] = 0.08;
  ASSERT_TRUE(cost->Evaluate(blocks, &r, nullptr));
  EXPECT_NEAR(r, -0.08 * 2000.0, 1e-6);
  ab[0] = 0.02;
  ab[1] = -0.01;
  test::expect_jacobians_match_central_differences(*cost, {ab, &alpha}, 1e-6);
}

TEST(LedCircleCost, ZeroWhereTheLedIsAndItsJacobianCentralDifferences) {
  // A sphere 1.2 m in front of the camera, the table axis roughly up (-y in the camera frame),
  // the LED on a 0.6 m arm 0.05 m above the sphere's centre, seen at table angle 40 deg.
  const Vec3 centre(0.01, -0.02, 1.2);
  const Vec3 a0 = Vec3(0.02, -1.0, -0.05).normalized();
  const Vec3 e1 = a0.unitOrthogonal(), e2 = a0.cross(e1);
  const double R = 0.6, h = 0.05, zero = 0.01, angle = 0.7;
  const Vec3 x = (-centre - (-centre).dot(a0) * a0).normalized();
  const Vec3 y = a0.cross(x);
  const Vec3 led = centre + R * (std::cos(angle + zero) * x + std::sin(angle + zero) * y) + h * a0;
  const Vec3 point = centre + 0.04 * Vec3(0.3, -0.2, -1.0).normalized();  // on the 40 mm sphere
  const Vec3 dir = (led - point).normalized();
  const Vec3 t1 = dir.unitOrthogonal(), t2 = dir.cross(t1);
  const std::unique_ptr<ceres::CostFunction> cost(
      LedCircleCost::Create({point, dir, t1, t2, angle, centre, a0, e1, e2}));
  double ab[2] = {0.0, 0.0}, uv[2] = {0.0, 0.0}, rhz[3] = {R, h, zero}, r[2];
  const double* blocks[3] = {ab, uv, rhz};
  ASSERT_TRUE(cost->Evaluate(blocks, r, nullptr));
  EXPECT_NEAR(r[0], 0.0, 1e-12);
  EXPECT_NEAR(r[1], 0.0, 1e-12);
  // The arm 0.1 deg further round: the direction moves by about R sin(0.1 deg) / |L - p|.
  rhz[2] = zero + 0.1 * M_PI / 180.0;
  ASSERT_TRUE(cost->Evaluate(blocks, r, nullptr));
  EXPECT_NEAR(std::hypot(r[0], r[1]), 0.6 * std::sin(0.1 * M_PI / 180.0) / (led - point).norm(), 2e-5);
  ab[0] = 0.01;
  ab[1] = -0.02;
  uv[0] = 0.003;
  uv[1] = -0.002;
  test::expect_jacobians_match_central_differences(*cost, {ab, uv, rhz}, 1e-6);
}


TEST(EdgeProfileCost, AnErfEdgeWithoutALimbAndItsJacobianCentralDifferencesAcrossTheLimbTable) {
  // Radii from 8 px inside to 8 px outside the edge at 50 px: x = t / s covers the limb
  // table and both of its tails.
  std::vector<double> r, v;
  for (double x = 42.0; x <= 58.0; x += 0.37) {
    r.push_back(x);
    v.push_back(0.0);
  }
  // c1 = c2 = 0 and no pixel box: a Gaussian-blurred step from c0 inside to b outside.
  double p[6] = {50.0, std::log(1.3), 0.1, 0.8, 0.0, 0.0};
  const std::unique_ptr<ceres::CostFunction> step(EdgeProfileCost::Create(&r, &v, PixelBox{}));
  std::vector<double> res(r.size());
  const double* blocks[1] = {p};
  ASSERT_TRUE(step->Evaluate(blocks, res.data(), nullptr));
  for (std::size_t i = 0; i < r.size(); ++i)
    EXPECT_NEAR(res[i], 0.1 + 0.7 * 0.5 * (1.0 + std::erf((50.0 - r[i]) / 1.3 / std::sqrt(2.0))), 1e-12) << r[i];
  // The limb term (c1, whose H has a hand-written derivative) and the slope term, over a
  // pixel box at 0.4 rad: every column against central differences.
  p[4] = 0.05;
  p[5] = -0.01;
  const std::unique_ptr<ceres::CostFunction> cost(EdgeProfileCost::Create(&r, &v, PixelBox::along(0.4)));
  test::expect_jacobians_match_central_differences(*cost, {p}, 1e-6);
}


TEST(HighlightCost, TheLobePeaksWhereTheMirrorNormalIsAndItsJacobianCentralDifferences) {
  // A 9 x 9 window on a 20 mm glossy sphere 0.5 m in front of the camera, centred on the
  // point facing the camera; the corner pixels are off the sphere.
  const Vec3 C(0.0, 0.0, 0.5);
  const double R = 0.02;
  const Vec3 n0 = (-C).normalized(), e1 = n0.unitOrthogonal(), e2 = n0.cross(e1);
  const int side = 9;
  std::vector<SpherePixel> grid(side * side);
  int data = 0;
  for (int j = 0; j < side; ++j)
    for (int i = 0; i < side; ++i) {
      SpherePixel& p = grid[static_cast<std::size_t>(j * side + i)];
      const bool corner = (i == 0 || i == side - 1) && (j == 0 || j == side - 1);
      p.on_sphere = !corner;
      p.data = true;
      ++data;
      p.normal = (n0 + 0.01 * (i - 4) * e1 + 0.01 * (j - 4) * e2).normalized();
      p.point = C + R * p.normal;
      p.wo = (-p.point).normalized();
    }
  double uv[2] = {0.0, 0.0}, logm = std::log(0.1), amp = 2.0, bg = 0.1, logblur = std::log(1.3);
  const double* blocks[5] = {uv, &logm, &amp, &bg, &logblur};
  std::vector<double> r(grid.size());
  {
    const std::unique_ptr<ceres::CostFunction> sharp(HighlightCost::Create({&grid, side, 0, C, n0, e1, e2, R, 0.6}, data));
    ASSERT_TRUE(sharp->Evaluate(blocks, r.data(), nullptr));
    EXPECT_NEAR(r[4 * side + 4], amp + bg, 1e-9);  // the mirror normal: tan(theta_h) = 0, n . wo = 1
    EXPECT_NEAR(r[0], bg, 1e-12);                  // off the sphere: the background
    EXPECT_LT(r[4 * side + 8], r[4 * side + 4]);   // falls off away from the peak
  }
  uv[0] = 0.003;
  uv[1] = -0.002;
  const std::unique_ptr<ceres::CostFunction> blurred(HighlightCost::Create({&grid, side, 2, C, n0, e1, e2, R, 0.6}, data));
  test::expect_jacobians_match_central_differences(*blurred, {uv, &logm, &amp, &bg, &logblur}, 1e-6);
}

}  // namespace
}  // namespace paintlab::calib
