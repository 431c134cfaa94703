// Intrinsics on real photos: OpenCV's own sample chessboard photos (Debian opencv-doc,
// examples/data/left01..left14.jpg; left10 does not exist, so 13 photos, 9x6 inner corners).
// The same run computes OpenCV's sample procedure (findChessboardCorners + cornerSubPix
// with winSize 11x11 + calibrateCamera, 5 coefficients) as the baseline.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "paintlab/calibration/intrinsics.h"
#include "paintlab/core/image_io.h"
#include "test_util.h"

namespace fs = std::filesystem;
using namespace paintlab;
using namespace paintlab::calib;

namespace {

const fs::path kDataDir = "/usr/share/doc/opencv-doc/examples/data";

std::vector<fs::path> sample_photos() {
  std::vector<fs::path> out;
  for (int i = 1; i <= 14; ++i) {
    char name[32];
    std::snprintf(name, sizeof name, "left%02d.jpg", i);
    if (fs::exists(kDataDir / name)) out.push_back(kDataDir / name);
  }
  return out;
}

// OpenCV's samples/cpp/calibration.cpp procedure.
double opencv_baseline_rms(const std::vector<fs::path>& files, cv::Mat* K, cv::Mat* std_intr, int* views) {
  std::vector<std::vector<cv::Point2f>> image_points;
  cv::Size size;
  for (const auto& f : files) {
    cv::Mat gray = cv::imread(f.string(), cv::IMREAD_GRAYSCALE);
    size = gray.size();
    std::vector<cv::Point2f> c;
    if (!cv::findChessboardCorners(gray, cv::Size(9, 6), c,
                                   cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_FAST_CHECK | cv::CALIB_CB_NORMALIZE_IMAGE))
      continue;
    cv::cornerSubPix(gray, c, cv::Size(11, 11), cv::Size(-1, -1),
                     cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 30, 0.0001));
    image_points.push_back(c);
  }
  std::vector<cv::Point3f> board;
  for (int r = 0; r < 6; ++r)
    for (int c = 0; c < 9; ++c) board.emplace_back(c * 0.025f, r * 0.025f, 0.0f);
  std::vector<std::vector<cv::Point3f>> object_points(image_points.size(), board);
  cv::Mat D, std_extr, per_view;
  std::vector<cv::Mat> rv, tv;
  *views = static_cast<int>(image_points.size());
  return cv::calibrateCamera(object_points, image_points, size, *K, D, rv, tv, *std_intr, std_extr, per_view, 0);
}

std::vector<BoardImage> load_photos(const std::vector<fs::path>& files, bool as_16bit) {
  std::vector<BoardImage> out;
  for (const auto& f : files) {
    RawImage raw = read_raw_image(f);
    BoardImage b{f.filename().string(), std::move(raw.pixels), raw.bit_depth};
    if (as_16bit) {
      for (auto& v : b.pixels.values()) v = static_cast<std::uint16_t>(v * 257);
      b.bit_depth = 16;
    }
    out.push_back(std::move(b));
  }
  return out;
}

}  // namespace

TEST(IntrinsicsRealPhotos, AllThirteenViewsBelowQuarterPixelAndBetterThanOpenCv) {
  auto files = sample_photos();
  ASSERT_FALSE(files.empty()) << "opencv-doc sample photos missing under " << kDataDir << " (scripts/setup.sh installs opencv-doc)";
  ASSERT_EQ(files.size(), 13u);

  cv::Mat K0, std0;
  int views0 = 0;
  const double rms0 = opencv_baseline_rms(files, &K0, &std0, &views0);
  std::printf("OpenCV sample procedure: views %d, RMS %.4f px, fx %.2f +- %.2f, fy %.2f +- %.2f\n", views0, rms0,
              K0.at<double>(0, 0), std0.at<double>(0), K0.at<double>(1, 1), std0.at<double>(1));

  IntrinsicsResult r = calibrate_intrinsics(load_photos(files, false), BoardSpec{9, 6, 0.025});
  std::printf("paintlab saddle fit:     views %d, RMS %.4f px, fx %.2f +- %.2f, fy %.2f +- %.2f, "
              "cx %.2f +- %.2f, cy %.2f +- %.2f, worst %.3f px, corner std %.3f px, blur %.2f px\n",
              r.views_used, r.rms_px, r.camera.fx(), r.std.fx, r.camera.fy(), r.std.fy, r.camera.cx(), r.std.cx,
              r.camera.cy(), r.std.cy, r.worst_px, r.median_corner_std_px, r.blur_sigma_px);
  for (const auto& v : r.views) std::printf("  %s: rms %.3f max %.3f px\n", v.name.c_str(), v.rms_px, v.max_px);

  EXPECT_EQ(views0, 13);
  EXPECT_NEAR(rms0, 0.41, 0.02);  // the published figure of OpenCV's procedure
  EXPECT_EQ(r.views_used, 13);
  EXPECT_EQ(r.views_dropped, 0);
  EXPECT_LE(r.rms_px, 0.25);
  EXPECT_LT(r.rms_px, 0.6 * rms0);
  // Same lens: the focal lengths agree within the baseline's uncertainty band.
  EXPECT_NEAR(r.camera.fx(), K0.at<double>(0, 0), 4.0 * std0.at<double>(0) + 1.0);
  EXPECT_NEAR(r.camera.fy(), K0.at<double>(1, 1), 4.0 * std0.at<double>(1) + 1.0);
  // Smaller corner noise gives smaller parameter uncertainty.
  EXPECT_LT(r.std.fx, std0.at<double>(0));
  EXPECT_GT(r.std.fx, 0.0);
}

TEST(IntrinsicsRealPhotos, SixteenBitInputGivesTheSameCamera) {
  auto files = sample_photos();
  ASSERT_FALSE(files.empty()) << "opencv-doc sample photos missing under " << kDataDir << " (scripts/setup.sh installs opencv-doc)";
  files.resize(6);  // enough views, keeps the test fast
  IntrinsicsResult a = calibrate_intrinsics(load_photos(files, false), BoardSpec{9, 6, 0.025});
  IntrinsicsResult b = calibrate_intrinsics(load_photos(files, true), BoardSpec{9, 6, 0.025});
  EXPECT_EQ(b.bit_depth, 16);
  EXPECT_EQ(a.views_used, b.views_used);
  EXPECT_NEAR(a.rms_px, b.rms_px, 1e-3);
  EXPECT_NEAR(a.camera.fx(), b.camera.fx(), 1e-2);
  EXPECT_NEAR(a.camera.cy(), b.camera.cy(), 1e-2);
}
