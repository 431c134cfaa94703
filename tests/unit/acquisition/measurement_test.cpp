// Setting up a measurement (acquisition/measurement.h) with in-memory devices: the plan's
// exposures are checked against the camera before anything is written, missing calibration
// files say which step makes them, the manifest records what was measured, and the bracket
// merger builds one merger for the session.
#include "paintlab/acquisition/measurement.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "fake_rig.h"
#include "paintlab/calibration/colour.h"
#include "paintlab/calibration/record.h"
#include "paintlab/calibration/scale.h"
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

TEST(Measurement, AColourCameraNeedsItsColourAndPerChannelScaleUnlessUncalibrated) {
  test::TempDir tmp;
  const RigConfig rig = write_rig(tmp);
  // A monochrome camera: nothing to do.
  EXPECT_EQ(acq::prepare_colour(rig, dev::PixelFormat::Mono16, false).pattern, dev::CfaPattern::None);
  // Uncalibrated: camera RGB as recorded.
  const acq::ColourMap raw = acq::prepare_colour(rig, dev::PixelFormat::BayerGR12, true);
  EXPECT_EQ(raw.pattern, dev::CfaPattern::GR);
  EXPECT_EQ(raw.colour_space, "linear camera RGB");
  EXPECT_FALSE(raw.matrix);
  fs::create_directories(rig.calibration_dir);
  EXPECT_THAT(test::error_message<DataError>([&] { acq::prepare_colour(rig, dev::PixelFormat::BayerRG16, false); }),
              ::testing::AllOf(HasSubstr("colour.json is missing"), HasSubstr("BayerRG16"),
                               HasSubstr("paintlab calibrate colour --rig")));
  // A colour calibration: camera white (2, 1, 1.5), XYZ = M rgb with M = sRGB->XYZ diag(1/white).
  calib::ColourCalibration cc;
  cc.camera_white = colour::Rgb(2.0, 1.0, 1.5);
  cc.matrix = colour::srgb_to_xyz_matrix() * cc.camera_white.cwiseInverse().asDiagonal();
  cc.save(rig.calibration_dir / calib::kColourFile);
  EXPECT_THAT(test::error_message<DataError>([&] { acq::prepare_colour(rig, dev::PixelFormat::BayerRG16, false); }),
              ::testing::AllOf(HasSubstr("scale.json is missing"), HasSubstr("calibrate scale")));
  calib::ScaleCalibration sc;
  sc.scale = 10.0;
  sc.save(rig.calibration_dir / calib::kScaleFile);
  EXPECT_THAT(test::error_message<DataError>([&] { acq::prepare_colour(rig, dev::PixelFormat::BayerRG16, false); }),
              HasSubstr("no per-channel scale (scale_rgb)"));
  sc.scale_rgb = std::array<double, 3>{20.0, 10.0, 15.0};
  sc.save(rig.calibration_dir / calib::kScaleFile);
  const acq::ColourMap map = acq::prepare_colour(rig, dev::PixelFormat::BayerRG16, false);
  EXPECT_EQ(map.colour_space, "linear sRGB (D65)");
  EXPECT_DOUBLE_EQ(map.balance[0], 0.5);
  EXPECT_DOUBLE_EQ(map.balance[2], 10.0 / 15.0);
  // The white reference's camera value (proportional to scale_rgb) comes out grey at the
  // luminance scale's level: (20, 10, 15) x k -> (10, 10, 10) x k.
  const std::array<double, 3> white = map.apply({40.0, 20.0, 30.0});
  for (double v : white) EXPECT_NEAR(v, 20.0, 1e-3);
  // A colour: sRGB (0.2, 0.5, 0.1) seen by this camera is (2 x 0.2, 0.5, 1.5 x 0.1) (its white
  // times the colour) and comes back as itself, the white reference's ratios being the chart's.
  const std::array<double, 3> c = map.apply({2.0 * 0.2, 1.0 * 0.5, 1.5 * 0.1});
  EXPECT_NEAR(c[0], 0.2, 1e-9);
  EXPECT_NEAR(c[1], 0.5, 1e-9);
  EXPECT_NEAR(c[2], 0.1, 1e-3);
}

TEST(Measurement, AColourBracketIsMergedAsAMosaicAndStoredAsRgbAndTheResumeKeepsTheFormat) {
  acq::ColourMap map;
  map.pattern = dev::CfaPattern::RG;
  map.balance = {2.0, 1.0, 4.0};
  acq::BracketMerger merge(acq::HdrCalibration{}, 16, map);
  EXPECT_EQ(merge.last_mosaic(), nullptr);
  std::vector<dev::Frame> frames(1);
  frames[0].pixels = Image<std::uint16_t>(8, 6, 1);
  for (int y = 0; y < 6; ++y)
    for (int x = 0; x < 8; ++x)  // R 500, G 1000, B 250 DN in 10 ms
      frames[0].pixels.at(x, y) = static_cast<std::uint16_t>(dev::cfa_colour(dev::CfaPattern::RG, x, y) == 0   ? 500
                                                             : dev::cfa_colour(dev::CfaPattern::RG, x, y) == 1 ? 1000
                                                                                                               : 250);
  frames[0].meta.exposure_s = 0.01;
  const ExrImage rgb = merge.function()(frames);
  EXPECT_EQ(rgb.find("Y"), nullptr);
  EXPECT_EQ(rgb.attributes.at("paintlab.demosaic"), "bilinear");
  EXPECT_EQ(rgb.attributes.at("paintlab.valid_pixels"), "48");
  for (const char* c : {"R", "G", "B"}) EXPECT_NEAR(rgb.plane(c).at(3, 3), 1e5, 1e5 * 1e-3) << c;
  const auto mosaic = merge.last_mosaic();
  ASSERT_NE(mosaic, nullptr);
  EXPECT_NEAR(mosaic->plane("Y").at(0, 0), 5e4, 50);  // an R site, before demosaicing
  EXPECT_NE(mosaic->find("valid"), nullptr);

  acq::SessionManifest m;
  m.options.pixel_format = "BayerRG12";
  acq::CameraPreparation cam;
  cam.format = dev::PixelFormat::BayerRG12;
  EXPECT_NO_THROW(acq::check_resume_camera(m, cam, "s"));
  cam.format = dev::PixelFormat::Mono12;
  EXPECT_THAT(test::error_message<DataError>([&] { acq::check_resume_camera(m, cam, "s"); }),
              ::testing::AllOf(HasSubstr("s: the session was measured in BayerRG12, but the camera now records Mono12")));
}

TEST(Measurement, SessionsOfVersionOneStillReadAndAColourSpaceIsChecked) {
  acq::SessionManifest m;
  m.sample = "old";
  m.angles_deg = {0.0, 10.0};
  m.exposures_s = {0.01};
  Json j = m.to_json();
  EXPECT_EQ(j["format_version"], 2);
  j["format_version"] = 1;
  EXPECT_EQ(acq::SessionManifest::from_json(j, "s/session.json").sample, "old");
  j["format_version"] = 3;
  EXPECT_THAT(test::error_message<DataError>([&] { acq::SessionManifest::from_json(j, "s/session.json"); }),
              HasSubstr("reads versions 1 to 2"));
  acq::SessionOptions o;
  o.colour_space = colour::kLinearSrgb;
  o.demosaic = "bilinear";
  const acq::SessionOptions back = acq::SessionOptions::from_json(o.to_json(), "s");
  EXPECT_EQ(back.colour_space, "linear sRGB (D65)");
  EXPECT_EQ(back.demosaic, "bilinear");
  EXPECT_THAT(test::error_message<DataError>(
                  [&] { acq::SessionOptions::from_json(Json{{"colour_space", "sRGB"}}, "s/session.json"); }),
              HasSubstr("colour_space 'sRGB' is none of"));
}

TEST(Measurement, AFilterWheelPositionIsMergedPerFilterAndMappedWithoutDemosaicing) {
  acq::ColourMap map;  // no pattern: a monochrome camera behind a wheel
  map.balance = {2.0, 1.0, 0.5};
  map.matrix = std::array<double, 9>{1, 0, 0, 0, 1, 0, 0, 0.5, 0.5};
  acq::BracketMerger merge(acq::HdrCalibration{}, 16, map);
  std::vector<dev::Frame> frames;
  const double dn[3] = {400, 1000, 3000};
  for (int c = 0; c < 3; ++c)
    for (double t : {0.01, 0.02}) {
      dev::Frame f;
      f.pixels = Image<std::uint16_t>(6, 4, 1, static_cast<std::uint16_t>(dn[c] * t / 0.01));
      f.pixels.at(2, 1) = c == 1 ? 65535 : f.pixels.at(2, 1);  // saturated in green only
      f.meta.exposure_s = t;
      f.meta.filter = c;
      frames.push_back(std::move(f));
    }
  const ExrImage rgb = merge.function()(frames);
  EXPECT_EQ(rgb.find("Y"), nullptr);
  EXPECT_EQ(rgb.attributes.at("paintlab.filters"), "R, G, B: one bracket each (filter wheel)");
  // Rates 4e4, 1e5, 3e5 DN/s balanced to 8e4, 1e5, 1.5e5; B = (G + B) / 2.
  EXPECT_NEAR(rgb.plane("R").at(0, 0), 8e4, 80);
  EXPECT_NEAR(rgb.plane("G").at(0, 0), 1e5, 100);
  EXPECT_NEAR(rgb.plane("B").at(0, 0), 1.25e5, 125);
  EXPECT_EQ(rgb.plane("valid").at(0, 0), 1.0f);
  // A pixel saturated through one filter is invalid, and so is every output that mixes it in.
  EXPECT_EQ(rgb.plane("valid").at(2, 1), 0.0f);
  EXPECT_FALSE(std::isinf(rgb.plane("var.R").at(2, 1)));
  EXPECT_TRUE(std::isinf(rgb.plane("var.G").at(2, 1)));
  EXPECT_TRUE(std::isinf(rgb.plane("var.B").at(2, 1)));
  // A position without one of the filters is refused.
  frames.resize(4);
  EXPECT_THAT(test::error_message<DataError>([&] { merge.function()(frames); }),
              HasSubstr("no frame through the B filter"));
}
