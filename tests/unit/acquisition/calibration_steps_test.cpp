// The geometric calibration steps from images to result (acquisition/calibration_steps.h),
// captured through in-memory devices whose camera sees a lit disc where the sphere is: the
// step mounts the right target, lights the LED, turns the table to each angle, fits, and
// records what it read; a step refuses before capturing when its inputs are missing.
#include "paintlab/acquisition/calibration_steps.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fmt/format.h>

#include <cmath>

#include "cap_rig.h"
#include "paintlab/calibration/intrinsics.h"
#include "paintlab/calibration/record.h"
#include "paintlab/core/error.h"
#include "test_util.h"

using namespace paintlab;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
namespace fs = std::filesystem;

namespace {

constexpr int kStepW = 200, kStepH = 160;
constexpr double kStepF = 1000.0, kDiscX = 110.0, kDiscY = 76.0, kDiscR = 40.0;

// A pinhole camera (no distortion) of kStepW x kStepH pixels, saved as the rig's camera.json.
void save_step_camera(const fs::path& dir) {
  calib::IntrinsicsResult r;
  r.camera.width_px = kStepW;
  r.camera.height_px = kStepH;
  r.camera.K << kStepF, 0, (kStepW - 1) / 2.0, 0, kStepF, (kStepH - 1) / 2.0, 0, 0, 1;
  r.views_used = 12;
  fs::create_directories(dir);
  r.save(dir / calib::kCameraFile);
}

// The white reference as a disc lit at 2e5 DN/s (its edge box-filtered over the pixel) on a
// dark background, only while the LED is on.
void show_disc(test::CapRig& r) {
  r.camera.width = kStepW;
  r.camera.height = kStepH;
  r.camera.image = [](int x, int y, double t, bool on) {
    const double d = std::hypot(x - kDiscX, y - kDiscY);
    const double inside = std::clamp(kDiscR - d + 0.5, 0.0, 1.0);
    return test::kCapBlackDn + (on ? 2e5 * t * inside : 0.0);
  };
}

RigConfig step_rig() {
  RigConfig rig;
  rig.file = "lab/rig.toml";
  rig.geometry.sphere_radius_m = 0.04;
  return rig;
}

}  // namespace

TEST(CalibrationSteps, EachGeometricStepSaysWhatItMountsAndHowItExposes) {
  EXPECT_EQ(acq::step_capture("sphere").target, acq::Target::WhiteReference);
  EXPECT_EQ(acq::step_capture("light").target, acq::Target::GlossySphere);
  EXPECT_DOUBLE_EQ(acq::step_capture("light").quantile, 1.0);
  EXPECT_DOUBLE_EQ(acq::step_capture("scale").quantile, 0.9999);
  for (const char* s : {"sphere", "light", "scale"}) EXPECT_TRUE(acq::step_capture(s).led_on) << s;
  EXPECT_THROW(acq::step_capture("dark"), UsageError);
}

TEST(CalibrationSteps, TheSphereStepCapturesTheLitReferenceAtEachAngleAndFindsItsCentre) {
  test::TempDir tmp;
  save_step_camera(tmp / "calib");
  test::CapRig r(tmp / "captures");
  show_disc(r);
  bool dark_capture = false;
  r.camera.on_capture = [&](int) { dark_capture = dark_capture || !r.light.state; };
  acq::StepImages in;
  in.capture = &r.rig;
  in.devices = {{"camera", "TEST-1"}};
  const calib::RigCalibration cal = calib::RigCalibration::load(tmp / "calib");
  const calib::SphereFit fit = acq::sphere_step(in, cal, step_rig(), {90.0, 270.0});

  EXPECT_THAT(r.stage.calls, ElementsAre("mount the white reference sphere"));
  EXPECT_FALSE(dark_capture);  // every frame with the LED on
  EXPECT_FALSE(r.light.state);  // and off afterwards
  EXPECT_EQ(r.table.angle_deg().value(), 270.0);
  // The disc's centre ray, at the distance where a 40 mm sphere subtends its 40 px radius.
  const Vec3 ray = cal.camera().ray(Vec2(kDiscX, kDiscY)).normalized();
  EXPECT_LT(std::acos(std::clamp(fit.centre_cam_m.normalized().dot(ray), -1.0, 1.0)), 0.2 / kStepF);
  const double distance = 0.04 / std::sin(std::atan(kDiscR / kStepF));
  EXPECT_NEAR(fit.centre_cam_m.norm(), distance, 0.01 * distance);
  // What it read: the two captures, kept in captures/sphere/, and the camera's serial.
  ASSERT_EQ(fit.provenance.inputs.size(), 2u);
  EXPECT_EQ(fs::path(fit.provenance.inputs[0].path).parent_path(), tmp / "captures" / "sphere");
  EXPECT_EQ(fit.provenance.devices["camera"], "TEST-1");
}

TEST(CalibrationSteps, AStepMissingItsCalibrationFilesOrImagesRefusesBeforeCapturing) {
  test::TempDir tmp;
  save_step_camera(tmp / "calib");
  test::CapRig r(tmp / "captures");
  show_disc(r);
  acq::StepImages in;
  in.capture = &r.rig;
  const calib::RigCalibration cal = calib::RigCalibration::load(tmp / "calib");
  EXPECT_THAT(test::error_message<CalibrationError>([&] { acq::light_step(in, cal, step_rig(), {0.0}); }),
              HasSubstr("sphere.json"));
  EXPECT_THROW(acq::scale_step(in, cal, step_rig(), {0.0}, 0.99), CalibrationError);  // sphere.json, light.json
  EXPECT_EQ(r.camera.captures, 0);
  EXPECT_TRUE(r.stage.calls.empty());
  // Neither files nor a rig to capture with.
  EXPECT_THAT(test::error_message<UsageError>([&] { acq::sphere_step(acq::StepImages{}, cal, step_rig(), {90.0}); }),
              HasSubstr("calibrate sphere: give --images or --capture"));
}

TEST(CalibrationSteps, TheDarkStepCapturesCappedFramesAndRecordsThemWithWhatElseItRead) {
  test::TempDir tmp;
  test::CapRig r(tmp / "captures");
  r.scene(1e5, 100.0);  // 100 DN/s of dark current
  acq::StackImages in;
  in.capture = &r.rig;
  in.capture_dir = tmp / "dark";
  in.also_read = {tmp / "rig-extra.json"};
  test::write_text(tmp / "rig-extra.json", "{}");
  EXPECT_THROW(acq::dark_step(in, {}, 1), UsageError);  // read noise needs two frames
  EXPECT_EQ(r.camera.captures, 0);
  const calib::DarkFrame d = acq::dark_step(in, {}, 3);
  EXPECT_THAT(r.stage.calls, ElementsAre("lens the lens cap", "lens nothing in front of the lens"));
  EXPECT_EQ(d.frame_count, 6);
  EXPECT_NEAR(d.mean_bias_dn, test::kCapBlackDn, 1.0);
  EXPECT_NEAR(d.mean_rate_dn_per_s, 100.0, 10.0);
  EXPECT_EQ(d.provenance.inputs.size(), 7u);  // six frames and the extra file
  // No stack and nothing to capture with.
  EXPECT_THROW(acq::dark_step(acq::StackImages{}, {}, 3), UsageError);
}

TEST(CalibrationSteps, TheResponseStepBracketsTheLitReferenceAndFindsALinearCamera) {
  test::TempDir tmp;
  test::CapRig r(tmp / "captures");
  r.scene(1e6);
  acq::StackImages in;
  in.capture = &r.rig;
  in.capture_dir = tmp / "response";
  calib::ResponseOptions o;
  o.black_dn = test::kCapBlackDn;
  EXPECT_THROW(acq::response_step(in, o, nullptr, 90.0, 2), UsageError);
  const acq::ResponseStep s = acq::response_step(in, o, nullptr, 90.0, 12);
  ASSERT_TRUE(s.captured);
  EXPECT_TRUE(s.captured->stack.images.empty());  // moved into the fit
  EXPECT_EQ(s.constant_ratio, 0.0);  // the capture's bracket has unequal steps
  EXPECT_THAT(r.stage.calls, ElementsAre("mount the white reference sphere"));
  EXPECT_EQ(s.curve.provenance.inputs.size(), 12u);
  EXPECT_LT(s.curve.report.linearity_error_rel, 0.02);
}

TEST(CalibrationSteps, TheFlatStepFromAStackCapturesNothing) {
  test::TempDir tmp;
  test::CapRig r(tmp / "captures");
  r.scene(0.0, 4e5);
  const calib::ExposureStack stack = acq::capture_flat_stack(r.rig, test::kCapBlackDn, 3, tmp / "flat");
  const int captured = r.camera.captures;
  acq::StackImages in;
  in.stack = stack;
  in.capture = &r.rig;  // ignored: the stack is given
  const calib::FlatField f = acq::flat_step(in, nullptr, nullptr, 3);
  EXPECT_EQ(r.camera.captures, captured);
  EXPECT_EQ(f.frame_count, 3);
  EXPECT_NEAR(f.corner_ratio, 1.0, 1e-6);  // a uniform field
  EXPECT_EQ(f.provenance.inputs.size(), 3u);
}

TEST(CalibrationSteps, TheIntrinsicsStepAsksTheStageForEachViewOrReadsTheFiles) {
  test::TempDir tmp;
  test::CapRig r(tmp / "captures");
  r.scene(0.0, 1e6);  // a blank view: no chessboard in it
  acq::StepImages in;
  in.capture = &r.rig;
  const calib::BoardSpec board = calib::BoardSpec::parse("9x6", 20.0);
  EXPECT_THAT(test::error_message<UsageError>([&] { acq::intrinsics_step(in, board, {}, 2); }),
              HasSubstr("--views 2: must be >= 3"));
  EXPECT_TRUE(r.stage.calls.empty());
  // Three blank views are captured, each shown by the stage; none can hold a board (8 x 6
  // pixels), which the error says.
  EXPECT_THAT(test::error_message<Error>([&] { acq::intrinsics_step(in, board, {}, 3); }),
              HasSubstr("too small to hold a 9x6 chessboard"));
  EXPECT_THAT(r.stage.calls, ElementsAre("board 0/3", "board 1/3", "board 2/3", "mount the sample sphere"));
  // From files: the captured views read back, nothing captured again.
  acq::StepImages files;
  for (int v = 0; v < 3; ++v) files.files.push_back(tmp / "captures" / "intrinsics" / fmt::format("view{:02d}.png", v));
  const int captured = r.camera.captures;
  EXPECT_THROW(acq::intrinsics_step(files, board, {}, 3), Error);
  EXPECT_EQ(r.camera.captures, captured);
  EXPECT_THROW(acq::intrinsics_step(acq::StepImages{}, board, {}, 3), UsageError);
}
