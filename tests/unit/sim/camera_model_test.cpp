#include <gtest/gtest.h>

#include <opencv2/calib3d.hpp>
#include <random>

#include "paintlab/sim/camera_model.h"
#include "sim_cv_util.h"
#include "sim_test_util.h"
#include "test_util.h"

using namespace paintlab;

namespace {

sim::CameraTruth distorted_camera() {
  return sim::test::camera_with(1250.0, 1243.0, 163.2, 117.9, {-0.28, 0.11, 0.0012, -0.0009, -0.02});
}

}  // namespace

TEST(CameraModel, ProjectionMatchesOpenCv) {
  sim::CameraModel cam(distorted_camera());
  std::mt19937_64 rng(test::seed());
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<cv::Point3d> pts;
  for (int i = 0; i < 500; ++i) {
    double z = 0.5 + 2.0 * (u(rng) + 1.0);
    pts.emplace_back(0.12 * z * u(rng), 0.09 * z * u(rng), z);
  }
  std::vector<cv::Point2d> cv_px;
  cv::projectPoints(pts, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), sim::test::cv_camera_matrix(cam), cv::Mat(cam.dist()), cv_px);
  double worst = 0;
  for (std::size_t i = 0; i < pts.size(); ++i) {
    Vec2 p = cam.project(Vec3(pts[i].x, pts[i].y, pts[i].z));
    worst = std::max(worst, (p - Vec2(cv_px[i].x, cv_px[i].y)).norm());
  }
  EXPECT_LT(worst, 1e-9) << "worst difference to cv::projectPoints: " << worst << " px";
}

TEST(CameraModel, UndistortInvertsDistortAndMatchesOpenCv) {
  sim::CameraModel cam(distorted_camera());
  std::vector<cv::Point2d> px;
  for (int y = 0; y <= 240; y += 20)
    for (int x = 0; x <= 320; x += 20) px.emplace_back(x - 0.5, y - 0.5);
  std::vector<cv::Point2d> cv_norm;
  // OpenCV's own iterative undistortion, run to convergence.
  cv::undistortPoints(px, cv_norm, sim::test::cv_camera_matrix(cam), cv::Mat(cam.dist()), cv::noArray(), cv::noArray(),
                      cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 200, 1e-15));
  double worst_round_trip = 0, worst_cv = 0;
  for (std::size_t i = 0; i < px.size(); ++i) {
    Vec2 xn = cam.unproject(Vec2(px[i].x, px[i].y));
    Vec2 back = cam.project(Vec3(xn.x(), xn.y(), 1.0));
    worst_round_trip = std::max(worst_round_trip, (back - Vec2(px[i].x, px[i].y)).norm());
    worst_cv = std::max(worst_cv, (xn - Vec2(cv_norm[i].x, cv_norm[i].y)).norm() * cam.truth().fx_px);
  }
  EXPECT_LT(worst_round_trip, 1e-9);
  EXPECT_LT(worst_cv, 1e-3) << "px";
}

TEST(CameraModel, CornerGridInterpolationIsExactEnough) {
  sim::CameraModel cam(distorted_camera());
  double worst = 0;
  for (int y = 0; y < 240; y += 7)
    for (int x = 0; x < 320; x += 5)
      for (double f : {0.25, 0.5, 0.8}) {
        Vec2 a = cam.grid_point(x, y, f, 1.0 - f);
        Vec2 b = cam.unproject(Vec2(x - 0.5 + f, y + 0.5 - f));
        worst = std::max(worst, (a - b).norm() * cam.truth().fx_px);
      }
  EXPECT_LT(worst, 1e-4) << "px";
}

TEST(CameraModel, PoseAndVignetting) {
  sim::CameraTruth t = distorted_camera();
  t.dist = {};
  t.position_rig_m = Vec3(1.0, 0.2, 0.3);
  t.look_at_rig_m = Vec3(0.01, -0.02, 0.005);
  t.roll_deg = 3.0;
  t.vignetting = {-0.2, 0.05};
  sim::CameraModel cam(t);
  EXPECT_NEAR((cam.centre_rig() - t.position_rig_m).norm(), 0.0, 1e-12);
  Vec2 px = cam.project_rig(t.look_at_rig_m);
  EXPECT_NEAR(px.x(), t.cx_px, 1e-9);
  EXPECT_NEAR(px.y(), t.cy_px, 1e-9);
  // Roll turns the image: a point above the target (rig +z) is up in the image, tilted by 3 deg.
  Vec2 up = cam.project_rig(t.look_at_rig_m + Vec3(0, 0, 0.01)) - px;
  EXPECT_LT(up.y(), 0);
  EXPECT_NEAR(std::atan2(-up.x(), -up.y()), -deg_to_rad(3.0), deg_to_rad(0.3));
  EXPECT_NEAR(cam.vignetting(Vec2(t.cx_px, t.cy_px)), 1.0, 1e-12);
  // A corner: cos^4 of the field angle times the polynomial.
  Vec2 corner(0, 0);
  double half_diag2 = 0.25 * (320.0 * 320 + 240.0 * 240);
  double rho2 = (corner - Vec2(t.cx_px, t.cy_px)).squaredNorm() / half_diag2;
  Vec2 xn((0 - t.cx_px) / t.fx_px, (0 - t.cy_px) / t.fy_px);
  double c2 = 1.0 / (1.0 + xn.squaredNorm());
  EXPECT_NEAR(cam.vignetting(corner), c2 * c2 * (1 - 0.2 * rho2 + 0.05 * rho2 * rho2), 1e-12);
  EXPECT_NEAR(cam.irradiance_per_radiance(), kPi / (4 * 64.0), 1e-15);
}
