// Real data: Debevec and Malik's Memorial Church stack (../shared/data/debevec-memorial).
// Recover the response, merge, and compare with their own radiance map memorial.hdr in
// natural-log radiance after one scale per channel, over pixels that are not registration
// border (pure blue) in any photo. OpenCV 4.6's Calibrate/Merge Robertson and Debevec are
// run on the same data and compared the same way, in the same run.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/photo.hpp>
#include <sstream>

#include "paintlab/acquisition/hdr_merge.h"
#include "paintlab/calibration/exposure_stack.h"
#include "paintlab/calibration/response.h"
#include "test_util.h"

using namespace paintlab;
namespace fs = std::filesystem;

namespace {

struct Memorial {
  std::vector<fs::path> files;
  std::vector<double> exposures_s;
  calib::ExposureStack stack;
  std::vector<std::uint8_t> border;  // per pixel: pure blue in some photo
  cv::Mat reference;                 // memorial.hdr, BGR float
};

bool load(Memorial* m) {
  const fs::path dir = test::shared_data_dir() / "debevec-memorial";
  if (!fs::exists(dir / "image_list.txt") || !fs::exists(dir / "memorial.hdr")) return false;
  std::ifstream in(dir / "image_list.txt");
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream ss(line);
    std::string file;
    double relative = 0.0, inverse_shutter = 0.0;
    if (!(ss >> file >> relative >> inverse_shutter)) continue;
    m->files.push_back(dir / file);
    m->exposures_s.push_back(1.0 / inverse_shutter);  // the column is 1 / exposure time
  }
  m->stack = calib::load_exposure_stack(m->files, m->exposures_s);
  const std::size_t P = m->stack.images[0].pixel_count();
  m->border.assign(P, 0);
  for (const auto& img : m->stack.images)
    for (std::size_t p = 0; p < P; ++p)
      if (img.data()[3 * p] == 0 && img.data()[3 * p + 1] == 0 && img.data()[3 * p + 2] == 255) m->border[p] = 1;
  m->reference = cv::imread((dir / "memorial.hdr").string(), cv::IMREAD_ANYDEPTH | cv::IMREAD_ANYCOLOR);
  return !m->reference.empty();
}

// RMS of ln(ours / reference) after the best scale per channel (the mean log ratio), over
// non-border pixels where both are positive. get(p, c) gives RGB channel c of pixel p.
template <class Get>
double log_rms(const Memorial& m, Get&& get, long* compared = nullptr) {
  const std::size_t P = m.border.size();
  const auto* ref = m.reference.ptr<cv::Vec3f>();
  double offset[3] = {0, 0, 0};
  long count[3] = {0, 0, 0};
  for (std::size_t p = 0; p < P; ++p) {
    if (m.border[p]) continue;
    for (int c = 0; c < 3; ++c) {
      const double a = get(p, c), b = ref[p][2 - c];
      if (!(a > 0.0 && b > 0.0)) continue;
      offset[c] += std::log(a / b);
      ++count[c];
    }
  }
  for (int c = 0; c < 3; ++c) offset[c] /= static_cast<double>(count[c]);
  double sq = 0.0;
  long n = 0;
  for (std::size_t p = 0; p < P; ++p) {
    if (m.border[p]) continue;
    for (int c = 0; c < 3; ++c) {
      const double a = get(p, c), b = ref[p][2 - c];
      if (!(a > 0.0 && b > 0.0)) continue;
      const double d = std::log(a / b) - offset[c];
      sq += d * d;
      ++n;
    }
  }
  if (compared) *compared = n;
  return std::sqrt(sq / static_cast<double>(n));
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

TEST(Memorial, BeatsOpenCvAgainstDebevecsRadianceMap) {
  Memorial m;
  if (!load(&m)) GTEST_SKIP() << "debevec-memorial data not found under " << test::shared_data_dir();
  ASSERT_EQ(m.files.size(), 16u);
  EXPECT_DOUBLE_EQ(m.exposures_s.front(), 32.0);
  EXPECT_DOUBLE_EQ(m.exposures_s.back(), 1.0 / 1024);
  const auto frames = m.stack.frames();

  // Ours: Robertson's method over all pixels (borders declared as no-data), merged with the
  // default weighting (inverse variance from the response's residual spread).
  calib::ResponseOptions opt;
  opt.no_data = {0, 0, 255};
  auto t0 = std::chrono::steady_clock::now();
  acq::HdrCalibration cal;
  cal.response = calib::recover_response(frames, 8, opt);
  const double t_response = seconds_since(t0);
  t0 = std::chrono::steady_clock::now();
  const acq::HdrResult ours = acq::merge_hdr(frames, 8, cal);
  const double t_merge = seconds_since(t0);
  EXPECT_EQ(ours.stats.weighting, "inverse-variance");
  const ImageF* planes[3] = {&ours.image.plane("R"), &ours.image.plane("G"), &ours.image.plane("B")};
  long compared = 0;
  const double ours_rms = log_rms(m, [&](std::size_t p, int c) { return planes[c]->data()[p]; }, &compared);

  // Ours with Debevec's method (log domain, hat weights), same merge.
  calib::ResponseOptions dopt = opt;
  dopt.method = calib::ResponseMethod::Debevec;
  acq::HdrCalibration dcal;
  dcal.response = calib::recover_response(frames, 8, dopt);
  const acq::HdrResult ours_d = acq::merge_hdr(frames, 8, dcal);
  const ImageF* dplanes[3] = {&ours_d.image.plane("R"), &ours_d.image.plane("G"), &ours_d.image.plane("B")};
  const double ours_d_rms = log_rms(m, [&](std::size_t p, int c) { return dplanes[c]->data()[p]; });

  // OpenCV 4.6 with its defaults on the 8-bit photos as read by OpenCV (BGR; channels are
  // independent), compared the same way.
  std::vector<cv::Mat> images;
  std::vector<float> times;
  for (std::size_t j = 0; j < m.files.size(); ++j) {
    images.push_back(cv::imread(m.files[j].string()));
    times.push_back(static_cast<float>(m.exposures_s[j]));
  }
  cv::Mat resp_r, hdr_r, resp_d, hdr_d;
  t0 = std::chrono::steady_clock::now();
  cv::createCalibrateRobertson()->process(images, resp_r, times);
  cv::createMergeRobertson()->process(images, hdr_r, times, resp_r);
  const double t_cv_r = seconds_since(t0);
  t0 = std::chrono::steady_clock::now();
  cv::createCalibrateDebevec()->process(images, resp_d, times);
  cv::createMergeDebevec()->process(images, hdr_d, times, resp_d);
  const double t_cv_d = seconds_since(t0);
  const double cv_r = log_rms(m, [&](std::size_t p, int c) { return hdr_r.ptr<cv::Vec3f>()[p][2 - c]; });
  const double cv_d = log_rms(m, [&](std::size_t p, int c) { return hdr_d.ptr<cv::Vec3f>()[p][2 - c]; });

  std::printf("Memorial Church vs memorial.hdr, RMS of ln ratio over %ld non-border values:\n", compared);
  std::printf("  ours (Robertson response, inverse-variance merge)   %.4f  (response %.2f s, merge %.3f s)\n",
              ours_rms, t_response, t_merge);
  std::printf("  ours (Debevec response, inverse-variance merge)     %.4f\n", ours_d_rms);
  std::printf("  OpenCV CalibrateRobertson + MergeRobertson          %.4f  (%.2f s)\n", cv_r, t_cv_r);
  std::printf("  OpenCV CalibrateDebevec + MergeDebevec              %.4f  (%.2f s)\n", cv_d, t_cv_d);
  std::printf("  response: linearity error %.4f, valid pixels %lld of %lld\n",
              cal.response->report.linearity_error_rel, ours.stats.valid, ours.stats.pixels);
  // The figures measured by the issue with OpenCV 4.6: 0.093 and 0.320.
  EXPECT_NEAR(cv_r, 0.093, 0.01);
  EXPECT_NEAR(cv_d, 0.320, 0.02);
  EXPECT_LT(ours_rms, cv_r);
  EXPECT_LT(ours_rms, cv_d);
  EXPECT_LT(ours_d_rms, cv_d);
  EXPECT_EQ(ours.stats.valid, ours.stats.pixels);
}
