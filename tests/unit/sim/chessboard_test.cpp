#include <gtest/gtest.h>

#include <opencv2/aruco/charuco.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "paintlab/sim/scenes.h"
#include "paintlab/sim/sensor.h"
#include "sim_cv_util.h"
#include "sim_test_util.h"
#include "test_util.h"

using namespace paintlab;

namespace {

sim::CameraTruth camera_truth() {
  sim::CameraTruth t = sim::test::camera_with(520.0, 518.0, 161.7, 118.4, {-0.24, 0.09, 0.0011, -0.0007, -0.015});
  t.psf_sigma_px = 0.7;  // a slightly soft lens, as real ones are
  return t;
}

sim::Chessboard board() {
  sim::Chessboard b;
  b.cols = 7;
  b.rows = 5;
  b.square_m = 0.02;
  return b;
}

}  // namespace

TEST(Chessboard, ProjectedCornersMatchOpenCv) {
  sim::CameraModel cam(camera_truth());
  sim::Chessboard b = board();
  auto poses = sim::chessboard_poses(cam, b, 12, test::seed());
  ASSERT_EQ(poses.size(), 12u);
  std::vector<cv::Point3d> obj;
  for (const Vec3& p : b.corners()) obj.emplace_back(p.x(), p.y(), p.z());
  double worst = 0;
  for (const Rigid3& pose : poses) {
    Eigen::AngleAxisd aa(pose.rotation);
    Vec3 r = aa.axis() * aa.angle();
    std::vector<cv::Point2d> cv_px;
    cv::projectPoints(obj, cv::Vec3d(r.x(), r.y(), r.z()),
                      cv::Vec3d(pose.translation.x(), pose.translation.y(), pose.translation.z()), sim::test::cv_camera_matrix(cam),
                      cv::Mat(cam.dist()), cv_px);
    auto ours = sim::project_points(cam, pose, b.corners());
    for (std::size_t i = 0; i < ours.size(); ++i)
      worst = std::max(worst, (ours[i] - Vec2(cv_px[i].x, cv_px[i].y)).norm());
  }
  EXPECT_LT(worst, 0.01) << "px";
  EXPECT_LT(worst, 1e-8) << "px (the same formula: only rounding should differ)";
}

TEST(Chessboard, PosesAreVariedAndKeepTheBoardInside) {
  sim::CameraModel cam(camera_truth());
  sim::Chessboard b = board();
  auto poses = sim::chessboard_poses(cam, b, 9, 42);
  auto again = sim::chessboard_poses(cam, b, 9, 42);
  double max_tilt = 0;
  Vec2 lo(1e9, 1e9), hi(-1e9, -1e9);
  for (std::size_t k = 0; k < poses.size(); ++k) {
    EXPECT_TRUE(poses[k].rotation.isApprox(again[k].rotation) && poses[k].translation == again[k].translation);
    max_tilt = std::max(max_tilt, rad_to_deg(angle_between(poses[k].rotation * Vec3::UnitZ(), Vec3::UnitZ())));
    for (const Vec2& p : sim::project_points(cam, poses[k], b.corners())) {
      EXPECT_TRUE(p.x() > 0 && p.y() > 0 && p.x() < 319 && p.y() < 239);
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
  }
  EXPECT_GT(max_tilt, 15.0);
  // Together the views cover most of the image (what intrinsics calibration needs).
  EXPECT_LT(lo.x(), 60);
  EXPECT_LT(lo.y(), 45);
  EXPECT_GT(hi.x(), 260);
  EXPECT_GT(hi.y(), 195);
}

// Rendered boards, detected by OpenCV: the measured corners sit where the camera model
// projects them. Prints the accuracy. cornerSubPix itself is biased by up to ~0.08 px
// depending on the corner's sub-pixel phase on sharp edges (measured here on a
// fronto-parallel board whose edges are exact to 1/32 px), so this bounds the detector
// plus the renderer; SupersampledEdgeHasTheRightCoverage checks the edges directly.
TEST(Chessboard, RenderedCornersAreSubPixelAccurate) {
  sim::CameraModel cam(camera_truth());
  sim::Chessboard b = board();
  auto poses = sim::chessboard_poses(cam, b, 6, test::seed() + 1);
  sim::PlaneLighting light{10.0, 0.02};
  double sum = 0, worst = 0;
  int n = 0, found_views = 0;
  for (const Rigid3& pose : poses) {
    ImageF rad = sim::render_chessboard(cam, b, pose, light, 16);
    double peak = b.white_albedo * light.irradiance_w_m2 / kPi;
    cv::Mat f(rad.height(), rad.width(), CV_32F, rad.data());
    cv::Mat img8;
    f.convertTo(img8, CV_8U, 250.0 / peak);
    std::vector<cv::Point2f> corners;
    if (!cv::findChessboardCorners(img8, cv::Size(b.cols, b.rows), corners, cv::CALIB_CB_ADAPTIVE_THRESH)) continue;
    ++found_views;
    cv::Mat f32 = f * (1.0 / peak);
    cv::cornerSubPix(f32, corners, cv::Size(5, 5), cv::Size(-1, -1),
                     cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 100, 1e-4));
    auto truth = sim::project_points(cam, pose, b.corners());
    // OpenCV may report the grid in reverse order.
    bool reversed = (Vec2(corners[0].x, corners[0].y) - truth.front()).norm() >
                    (Vec2(corners[0].x, corners[0].y) - truth.back()).norm();
    for (std::size_t i = 0; i < truth.size(); ++i) {
      const auto& c = corners[reversed ? truth.size() - 1 - i : i];
      double e = (Vec2(c.x, c.y) - truth[i]).norm();
      sum += e;
      worst = std::max(worst, e);
      ++n;
    }
  }
  ASSERT_GE(found_views, 4) << "OpenCV must find most rendered boards";
  double mean = sum / n;
  std::printf("rendered chessboard corners vs projection: %d corners in %d views, mean %.4f px, worst %.4f px\n", n,
              found_views, mean, worst);
  EXPECT_LT(mean, 0.05);
  EXPECT_LT(worst, 0.15);
}

TEST(Chessboard, SupersampledEdgeHasTheRightCoverage) {
  // A fronto-parallel board on an undistorted camera: the grey value of a pixel that an
  // edge cuts equals the fraction of it on the white side.
  sim::CameraTruth t = camera_truth();
  t.dist = {};
  t.psf_sigma_px = 0.0;
  sim::CameraModel cam(t);
  sim::Chessboard b = board();
  Rigid3 pose;
  pose.translation = Vec3(-0.05, -0.03, 0.5);
  ImageF rad = sim::render_chessboard(cam, b, pose, {kPi, 0.0}, 32);
  // The vertical edge x = 0.02 m (between the first and second column of squares) in row y = 0.01 m.
  double u_edge = t.fx_px * (0.02 - 0.05) / 0.5 + t.cx_px;
  double v = t.fy_px * (0.01 - 0.03) / 0.5 + t.cy_px;
  int px = static_cast<int>(std::floor(u_edge + 0.5)), py = static_cast<int>(std::floor(v + 0.5));
  double left_part = u_edge - (px - 0.5);  // the pixel's share left of the edge
  // Square (0, 0) is black (albedo 0.04), square (1, 0) white (0.8).
  double expected = 0.04 * left_part + 0.8 * (1 - left_part);
  EXPECT_NEAR(rad.at(px, py), expected, 0.76 / 32 + 1e-6);
  EXPECT_NEAR(rad.at(px - 2, py), 0.04, 1e-6);
  EXPECT_NEAR(rad.at(px + 2, py), 0.8, 1e-6);
}

TEST(Scenes, DarkAndUniformFields) {
  sim::CameraTruth t = camera_truth();
  t.vignetting = {-0.3, 0.0};
  t.psf_sigma_px = 0.0;
  sim::CameraModel cam(t);
  sim::SensorParams sp;
  sp.hot_pixel_frac = 0.0;
  sp.prnu_rel = 0.0;
  sp.read_noise_e = 0.0;
  sp.dark_current_e_per_s = 0.0;
  sim::Sensor sensor(cam, sp, 3);
  auto dark = sensor.expose(sim::dark_field(cam), {0.1, 0.0, 0, std::nullopt});
  for (std::uint16_t v : dark.values()) ASSERT_EQ(v, 64);
  ImageF flat = sim::uniform_field(cam, 1.0);
  double g_centre = sensor.electrons_per_s_per_radiance(160, 118);
  auto img = sensor.expose(flat, {5000.0 / g_centre, 0.0, 0, std::nullopt});
  // The flat field shows the vignetting: corners darker than the centre by the model's factor.
  double ratio_model = cam.vignetting(Vec2(0, 0)) / cam.vignetting(Vec2(160, 118));
  double centre = 0, corner = 0;
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 4; ++x) {
      centre += img.at(158 + x, 116 + y) - 64.0;
      corner += img.at(x, y) - 64.0;
    }
  EXPECT_NEAR(corner / centre, ratio_model, 0.02);
  EXPECT_LT(ratio_model, 0.8);
}

// A ChArUco board laid out as OpenCV's CharucoBoard: OpenCV's detector finds every marker
// with the right id, and its ChArUco corners sit where our projection puts them.
TEST(Charuco, OpenCvDetectsTheRenderedBoard) {
  sim::CameraTruth t = sim::test::small_config(8.0, 640, 480).camera;
  t.fx_px = 610.0;
  t.fy_px = 607.0;
  t.cx_px = 322.4;
  t.cy_px = 236.1;
  t.dist = {-0.12, 0.05, 0.0005, -0.0004, 0.0};
  t.psf_sigma_px = 0.7;
  sim::CameraModel cam(t);
  sim::CharucoBoard b;  // 5 x 7 squares of 40 mm, 20 mm DICT_6X6_250 markers: the OpenCV tutorial's board
  Rigid3 pose;
  pose.rotation = Eigen::AngleAxisd(deg_to_rad(12.0), Vec3::UnitX()) * Eigen::AngleAxisd(deg_to_rad(-15.0), Vec3::UnitY());
  pose.translation = Vec3(0, 0, 0.5) - pose.rotation * Vec3(0.1, 0.14, 0.0);
  ImageF rad = sim::render_charuco(cam, b, pose, {10.0, 0.02});
  double peak = b.white_albedo * 10.0 / kPi;
  cv::Mat f(rad.height(), rad.width(), CV_32F, rad.data());
  cv::Mat img8;
  f.convertTo(img8, CV_8U, 250.0 / peak);

  auto dict = cv::aruco::getPredefinedDictionary(b.dictionary);
  std::vector<std::vector<cv::Point2f>> marker_corners;
  std::vector<int> ids;
  cv::aruco::detectMarkers(img8, dict, marker_corners, ids);
  ASSERT_EQ(ids.size(), static_cast<std::size_t>(b.marker_count()));
  std::sort(ids.begin(), ids.end());
  for (int i = 0; i < b.marker_count(); ++i) EXPECT_EQ(ids[static_cast<std::size_t>(i)], i);
  cv::aruco::detectMarkers(img8, dict, marker_corners, ids);  // unsorted again, paired with corners

  auto cv_board = cv::aruco::CharucoBoard::create(b.squares_x, b.squares_y, static_cast<float>(b.square_m),
                                                  static_cast<float>(b.marker_m), dict);
  std::vector<cv::Point2f> ch_corners;
  std::vector<int> ch_ids;
  int n = cv::aruco::interpolateCornersCharuco(marker_corners, ids, img8, cv_board, ch_corners, ch_ids);
  ASSERT_EQ(n, (b.squares_x - 1) * (b.squares_y - 1));
  auto truth = sim::project_points(cam, pose, b.corners());
  // OpenCV 4.6's interpolateCornersCharuco (opencv_contrib aruco) returns corners shifted by
  // about +0.5 px in x and y: it wraps its cornerSubPix call in a -0.5/+0.5 shift (added by
  // opencv_contrib#3024; the same bias in the later objdetect CharucoDetector is
  // opencv/opencv#25539, fixed by opencv/opencv#28380). Print it, then refine its corners
  // again with cornerSubPix, as the chessboard test does.
  Vec2 raw_offset = Vec2::Zero();
  for (int i = 0; i < n; ++i) {
    const auto& c = ch_corners[static_cast<std::size_t>(i)];
    Vec2 dv = Vec2(c.x, c.y) - truth[static_cast<std::size_t>(ch_ids[static_cast<std::size_t>(i)])];
    ASSERT_LT(dv.norm(), 1.5) << "corner id " << ch_ids[static_cast<std::size_t>(i)];
    raw_offset += dv / n;
  }
  std::printf("interpolateCornersCharuco corners vs projection: mean offset (%+.3f, %+.3f) px\n", raw_offset.x(),
              raw_offset.y());
  cv::Mat f32 = f * (1.0 / peak);
  cv::cornerSubPix(f32, ch_corners, cv::Size(5, 5), cv::Size(-1, -1),
                   cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 100, 1e-4));
  double sum = 0, worst = 0;
  for (int i = 0; i < n; ++i) {
    const Vec2 c(ch_corners[static_cast<std::size_t>(i)].x, ch_corners[static_cast<std::size_t>(i)].y);
    Vec2 dv = c - truth[static_cast<std::size_t>(ch_ids[static_cast<std::size_t>(i)])];
    double e = dv.norm();
    sum += e;
    worst = std::max(worst, e);
  }
  std::printf("rendered ChArUco corners vs projection: %d corners, mean %.4f px, worst %.4f px\n", n, sum / n, worst);
  EXPECT_LT(sum / n, 0.08);
  EXPECT_LT(worst, 0.2);
}

TEST(Charuco, PosesKeepTheBoardInsideAndOpenCvFindsIt) {
  sim::CameraTruth t = camera_truth();
  t.width_px = 640;
  t.height_px = 480;
  t.fx_px = 2 * t.fx_px;
  t.fy_px = 2 * t.fy_px;
  t.cx_px = 2 * t.cx_px + 0.5;
  t.cy_px = 2 * t.cy_px + 0.5;
  sim::CameraModel cam(t);
  sim::CharucoBoard b;
  b.squares_x = 5;
  b.squares_y = 4;
  b.marker_m = 0.03;
  b.dictionary = cv::aruco::DICT_4X4_50;  // 6 x 6 cells of >= 4 px at 30 % of the image width
  auto poses = sim::charuco_poses(cam, b, 4, 7);
  auto again = sim::charuco_poses(cam, b, 4, 7);
  ASSERT_EQ(poses.size(), 4u);
  auto dict = cv::aruco::getPredefinedDictionary(b.dictionary);
  int detected = 0;
  for (std::size_t k = 0; k < poses.size(); ++k) {
    EXPECT_TRUE(poses[k].rotation.isApprox(again[k].rotation) && poses[k].translation == again[k].translation);
    // The printed area's corners are inside the image.
    const double lo = -b.margin_squares * b.square_m;
    const double hx = (b.squares_x + b.margin_squares) * b.square_m, hy = (b.squares_y + b.margin_squares) * b.square_m;
    for (const Vec2& p : sim::project_points(cam, poses[k], {Vec3(lo, lo, 0), Vec3(hx, lo, 0), Vec3(lo, hy, 0),
                                                              Vec3(hx, hy, 0)}))
      EXPECT_TRUE(p.x() > 0 && p.y() > 0 && p.x() < 639 && p.y() < 479) << "view " << k;
    ImageF rad = sim::render_charuco(cam, b, poses[k], {10.0, 0.02});
    cv::Mat f(rad.height(), rad.width(), CV_32F, rad.data());
    cv::Mat img8;
    f.convertTo(img8, CV_8U, 250.0 / (b.white_albedo * 10.0 / kPi));
    std::vector<std::vector<cv::Point2f>> marker_corners;
    std::vector<int> ids;
    cv::aruco::detectMarkers(img8, dict, marker_corners, ids);
    // Every detected id belongs to the board; most views show all markers.
    for (int id : ids) EXPECT_LT(id, b.marker_count());
    detected += static_cast<int>(ids.size()) == b.marker_count();
    std::printf("view %zu: %zu of %d markers\n", k, ids.size(), b.marker_count());
  }
  EXPECT_GE(detected, 3);
}
