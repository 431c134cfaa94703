// Real data: Debevec and Malik's Memorial Church stack against their radiance map
// memorial.hdr (memorial_data.h), ours only, against the figures OpenCV 4.6 gets on exactly
// this comparison (0.093 with CalibrateRobertson + MergeRobertson, 0.320 with Debevec's pair;
// memorial_opencv.cpp, labelled slow, recomputes them in the same run).
#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>

#include "memorial_data.h"
#include "paintlab/acquisition/hdr_merge.h"
#include "paintlab/calibration/response.h"
#include "test_util.h"

using namespace paintlab;
using namespace paintlab::memorial_test;

TEST(Memorial, OursBeatsOpenCvsFiguresAgainstDebevecsRadianceMap) {
  Memorial m;
  ASSERT_TRUE(load(&m)) << "debevec-memorial data missing or unreadable under " << test::data_dir();
  ASSERT_EQ(m.files.size(), 16u);
  const auto frames = m.stack.frames();
  calib::ResponseOptions opt;
  opt.no_data = {0, 0, 255};
  for (auto method : {calib::ResponseMethod::Robertson, calib::ResponseMethod::Debevec}) {
    opt.method = method;
    const auto t0 = std::chrono::steady_clock::now();
    acq::HdrCalibration cal;
    cal.response = calib::recover_response(frames, 8, opt);
    const acq::HdrResult ours = acq::merge_hdr(frames, 8, cal);
    const double seconds = seconds_since(t0);
    const ImageF* planes[3] = {&ours.image.plane("R"), &ours.image.plane("G"), &ours.image.plane("B")};
    long compared = 0;
    const double rms = log_rms(m, [&](std::size_t p, int c) { return planes[c]->data()[p]; }, &compared);
    std::printf("Memorial Church, ours (%s response, %s merge): RMS of ln ratio %.4f over %ld values (%.2f s)\n",
                calib::to_string(method), ours.stats.weighting.c_str(), rms, compared, seconds);
    EXPECT_EQ(ours.stats.valid, ours.stats.pixels);
    EXPECT_GT(compared, 1000000);
    if (method == calib::ResponseMethod::Robertson) {
      EXPECT_LT(rms, 0.093);
    }
    EXPECT_LT(rms, 0.320);
  }
}
