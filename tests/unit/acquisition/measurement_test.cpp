// Setting up a measurement (acquisition/measurement.h) with in-memory devices: the plan's
// exposures are checked against the camera before anything is written, missing calibration
// files say which step makes them, the manifest records what was measured, and the bracket
// merger builds one merger for the session.
#include "paintlab/acquisition/measurement.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "fake_rig.h"
#include "paintlab/calibration/record.h"
#include "paintlab/core/error.h"
#include "paintlab/core/hash.h"
#include "sim_rigs.h"
#include "test_util.h"

using namespace paintlab;
using ::testing::HasSubstr;
namespace fs = std::filesystem;

namespace {

RigConfig write_rig(const test::TempDir& tmp, int exposures = 4) {
  test::write_text(tmp / "rig.toml", test::small_sim_rig(5, 10.0, exposures));
  return RigConfig::load(tmp / "rig.toml");
}

}  // namespace

TEST(Measurement, CameraPreparationAppliesTheGainAndRefusesExposuresOutsideTheRange) {
  test::TempDir tmp;
  RigConfig rig = write_rig(tmp);
  rig.plan.gain_db = 3.0;
  test::FakeClock clock;
  test::FakeLight light;
  test::FakeCamera camera(clock, light);
  const acq::CameraPreparation c = acq::prepare_camera(camera, rig);
  EXPECT_DOUBLE_EQ(c.gain_db, 3.0);
  EXPECT_DOUBLE_EQ(camera.gain_db, 3.0);
  EXPECT_EQ(c.format, dev::PixelFormat::Mono16);
  EXPECT_DOUBLE_EQ(c.range.max_s, 1.0);

  camera.range = {1e-3, 0.1};  // the plan's 0.5 ms and 200 ms are outside
  EXPECT_THAT(test::error_message<DataError>([&] { acq::prepare_camera(camera, rig); }),
              ::testing::AllOf(HasSubstr("exposure 0.5 ms of the plan is outside the camera's range [1, 100] ms"),
                               HasSubstr("camera test"),
                               HasSubstr("nothing was written")));
}

TEST(Measurement, MissingCalibrationNamesTheStepAndUncalibratedRecordsWhatIsThere) {
  test::TempDir tmp;
  const RigConfig rig = write_rig(tmp);
  EXPECT_THAT(test::error_message<DataError>([&] { acq::prepare_measurement(rig, false, false); }),
              ::testing::AllOf(HasSubstr("response.json is missing: run `paintlab calibrate response --rig"),
                               HasSubstr("--uncalibrated")));
  fs::create_directories(rig.calibration_dir);
  test::write_text(rig.calibration_dir / calib::kCameraFile, "{}");
  const acq::MeasureSetup s = acq::prepare_measurement(rig, true, false);
  EXPECT_FALSE(s.hdr.response);
  EXPECT_FALSE(s.hdr.dark);
  EXPECT_FALSE(s.sphere_mask);
  ASSERT_TRUE(s.calibration_checksums.contains(calib::kCameraFile));
  EXPECT_EQ(s.calibration_checksums[calib::kCameraFile], sha256_file(rig.calibration_dir / calib::kCameraFile));
  EXPECT_EQ(s.calibration_checksums.size(), 1u);
  // Adaptive bracketing needs the sphere's outline: a clear error without sphere.json.
  EXPECT_THROW(acq::prepare_measurement(rig, true, true), Error);
}

TEST(Measurement, ManifestRecordsRigPlanCameraAndOptions) {
  test::TempDir tmp;
  const RigConfig rig = write_rig(tmp, 3);
  acq::MeasureSetup setup;
  setup.calibration_checksums = {{"dark.json", "abc"}};
  acq::CameraPreparation cam;
  cam.gain_db = 1.5;
  cam.format = dev::PixelFormat::Mono12;
  acq::ManifestInput in;
  in.sample = "panel-7";
  in.operator_name = "jo";
  in.devices = {{"camera", {{"id", "camera test"}}}};
  in.options.adaptive = true;
  const acq::SessionManifest m = acq::make_manifest(rig, setup, cam, in);
  EXPECT_EQ(m.sample, "panel-7");
  EXPECT_EQ(m.operator_name, "jo");
  EXPECT_EQ(m.rig_name, "test-sim-rig");
  EXPECT_EQ(m.rig_file, rig.file.string());
  EXPECT_EQ(m.rig_sha256, sha256_file(rig.file));
  EXPECT_EQ(m.angles_deg, rig.plan.angles_deg());
  EXPECT_EQ(m.exposures_s.size(), 3u);
  EXPECT_DOUBLE_EQ(m.gain_db, 1.5);
  EXPECT_EQ(m.calibration, setup.calibration_checksums);
  EXPECT_TRUE(m.options.adaptive);
  EXPECT_EQ(m.options.pixel_format, "Mono12");
  EXPECT_FALSE(m.created_utc.empty());
  // It is a valid session manifest.
  EXPECT_EQ(acq::SessionManifest::from_json(m.to_json(), "test").sample, "panel-7");
}

TEST(Measurement, SessionOptionsRoundTripAndAMistypedKeyIsRefused) {
  acq::SessionOptions o;
  o.keep_raw = true;
  o.uncalibrated = true;
  o.pixel_format = "Mono12";
  o.sim_paint = Json{{"name", "p"}, {"model", "cook-torrance"}};
  const acq::SessionOptions back = acq::SessionOptions::from_json(o.to_json(), "s/session.json");
  EXPECT_TRUE(back.keep_raw);
  EXPECT_FALSE(back.adaptive);
  EXPECT_TRUE(back.uncalibrated);
  EXPECT_EQ(back.pixel_format, "Mono12");
  EXPECT_EQ(back.sim_paint, o.sim_paint);
  // Sessions written before a key existed read it as its default.
  EXPECT_FALSE(acq::SessionOptions::from_json(Json::object(), "s/session.json").keep_raw);
  EXPECT_TRUE(acq::SessionOptions::from_json(Json::object(), "s/session.json").sim_paint.is_null());
  EXPECT_THAT(test::error_message<DataError>([&] { acq::SessionOptions::from_json(Json{{"keep_raws", true}}, "s/session.json"); }),
              HasSubstr("s/session.json: options: unknown key 'keep_raws'"));
  EXPECT_THAT(test::error_message<DataError>([&] { acq::SessionOptions::from_json(Json{{"adaptive", "yes"}}, "s/session.json"); }),
              HasSubstr("adaptive"));
  EXPECT_THROW(acq::SessionOptions::from_json(Json{{"sim_paint", 3}}, "s/session.json"), DataError);
}

TEST(Measurement, BracketMergerMergesEveryBracketWithOneMerger) {
  acq::BracketMerger merge(acq::HdrCalibration{}, 16);
  acq::MergeFn fn = merge.function();
  std::vector<dev::Frame> frames(2);
  for (int k = 0; k < 2; ++k) {
    frames[k].pixels = Image<std::uint16_t>(6, 4, 1, static_cast<std::uint16_t>(1000 * (k + 1)));
    frames[k].meta.exposure_s = 0.01 * (k + 1);
  }
  const ExrImage a = fn(frames);
  const acq::HdrMerger* first = merge.merger();
  ASSERT_NE(first, nullptr);
  const ExrImage b = fn(frames);
  EXPECT_EQ(merge.merger(), first);
  EXPECT_EQ(a.attributes.at("paintlab.valid_pixels"), "24");
  EXPECT_EQ(a.attributes.at("paintlab.saturated_pixels"), "0");
  EXPECT_NEAR(a.planes.front().values()[0], 1e5, 1e5 * 1e-3);  // 1000 DN in 10 ms, 2000 DN in 20 ms
  EXPECT_EQ(a.planes.front().values()[0], b.planes.front().values()[0]);
  EXPECT_THROW(fn({}), DataError);
}
