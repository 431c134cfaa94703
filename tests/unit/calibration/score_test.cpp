// Scoring a calibration against a known truth (calibration/score.h): the figures the demo's
// summary and the accuracy tests report, from a calibration folder whose errors are set by hand.
#include "paintlab/calibration/score.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>

#include "paintlab/calibration/intrinsics.h"
#include "paintlab/calibration/record.h"
#include "paintlab/calibration/response.h"
#include "paintlab/calibration/sphere.h"
#include "paintlab/core/error.h"
#include "test_util.h"

namespace paintlab::calib {
namespace {

Mat3 camera_matrix(double f, double cx, double cy) {
  Mat3 K = Mat3::Identity();
  K(0, 0) = K(1, 1) = f;
  K(0, 2) = cx;
  K(1, 2) = cy;
  return K;
}

TEST(ScoreCalibration, FiguresOfAFolderWithKnownErrors) {
  test::TempDir dir;
  IntrinsicsResult in;
  in.camera.width_px = 640;
  in.camera.height_px = 480;
  in.camera.K = camera_matrix(2020.0, 323.0, 244.0);  // focal 1 % long, principal point 5 px off
  in.std.cx = 0.3;
  in.std.cy = 0.4;
  in.rms_px = 0.12;
  in.views_used = 12;
  in.provenance = Provenance::make("intrinsics", {});
  in.save(dir / kCameraFile);
  SphereFit s;
  s.radius_m = 0.04;
  s.centre_cam_m = Vec3(0.003, -0.004, 1.2);  // 5 mm from the truth
  s.axis = s.centre_cam_m.normalized();
  s.provenance = Provenance::make("sphere", {});
  s.save(dir / kSphereFile);  // without edge figures (NaN): they are left out and read back as NaN
  EXPECT_TRUE(std::isnan(SphereFit::load(dir / kSphereFile).edge_width_px));
  ValueWindow w;
  w.saturation_dn = 4095;
  ResponseCurve linear = ResponseCurve::identity(12, 1, w);
  linear.provenance = Provenance::make("response", {});
  linear.save(dir / kResponseFile);

  CalibrationTruth t;
  t.K = camera_matrix(2000.0, 320.0, 240.0);
  t.sphere_centre_cam_m = Vec3(0.0, 0.0, 1.2);
  t.adc_bits = 12;
  t.adc_max_dn = 4095;
  for (int i = 0; i <= 100; ++i) t.inverse_response.emplace_back(i / 100.0, i / 100.0);  // a linear camera
  const RigCalibration cal = RigCalibration::load(dir.path());
  const CalibrationScore sc = score_calibration(cal, t);
  ASSERT_TRUE(sc.focal_error_rel && sc.principal_point_error_px && sc.principal_point_std_px);
  EXPECT_NEAR(*sc.focal_error_rel, 0.01, 1e-12);
  EXPECT_NEAR(*sc.principal_point_error_px, 5.0, 1e-9);
  EXPECT_NEAR(*sc.principal_point_std_px, 0.5, 1e-12);
  EXPECT_DOUBLE_EQ(*sc.reprojection_rms_px, 0.12);
  ASSERT_TRUE(sc.sphere_centre_error_mm);
  EXPECT_NEAR(*sc.sphere_centre_error_mm, 5.0, 1e-9);
  EXPECT_FALSE(sc.light_angle_error_deg);  // no light.json
  ASSERT_TRUE(sc.response_error_rel);
  EXPECT_LT(*sc.response_error_rel, 1e-9);
  const Json j = sc.to_json();
  EXPECT_EQ(j.size(), 6u) << j.dump();
  EXPECT_FALSE(j.contains("light_angle_error_deg"));

  // A camera whose true response is not linear: the linear curve is wrong by the factor
  // k u / u^2 over its range, seen after the best scale k.
  t.inverse_response.clear();
  for (int i = 0; i <= 1000; ++i) t.inverse_response.emplace_back(i / 1000.0, std::pow(i / 1000.0, 2.0));
  EXPECT_GT(*score_calibration(cal, t).response_error_rel, 0.5);

  t.angles_deg = {0.0, 10.0};
  t.led_cam_m = {Vec3::Zero()};
  EXPECT_THROW(score_calibration(cal, t), DataError);
}

}  // namespace
}  // namespace paintlab::calib
