// Intrinsics on synthetic chessboard images whose truth is known (synthetic_scenes.h):
// corner accuracy against OpenCV's cornerSubPix, focal length and principal point against
// the truth, reprojection RMS against the corner-noise floor, uncertainty against the
// scatter of repeated noisy solves, outlier and missing views.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <opencv2/imgproc.hpp>
#include <random>

#include "paintlab/calibration/intrinsics.h"
#include "paintlab/core/error.h"
#include "synthetic_scenes.h"
#include "test_util.h"

using namespace paintlab;
using namespace paintlab::calib;
using namespace paintlab::calib::testing;

namespace {

CameraModel test_camera() {
  CameraModel c;
  c.width_px = 480;
  c.height_px = 360;
  c.K << 620.0, 0.0, 243.7, 0.0, 621.5, 176.2, 0.0, 0.0, 1.0;
  c.dist = {-0.21, 0.09, 0.0012, -0.0007, 0.0};
  return c;
}

ChessboardScene test_scene() {
  ChessboardScene sc;
  sc.camera = test_camera();
  sc.board = BoardSpec{9, 6, 0.02};
  return sc;
}

// Twelve views with tilts up to 40 deg, the board filling a good part of the image.
std::vector<Rigid3> test_poses(const BoardSpec& b) {
  const double t[12][6] = {{0.0, 0.0, 0.42, 0, 0, 0},       {0.03, 0.01, 0.40, 30, 0, 5},
                           {-0.03, 0.0, 0.40, -30, 0, -5},  {0.0, 0.02, 0.41, 0, 35, 10},
                           {0.0, -0.02, 0.41, 0, -35, -10}, {0.04, 0.03, 0.45, 25, 25, 20},
                           {-0.04, -0.03, 0.45, -25, 25, -20}, {0.04, -0.03, 0.46, 25, -25, 15},
                           {-0.04, 0.03, 0.46, -25, -25, -15}, {0.0, 0.0, 0.36, 15, -10, 90},
                           {0.05, 0.0, 0.50, 0, 40, 0},     {-0.05, 0.0, 0.50, 40, 0, 0}};
  std::vector<Rigid3> out;
  for (const auto& p : t) out.push_back(board_pose(b, Vec3(p[0], p[1], p[2]), p[3], p[4], p[5]));
  return out;
}

double rms_error(const std::vector<Vec2>& a, const std::vector<Vec2>& b) {
  double s = 0;
  for (std::size_t i = 0; i < a.size(); ++i) s += (a[i] - b[i]).squaredNorm();
  return std::sqrt(s / static_cast<double>(a.size()));
}

}  // namespace

TEST(IntrinsicsSynthetic, SaddleFitCornersBeatCornerSubPixAgainstTruth) {
  ChessboardScene sc = test_scene();
  auto poses = test_poses(sc.board);
  double ss_fit = 0, ss_subpix = 0, ss_subpix11 = 0, ss_std = 0, ss_tilted = 0;
  int n = 0, views = 0, n_tilted = 0;
  const NormalizedMap map(sc.camera, 3);
  for (int v : {0, 3, 5, 8}) {
    Image<std::uint16_t> img = render_chessboard(sc, poses[static_cast<std::size_t>(v)], test::seed() + v, &map);
    auto truth = true_corners(sc.camera, sc.board, poses[static_cast<std::size_t>(v)]);
    ChessboardDetection fit = detect_chessboard(img, sc.bit_depth, sc.board);
    CornerOptions sp;
    sp.method = CornerMethod::OpenCvSubPix;
    ChessboardDetection sub = detect_chessboard(img, sc.bit_depth, sc.board, sp);
    sp.subpix_half_window_px = 11;
    ChessboardDetection sub11 = detect_chessboard(img, sc.bit_depth, sc.board, sp);
    ASSERT_TRUE(fit.found && sub.found && sub11.found) << "view " << v;
    EXPECT_EQ(fit.fallback, 0);
    // Detection may start at the opposite corner of the board: compare in that order.
    if ((fit.corners_px.front() - truth.front()).norm() > (fit.corners_px.front() - truth.back()).norm())
      std::reverse(truth.begin(), truth.end());
    const double e_fit = rms_error(fit.corners_px, truth);
    ss_fit += e_fit * e_fit * truth.size();
    ss_subpix += std::pow(rms_error(sub.corners_px, truth), 2) * truth.size();
    ss_subpix11 += std::pow(rms_error(sub11.corners_px, truth), 2) * truth.size();
    if (v != 0) {  // view 0 faces the camera: its edges run along the pixel grid
      for (double s : fit.corner_std_px) ss_std += s * s;
      ss_tilted += e_fit * e_fit * truth.size();
      n_tilted += static_cast<int>(truth.size());
    }
    n += static_cast<int>(truth.size());
    ++views;
    // The fitted blur is the optics PSF combined with the pixel's box (variance 1/12).
    EXPECT_NEAR(fit.blur_sigma_px, std::hypot(sc.blur_sigma_px, std::sqrt(1.0 / 12.0)), 0.05);
  }
  const double e_fit = std::sqrt(ss_fit / n), e_sub = std::sqrt(ss_subpix / n), e_sub11 = std::sqrt(ss_subpix11 / n);
  // corner_std_px is per axis; the error is a 2D distance.
  const double predicted = std::sqrt(2.0 * ss_std / n_tilted), e_tilted = std::sqrt(ss_tilted / n_tilted);
  std::printf("corner error vs truth over %d views: saddle fit %.4f px (tilted views %.4f, predicted %.4f), "
              "cornerSubPix auto %.4f px, cornerSubPix 11 %.4f px\n",
              views, e_fit, e_tilted, predicted, e_sub, e_sub11);
  EXPECT_LT(e_fit, 0.025);
  EXPECT_LT(e_fit, 0.7 * e_sub);
  EXPECT_LT(e_fit, 0.7 * e_sub11);
  // On tilted views the uncertainty the fit reports matches its actual error within a
  // factor 2. (Edges parallel to the pixel grid add a pixel-phase bias of ~0.015 px at
  // 0.8 px blur that the noise-based figure does not contain: the Gaussian edge model
  // does not include the pixel's box integration.)
  EXPECT_GT(e_tilted, 0.5 * predicted);
  EXPECT_LT(e_tilted, 2.0 * predicted);
}

TEST(IntrinsicsSynthetic, FocalPrincipalPointAndRmsAgainstTruth) {
  ChessboardScene sc = test_scene();
  auto poses = test_poses(sc.board);
  std::vector<BoardImage> images;
  std::vector<std::vector<Vec2>> truth;
  const NormalizedMap map(sc.camera, 2);
  for (std::size_t v = 0; v < poses.size(); ++v) {
    images.push_back({"view" + std::to_string(v), render_chessboard(sc, poses[v], test::seed() + 100 + v, &map), sc.bit_depth});
    truth.push_back(true_corners(sc.camera, sc.board, poses[v]));
  }
  IntrinsicsResult r = calibrate_intrinsics(images, sc.board);
  ASSERT_EQ(r.views_used, 12);
  // The corner-noise floor: RMS distance of the detected corners from their true positions.
  double ss = 0;
  int n = 0;
  for (std::size_t v = 0; v < poses.size(); ++v) {
    auto t = truth[v];
    const auto& c = r.views[v].corners_px;
    if ((c.front() - t.front()).norm() > (c.front() - t.back()).norm()) std::reverse(t.begin(), t.end());
    for (std::size_t i = 0; i < t.size(); ++i, ++n) ss += (c[i] - t[i]).squaredNorm();
  }
  const double floor_px = std::sqrt(ss / n);
  const CameraModel& T = sc.camera;
  std::printf("synthetic intrinsics: RMS %.4f px, corner-noise floor %.4f px (ratio %.2f); fx %.3f (true %.3f, %+.4f %%), "
              "fy %.3f (%+.4f %%), cx %.3f (true %.3f), cy %.3f (true %.3f), std fx %.3f\n",
              r.rms_px, floor_px, r.rms_px / floor_px, r.camera.fx(), T.fx(), 100 * (r.camera.fx() / T.fx() - 1),
              r.camera.fy(), 100 * (r.camera.fy() / T.fy() - 1), r.camera.cx(), T.cx(), r.camera.cy(), T.cy(), r.std.fx);
  EXPECT_LE(r.rms_px, 1.2 * floor_px);
  EXPECT_THAT(r.camera.fx(), test::NearRel(T.fx(), 0.001));
  EXPECT_THAT(r.camera.fy(), test::NearRel(T.fy(), 0.001));
  EXPECT_NEAR(r.camera.cx(), T.cx(), 0.5);
  EXPECT_NEAR(r.camera.cy(), T.cy(), 0.5);
  // Distortion: the model reproduces the true mapping within 0.1 px wherever the views
  // put corners (the image corners beyond them are extrapolation).
  double reach = 0;
  for (const auto& t : truth)
    for (const Vec2& p : t) reach = std::max(reach, (p - Vec2(T.cx(), T.cy())).norm());
  double worst = 0;
  for (int y = 0; y < T.height_px; y += 20)
    for (int x = 0; x < T.width_px; x += 20) {
      if ((Vec2(x, y) - Vec2(T.cx(), T.cy())).norm() > reach) continue;
      Vec3 ray = T.ray(Vec2(x, y));
      worst = std::max(worst, (r.camera.project(ray) - Vec2(x, y)).norm());
    }
  EXPECT_LT(worst, 0.1) << "largest mapping difference over the image";
}

TEST(IntrinsicsSynthetic, ReportedUncertaintyMatchesScatterOfNoisySolves) {
  // Corner noise injected directly into the true corners (mrcal-style check): the
  // reprojection RMS sits at the injected floor and OpenCV's standard deviations match the
  // scatter of repeated solves.
  ChessboardScene sc = test_scene();
  auto poses = test_poses(sc.board);
  const double sigma = 0.1;
  std::mt19937_64 rng(test::seed());
  std::normal_distribution<double> noise(0.0, sigma);
  std::vector<double> fx, reported;
  for (int trial = 0; trial < 24; ++trial) {
    std::vector<CornerView> views;
    for (std::size_t v = 0; v < poses.size(); ++v) {
      CornerView cv{"view" + std::to_string(v), true_corners(sc.camera, sc.board, poses[v])};
      for (auto& p : cv.corners_px) p += Vec2(noise(rng), noise(rng));
      views.push_back(cv);
    }
    IntrinsicsResult r = calibrate_from_corners(views, sc.board, sc.camera.width_px, sc.camera.height_px);
    EXPECT_EQ(r.views_used, 12);
    // The floor: RMS length of the injected 2D error, sqrt(2) sigma.
    EXPECT_LE(r.rms_px, 1.2 * std::sqrt(2.0) * sigma);
    EXPECT_GE(r.rms_px, 0.8 * std::sqrt(2.0) * sigma);
    fx.push_back(r.camera.fx());
    reported.push_back(r.std.fx);
  }
  double mean = 0, var = 0, rep = 0;
  for (double v : fx) mean += v / fx.size();
  for (double v : fx) var += (v - mean) * (v - mean) / (fx.size() - 1);
  for (double v : reported) rep += v / reported.size();
  std::printf("fx over 24 noisy solves: mean %.3f (true %.3f), scatter %.4f px, reported std %.4f px\n", mean,
              sc.camera.fx(), std::sqrt(var), rep);
  EXPECT_GT(std::sqrt(var), 0.6 * rep);
  EXPECT_LT(std::sqrt(var), 1.6 * rep);
  EXPECT_NEAR(mean, sc.camera.fx(), 3.0 * rep);
}

TEST(IntrinsicsSynthetic, BentBoardViewIsDroppedWithReason) {
  ChessboardScene sc = test_scene();
  auto poses = test_poses(sc.board);
  std::mt19937_64 rng(test::seed());
  std::normal_distribution<double> noise(0.0, 0.05);
  std::vector<CornerView> views;
  for (std::size_t v = 0; v < poses.size(); ++v) {
    CornerView cv{"view" + std::to_string(v), true_corners(sc.camera, sc.board, poses[v])};
    for (auto& p : cv.corners_px) p += Vec2(noise(rng), noise(rng));
    views.push_back(cv);
  }
  // View 4: the board bent along its middle (the right half shifted by 3 px).
  for (int r = 0; r < sc.board.rows; ++r)
    for (int c = 5; c < sc.board.cols; ++c) views[4].corners_px[static_cast<std::size_t>(r * sc.board.cols + c)] += Vec2(3.0, 0.0);
  views.push_back(CornerView{"blank.png", {}});
  IntrinsicsResult r = calibrate_from_corners(views, sc.board, sc.camera.width_px, sc.camera.height_px);
  EXPECT_EQ(r.views_used, 11);
  EXPECT_EQ(r.views_dropped, 2);
  EXPECT_FALSE(r.views[4].used);
  EXPECT_THAT(r.views[4].reason, ::testing::HasSubstr("reprojection RMS"));
  EXPECT_GT(r.views[4].rms_px, 0.5);
  EXPECT_FALSE(r.views[12].used);
  EXPECT_THAT(r.views[12].reason, ::testing::HasSubstr("no chessboard"));
  EXPECT_LT(r.rms_px, 0.08);
  EXPECT_THAT(r.camera.fx(), test::NearRel(sc.camera.fx(), 0.002));
  // Each corner's residual (for the report's residual plots), of the views in the fit and of
  // the dropped bent one (against its own pose): they give back each view's RMS and worst
  // corner; camera.json keeps them with the corners.
  for (int v : {0, 4}) {
    const auto& res = r.views[static_cast<std::size_t>(v)].residuals_px;
    ASSERT_EQ(res.size(), static_cast<std::size_t>(sc.board.corner_count()));
    double ss = 0, worst = 0;
    for (const Vec2& e : res) {
      ss += e.squaredNorm();
      worst = std::max(worst, e.norm());
    }
    EXPECT_NEAR(std::sqrt(ss / res.size()), r.views[static_cast<std::size_t>(v)].rms_px, 1e-9) << v;
    EXPECT_NEAR(worst, r.views[static_cast<std::size_t>(v)].max_px, 1e-9) << v;
  }
  EXPECT_TRUE(r.views[12].residuals_px.empty());
  const Json j = r.to_json();
  ASSERT_EQ(j["views"][0]["residuals_px"].size(), r.views[0].residuals_px.size());
  EXPECT_NEAR(j["views"][0]["residuals_px"][3][1].get<double>(), r.views[0].residuals_px[3].y(), 1e-4);
  EXPECT_NEAR(j["views"][0]["corners_px"][3][0].get<double>(), r.views[0].corners_px[3].x(), 1e-4);
  EXPECT_FALSE(j["views"][12].contains("residuals_px"));
}

TEST(IntrinsicsSynthetic, TooFewViewsNamesTheDroppedOnes) {
  ChessboardScene sc = test_scene();
  auto poses = test_poses(sc.board);
  std::vector<CornerView> views;
  for (std::size_t v = 0; v < 2; ++v) views.push_back({"view" + std::to_string(v), true_corners(sc.camera, sc.board, poses[v])});
  views.push_back({"dark.png", {}});
  EXPECT_THAT(test::error_message<CalibrationError>([&] { calibrate_from_corners(views, sc.board, sc.camera.width_px, sc.camera.height_px); }),
              ::testing::AllOf(::testing::HasSubstr("only 2 usable"), ::testing::HasSubstr("dark.png: no chessboard")));
}

TEST(IntrinsicsSynthetic, BlankImageIsNotABoard) {
  ChessboardScene sc = test_scene();
  Image<std::uint16_t> blank(sc.camera.width_px, sc.camera.height_px, 1, 1000);
  ChessboardDetection d = detect_chessboard(blank, 16, sc.board);
  EXPECT_FALSE(d.found);
  EXPECT_THAT(d.reason, ::testing::HasSubstr("no 9x6 chessboard"));
}

TEST(IntrinsicsSynthetic, CameraJsonRoundTripAndContractKeys) {
  ChessboardScene sc = test_scene();
  auto poses = test_poses(sc.board);
  std::vector<CornerView> views;
  for (std::size_t v = 0; v < poses.size(); ++v) views.push_back({"view" + std::to_string(v), true_corners(sc.camera, sc.board, poses[v])});
  IntrinsicsResult r = calibrate_from_corners(views, sc.board, sc.camera.width_px, sc.camera.height_px);
  test::TempDir dir;
  r.save(dir / "camera.json");
  Json j = read_json_file(dir / "camera.json");
  ASSERT_TRUE(j.contains("K") && j.contains("dist") && j.contains("rms_px") && j.contains("image_size"));
  EXPECT_EQ(j["K"].size(), 3u);
  EXPECT_EQ(j["dist"].size(), 5u);
  EXPECT_EQ(j["image_size"][0], 480);
  EXPECT_EQ(j["provenance"]["kind"], "intrinsics");
  IntrinsicsResult back = IntrinsicsResult::load(dir / "camera.json");
  EXPECT_DOUBLE_EQ(back.camera.fx(), r.camera.fx());
  EXPECT_DOUBLE_EQ(back.camera.dist[4], r.camera.dist[4]);
  EXPECT_EQ(back.views.size(), r.views.size());
  CameraModel m = load_camera_model(dir / "camera.json");
  EXPECT_DOUBLE_EQ(m.cy(), r.camera.cy());
  // A broken file names itself and the key.
  test::write_text(dir / "bad.json", R"({"K": [[1,0,0],[0,1,0]], "dist": [0,0,0,0,0], "image_size": [4, 4]})");
  EXPECT_THAT(test::error_message<DataError>([&] { load_camera_model(dir / "bad.json"); }),
              ::testing::AllOf(::testing::HasSubstr("bad.json"), ::testing::HasSubstr("'K'")));
}

TEST(CameraModelTest, UndistortInvertsDistortAndRayInvertsProject) {
  CameraModel c = test_camera();
  for (double x = -0.45; x <= 0.45; x += 0.05)
    for (double y = -0.35; y <= 0.35; y += 0.05) {
      Vec2 p(x, y);
      EXPECT_LT((c.undistort(c.distort(p)) - p).norm(), 1e-12);
      Vec3 P(x * 2.0, y * 2.0, 2.0);
      EXPECT_LT((c.ray(c.project(P)) - P.normalized()).norm(), 1e-12);
    }
}

namespace {

// Noisy corners of the twelve test poses seen by `cam`, each board `depth_scale` times
// further away (the same image coverage for a lens with that much more focal length).
std::vector<CornerView> noisy_views(const CameraModel& cam, const BoardSpec& board, double depth_scale,
                                    double noise_px, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> noise(0.0, noise_px);
  const Vec3 half(0.5 * (board.cols - 1) * board.square_m, 0.5 * (board.rows - 1) * board.square_m, 0.0);
  std::vector<CornerView> views;
  for (const Rigid3& p0 : test_poses(board)) {
    Rigid3 p = p0;
    const Vec3 centre = p0.rotation * half + p0.translation;
    p.translation.z() += (depth_scale - 1.0) * centre.z();
    CornerView v{"view" + std::to_string(views.size()), true_corners(cam, board, p)};
    for (auto& c : v.corners_px) c += Vec2(noise(rng), noise(rng));
    views.push_back(v);
  }
  return views;
}

}  // namespace

TEST(IntrinsicsSynthetic, AutoK3IsFixedWhereTheViewsCannotTellItAndKeptWhereTheyCan) {
  IntrinsicsOptions o;
  o.auto_fix_k3 = true;
  // A long lens (5x the focal length, the same image; the simulated rig's distortion, true
  // k3 = 0): k3 r^6 is not determined over a 9 deg field. The free fit's k3 (here -9.1e4 +-
  // 4.0e4, 2.3 sigma) is within 3 standard deviations of 0: held at 0.
  CameraModel narrow = test_camera();
  narrow.K(0, 0) *= 5.0;
  narrow.K(1, 1) *= 5.0;
  narrow.dist = {-0.21, 0.9, 0.0004, -0.0003, 0.0};
  const BoardSpec board = test_scene().board;
  IntrinsicsResult free = calibrate_from_corners(noisy_views(narrow, board, 5.0, 0.1, test::seed()), board,
                                                 narrow.width_px, narrow.height_px);
  IntrinsicsResult a = calibrate_from_corners(noisy_views(narrow, board, 5.0, 0.1, test::seed()), board, narrow.width_px,
                                              narrow.height_px, o);
  std::printf("narrow lens: free k3 %.4g +- %.4g (fx %.2f, true %.2f); auto: %s (%s), fx %.2f +- %.2f\n",
              free.camera.dist[4], free.std.dist[4], free.camera.fx(), narrow.fx(), a.k3.fixed ? "fixed" : "free",
              a.k3.note.c_str(), a.camera.fx(), a.std.fx);
  EXPECT_EQ(free.k3.mode, "free");
  EXPECT_FALSE(free.k3.fixed);
  EXPECT_LT(std::abs(free.camera.dist[4]), 3.0 * free.std.dist[4]);
  EXPECT_EQ(a.k3.mode, "auto");
  EXPECT_TRUE(a.k3.fixed);
  EXPECT_EQ(a.camera.dist[4], 0.0);
  EXPECT_EQ(a.std.dist[4], 0.0);
  EXPECT_THAT(a.k3.free_value, test::NearRel(free.camera.dist[4], 1e-6));
  EXPECT_THAT(a.k3.free_std, test::NearRel(free.std.dist[4], 1e-6));
  EXPECT_THAT(a.k3.note, ::testing::HasSubstr("k3 fixed at 0"));
  // 12 views of a small board through a long lens: the focal length to its 1-sigma (0.5 %).
  EXPECT_NEAR(a.camera.fx(), narrow.fx(), 3.0 * a.std.fx);

  // A wide lens with a strong k3 and sharp corners: determined, so kept.
  CameraModel wide = test_camera();
  wide.dist = {-0.30, 0.12, 0.0012, -0.0007, -2.0};
  IntrinsicsResult w = calibrate_from_corners(noisy_views(wide, board, 1.0, 0.01, test::seed() + 1), board,
                                              wide.width_px, wide.height_px, o);
  std::printf("wide lens: %s, k3 %.4f +- %.4f (true %.2f)\n", w.k3.fixed ? "fixed" : "free", w.camera.dist[4], w.std.dist[4],
              wide.dist[4]);
  EXPECT_EQ(w.k3.mode, "auto");
  EXPECT_FALSE(w.k3.fixed);
  EXPECT_NEAR(w.camera.dist[4], wide.dist[4], 3.0 * w.std.dist[4]);
  EXPECT_LT(3.0 * w.std.dist[4], std::abs(wide.dist[4]));
  EXPECT_THAT(w.k3.note, ::testing::HasSubstr("k3 fitted"));

  // camera.json says which.
  test::TempDir dir;
  a.save(dir / "camera.json");
  const Json j = read_json_file(dir / "camera.json");
  EXPECT_EQ(j["k3"]["mode"], "auto");
  EXPECT_TRUE(j["k3"]["fixed"].get<bool>());
  EXPECT_DOUBLE_EQ(j["k3"]["free_fit"]["k3"].get<double>(), a.k3.free_value);
  const IntrinsicsResult back = IntrinsicsResult::load(dir / "camera.json");
  EXPECT_TRUE(back.k3.fixed);
  EXPECT_EQ(back.k3.note, a.k3.note);
}

TEST(IntrinsicsSynthetic, AnImageTooSmallForTheBoardIsNotDetectedAndSaysWhy) {
  // OpenCV's detectors assert on images smaller than their filters: an 8 x 6 frame is a view
  // without a board, not a crash.
  const Image<std::uint16_t> tiny(8, 6, 1, 30000);
  const calib::ChessboardDetection d = calib::detect_chessboard(tiny, 16, calib::BoardSpec::parse("9x6", 20.0), {});
  EXPECT_FALSE(d.found);
  EXPECT_THAT(d.reason, ::testing::HasSubstr("8x6 px) is too small to hold a 9x6 chessboard"));
  // Rotated boards fit either way: 30 x 21 px holds a 9x6 board on its side too.
  const Image<std::uint16_t> enough(21, 30, 1, 30000);
  EXPECT_THAT(calib::detect_chessboard(enough, 16, calib::BoardSpec::parse("9x6", 20.0), {}).reason,
              ::testing::HasSubstr("no 9x6 chessboard found"));
}
