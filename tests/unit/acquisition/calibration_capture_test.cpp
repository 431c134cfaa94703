// The capture side of the calibration steps and the live check (acquisition/calibration_capture.h)
// with in-memory devices and a stage that records what it was asked to show: each step puts
// the right thing in front of the camera, exposes where it says, leaves the LED off and the
// lens uncovered, and keeps its frames.
#include "paintlab/acquisition/calibration_capture.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "cap_rig.h"
#include "paintlab/core/error.h"
#include "test_util.h"

using namespace paintlab;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
namespace fs = std::filesystem;
using test::CapRig;
using test::kCapBlackDn;
using test::kCapFullDn;

namespace {

double cap_level_of(double rate, double t) { return std::min(rate * t, kCapFullDn - kCapBlackDn) / (kCapFullDn - kCapBlackDn); }

}  // namespace

TEST(CalibrationBracket, SpansMinToMaxWithUnequalSteps) {
  const std::vector<double> t = acq::calibration_bracket(0.001, 0.256, 16);
  ASSERT_EQ(t.size(), 16u);
  EXPECT_DOUBLE_EQ(t.front(), 0.001);
  EXPECT_NEAR(t.back(), 0.256, 1e-12);
  for (std::size_t i = 1; i < t.size(); ++i) EXPECT_GT(t[i], t[i - 1]);
  double ratio = 0.0;
  EXPECT_FALSE(acq::constant_ratio(t, &ratio));
  // A plain geometric bracket is recognised, in any order.
  EXPECT_TRUE(acq::constant_ratio({0.004, 0.001, 0.002, 0.008}, &ratio));
  EXPECT_NEAR(ratio, 2.0, 1e-12);
  EXPECT_FALSE(acq::constant_ratio({0.001, 0.002}, &ratio));  // two exposures: no steps to compare
  EXPECT_THROW(acq::calibration_bracket(0.01, 0.001, 16), UsageError);
  EXPECT_THROW(acq::calibration_bracket(0.001, 0.01, 2), UsageError);
}

TEST(CalibrationCapture, DarkFramesAreTakenCappedWithTheLedOffAtThePlansEnds) {
  test::TempDir tmp;
  CapRig r(tmp / "captures");
  r.scene(1e5, 200.0);  // 200 DN/s of dark current
  bool lit = false;
  r.camera.on_capture = [&](int) { lit = lit || r.light.state; };
  const calib::ExposureStack s = acq::capture_dark_stack(r.rig, 3, tmp / "dark");
  EXPECT_FALSE(lit);
  EXPECT_THAT(r.stage.calls, ElementsAre("lens the lens cap", "lens nothing in front of the lens"));
  ASSERT_EQ(s.images.size(), 6u);
  EXPECT_DOUBLE_EQ(s.exposures_s.front(), 0.00025);
  EXPECT_DOUBLE_EQ(s.exposures_s.back(), 0.328);
  EXPECT_EQ(s.images.back().values()[0], static_cast<std::uint16_t>(std::round(kCapBlackDn + 200.0 * 0.328)));
  EXPECT_DOUBLE_EQ(r.camera.gain_db, 3.0);
  EXPECT_TRUE(fs::exists(tmp / "dark" / "exposures.txt"));
  EXPECT_THROW(acq::capture_dark_stack(r.rig, 1, tmp / "dark1"), UsageError);  // read noise needs two
}

TEST(CalibrationCapture, TheResponseBracketIsAnchoredOnTheLitReferenceAndSpans256x) {
  test::TempDir tmp;
  CapRig r(tmp / "captures");
  r.scene(1e6);
  const acq::ResponseCapture c = acq::capture_response_stack(r.rig, -90.0, kCapBlackDn, 12, tmp / "response");
  EXPECT_THAT(r.stage.calls, ElementsAre("mount the white reference sphere"));
  EXPECT_EQ(r.table.angle_deg().value(), 270.0);
  EXPECT_NEAR(cap_level_of(1e6, c.top_s), acq::kResponseTopFill, 0.1 * acq::kResponseTopFill);
  EXPECT_NEAR(c.min_s, c.top_s / 32.0, 1e-12);
  EXPECT_NEAR(c.max_s, c.top_s * 8.0, 1e-12);
  ASSERT_EQ(c.stack.images.size(), 12u);
  EXPECT_NEAR(c.stack.exposures_s.front(), c.min_s, 1e-5);  // the camera's 10 us steps
  EXPECT_NEAR(c.stack.exposures_s.back(), c.max_s, 1e-5);
  EXPECT_FALSE(acq::constant_ratio(c.stack.exposures_s, nullptr));
  EXPECT_FALSE(r.light.state);
}

TEST(CalibrationCapture, AResponseBracketTheCameraCannotTakeSaysWhyAndLeavesTheLedOff) {
  test::TempDir tmp;
  CapRig r(tmp / "captures");
  r.scene(1e6);
  r.camera.range = {0.09, 0.1};  // far too bright for this camera's exposures
  EXPECT_THAT(test::error_message<CalibrationError>([&] { acq::capture_response_stack(r.rig, 90.0, kCapBlackDn, 12, tmp / "response"); }),
              HasSubstr("leaves no bracket"));
  EXPECT_FALSE(r.light.state);
  EXPECT_FALSE(fs::exists(tmp / "response" / "exposures.txt"));
}

TEST(CalibrationCapture, FlatFramesAreTakenThroughTheDiffuserAtSixtyPercent) {
  test::TempDir tmp;
  CapRig r(tmp / "captures");
  r.scene(0.0, 4e5);  // the diffuser's light, with the LED off
  const calib::ExposureStack s = acq::capture_flat_stack(r.rig, kCapBlackDn, 4, tmp / "flat");
  EXPECT_THAT(r.stage.calls, ElementsAre("lens the diffuser", "lens nothing in front of the lens"));
  ASSERT_EQ(s.images.size(), 4u);
  EXPECT_NEAR(cap_level_of(4e5, s.exposures_s[0]), 0.6, 0.06);
  EXPECT_FALSE(r.light.state);
}

TEST(CalibrationCapture, BoardViewsAreShownOneByOneAndTheSampleMountedAfter) {
  test::TempDir tmp;
  CapRig r(tmp / "captures");
  r.scene(0.0, 1e6);
  const acq::BoardViews v = acq::capture_board_views(r.rig, calib::BoardSpec::parse("9x6", 20.0), 3);
  EXPECT_THAT(r.stage.calls, ElementsAre("board 0/3", "board 1/3", "board 2/3", "mount the sample sphere"));
  ASSERT_EQ(v.images.size(), 3u);
  EXPECT_EQ(v.images[1].name, "view01");
  EXPECT_EQ(v.images[1].bit_depth, 16);
  EXPECT_EQ(v.files[2], tmp / "captures" / "intrinsics" / "view02.png");
  EXPECT_TRUE(fs::exists(v.files[2]));
  EXPECT_THROW(acq::capture_board_views(r.rig, calib::BoardSpec::parse("9x6", 20.0), 2), UsageError);
}

TEST(CalibrationCapture, StepShotsTurnTheTableAndBecomeHighlightAndReferenceImages) {
  test::TempDir tmp;
  CapRig r(tmp / "captures");
  r.scene(1e6);
  const std::vector<acq::Shot> shots =
      acq::capture_shots(r.rig, "light", {-30.0, 40.0}, acq::Target::GlossySphere, true, 0.8, 1.0);
  EXPECT_THAT(r.stage.calls, ElementsAre("mount the glossy calibration sphere"));
  ASSERT_EQ(shots.size(), 2u);
  EXPECT_EQ(shots[0].name, "light_angle-30");
  EXPECT_EQ(*shots[1].table_angle_deg, 40.0);
  EXPECT_EQ(r.table.angle_deg().value(), 40.0);
  EXPECT_FALSE(r.light.state);

  // Clipped pixels are +inf in a highlight image.
  acq::Shot clipped = shots[0];
  clipped.saturated.values()[0] = 1;
  const calib::HighlightImage h = acq::highlight_image(clipped, "calibrate light");
  EXPECT_EQ(h.table_angle_deg, -30.0);
  EXPECT_EQ(h.pixels.values()[0], std::numeric_limits<float>::infinity());
  EXPECT_EQ(h.pixels.values()[1], clipped.rate.values()[1]);
  const calib::ReferenceImage ref = acq::reference_image(shots[1], "calibrate scale");
  EXPECT_EQ(ref.table_angle_deg, 40.0);

  // Files without the angle or the exposure in their names say which and how to name them.
  acq::Shot unnamed = shots[0];
  unnamed.table_angle_deg.reset();
  unnamed.file = "light/IMG_0001.png";
  EXPECT_THAT(test::error_message<UsageError>([&] { acq::highlight_image(unnamed, "calibrate light"); }),
              HasSubstr("calibrate light: light/IMG_0001.png: the table angle is not in the file name"));
  acq::Shot no_exposure = shots[1];
  no_exposure.per_second = false;
  EXPECT_THROW(acq::reference_image(no_exposure, "calibrate scale"), UsageError);
}

TEST(CalibrationCapture, ALiveCheckWithoutTheGeometryIsOneFailedItemThatSaysWhatToRun) {
  test::TempDir tmp;
  CapRig r(tmp / "captures");
  RigConfig config;
  config.file = "lab/rig.toml";
  const calib::RigCalibration empty = calib::RigCalibration::load(tmp / "no-calibration");
  const acq::LiveCheck live = acq::capture_live_check(r.rig, empty, config);
  ASSERT_EQ(live.failed.size(), 1u);
  EXPECT_FALSE(live.failed[0].pass);
  EXPECT_THAT(live.failed[0].action, HasSubstr("paintlab calibrate all --rig lab/rig.toml"));
  EXPECT_EQ(r.camera.captures, 0);  // nothing captured
  acq::Linearizer lin;
  EXPECT_THROW(acq::live_check_from_images(tmp.path(), empty, config, lin), CalibrationError);
}
