// Capturing frames for the calibration steps (acquisition/capture.h) with in-memory devices:
// the auto-exposure loop lands where it is asked to or says why not, the LED is off after
// every capture whatever happens, stacks and shots are saved with their applied exposures,
// and names, raw quantiles and the linearizer's merger cache behave as documented.
#include "paintlab/acquisition/capture.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include "fake_rig.h"
#include "paintlab/core/atomic_file.h"
#include "paintlab/core/error.h"
#include "paintlab/core/image_io.h"
#include "test_util.h"

using namespace paintlab;
using ::testing::HasSubstr;
namespace fs = std::filesystem;

namespace {

constexpr double kBlack = 50.0;
constexpr double kFull = 65535.0;

struct Rig {
  test::FakeClock clock;
  test::FakeTable table{clock};
  test::FakeLight light;
  test::FakeCamera camera{clock, light};
  // A uniform scene of `rate` DN/s above a black level of 50 DN with the light on, black off.
  void scene(double rate) {
    camera.pixel = [rate](double t, bool on) { return kBlack + (on ? rate * t : 0.0); };
  }
  acq::ShotCapture::Devices devices(bool with_table = true) {
    return {with_table ? &table : nullptr, &light, &camera, &clock};
  }
};

double level_of(double rate, double t) { return std::min(rate * t, kFull - kBlack) / (kFull - kBlack); }

}  // namespace

TEST(AutoExposure, LandsOnTheRequestedFillFromBelowAndFromSaturation) {
  for (double start : {0.01, 1.0}) {
    Rig rig;
    rig.scene(1e6);
    rig.light.state = true;
    acq::AutoExposureOptions o;
    o.fill = 0.6;
    o.black_dn = kBlack;
    o.tolerance = 0.1;
    o.start_s = start;
    const acq::AutoExposure a = acq::auto_expose(rig.camera, o);
    SCOPED_TRACE(start);
    EXPECT_TRUE(a.converged);
    EXPECT_NEAR(a.level, 0.6, 0.06);
    EXPECT_NEAR(level_of(1e6, a.exposure_s), a.level, 1e-4);  // the level of the frame returned
    EXPECT_DOUBLE_EQ(a.exposure_s, rig.camera.exposure_s());
    EXPECT_EQ(a.frames, rig.camera.captures);
    // From below: one step of fill / level. From 1 s: saturated twice (/8 each), then on.
    EXPECT_LE(a.frames, start < 0.1 ? 2 : 5);
    EXPECT_GE(rig.camera.last_timeout_s, a.exposure_s + 10.0);
  }
}

TEST(AutoExposure, StopsAtTheEndOfTheCamerasRangeAndAfterItsFrameBudget) {
  Rig rig;
  rig.scene(10.0);  // 10 DN/s: even 1 s is nearly black
  rig.light.state = true;
  acq::AutoExposureOptions o;
  o.black_dn = kBlack;
  acq::AutoExposure a = acq::auto_expose(rig.camera, o);
  EXPECT_FALSE(a.converged);
  EXPECT_DOUBLE_EQ(a.exposure_s, 1.0);  // the camera's longest
  EXPECT_LE(a.frames, 4);

  Rig slow;
  slow.scene(1e6);
  slow.light.state = true;
  o.start_s = 1e-4;
  o.max_frames = 1;
  a = acq::auto_expose(slow.camera, o);
  EXPECT_FALSE(a.converged);
  EXPECT_EQ(a.frames, 1);
  EXPECT_EQ(slow.camera.captures, 1);
}

TEST(AutoExposure, OptionsNameTheFieldTheValueAndTheRule) {
  Rig rig;
  auto message = [&](auto change) {
    acq::AutoExposureOptions o;
    change(o);
    try {
      acq::auto_expose(rig.camera, o);
    } catch (const UsageError& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_THAT(message([](auto& o) { o.fill = 0.0; }), HasSubstr("fill = 0"));
  EXPECT_THAT(message([](auto& o) { o.fill = 0.99; }), HasSubstr("0 < fill < 0.97"));
  EXPECT_THAT(message([](auto& o) { o.quantile = -0.1; }), HasSubstr("quantile = -0.1"));
  EXPECT_THAT(message([](auto& o) { o.tolerance = 1.5; }), HasSubstr("tolerance = 1.5"));
  EXPECT_THAT(message([](auto& o) { o.start_s = 0.0; }), HasSubstr("start_s = 0"));
  EXPECT_THAT(message([](auto& o) { o.max_frames = 0; }), HasSubstr("max_frames = 0"));
  EXPECT_THAT(message([](auto& o) { o.black_dn = 70000; }), HasSubstr("not below the camera's full scale 65535"));
  EXPECT_EQ(rig.camera.captures, 0);  // nothing captured with bad options
}

TEST(RawQuantile, NearestRankRoundingDownAndEveryPixelAtTheTop) {
  Image<std::uint16_t> small(10, 10, 1, 0);
  for (int i = 0; i < 100; ++i) small.values()[i] = static_cast<std::uint16_t>(99 - i);
  EXPECT_EQ(acq::raw_quantile(small, 0.0), 0);
  EXPECT_EQ(acq::raw_quantile(small, 1.0), 99);
  EXPECT_EQ(acq::raw_quantile(small, 0.5), 49);  // rank floor(0.5 * 99)
  // A large image is looked at every 4th pixel below q = 0.9999 only.
  Image<std::uint16_t> big(100, 100, 1, 0);
  big.values()[1] = 1000;  // not on the every-4th grid
  EXPECT_EQ(acq::raw_quantile(big, 1.0), 1000);
  EXPECT_EQ(acq::raw_quantile(big, 0.999), 0);
  EXPECT_THROW(acq::raw_quantile(Image<std::uint16_t>(), 0.5), DataError);
}

TEST(LightSwitch, TheLedIsOffOnEveryPath) {
  test::FakeLight light;
  try {
    acq::LightSwitch on(light, true);
    EXPECT_TRUE(light.state);
    throw DataError("something failed while the LED was on");
  } catch (const DataError&) {
  }
  EXPECT_FALSE(light.state);
  {
    acq::LightSwitch on(light, true);
    on.off();
    EXPECT_FALSE(light.state);
    light.state = true;  // someone else's business after off(): not switched again
  }
  EXPECT_TRUE(light.state);
  acq::LightSwitch dark(light, false);
  EXPECT_FALSE(light.state);
}

TEST(CaptureStack, SavesEveryFrameWithTheAppliedExposuresAndSwitchesTheLedOff) {
  test::TempDir tmp;
  Rig rig;
  rig.scene(1e5);
  const calib::ExposureStack s =
      acq::capture_stack(rig.camera, rig.light, 6.0, {0.0012345, 0.01}, 2, true, tmp / "stack");
  EXPECT_DOUBLE_EQ(rig.camera.gain_db, 6.0);
  EXPECT_FALSE(rig.light.state);
  ASSERT_EQ(s.images.size(), 4u);
  EXPECT_EQ(s.bit_depth, 16);
  EXPECT_NEAR(s.exposures_s[0], 0.00123, 1e-12);  // as applied (10 us steps), not as asked
  EXPECT_NEAR(s.exposures_s[3], 0.01, 1e-12);
  EXPECT_EQ(s.images[0].values()[0], static_cast<std::uint16_t>(std::round(kBlack + 1e5 * 0.00123)));
  for (const auto& f : s.files) EXPECT_TRUE(fs::exists(f)) << f;
  const std::string listing = read_file(tmp / "stack" / "exposures.txt");
  EXPECT_THAT(listing, HasSubstr("000.png 0.00123\n"));
  EXPECT_THAT(listing, HasSubstr("003.png 0.01\n"));
  // The saved folder reads back as the same stack.
  const calib::ExposureStack again =
      calib::load_exposure_stack(s.files, calib::read_exposure_file(tmp / "stack" / "exposures.txt", s.files), 16);
  ASSERT_EQ(again.exposures_s.size(), s.exposures_s.size());
  for (std::size_t k = 0; k < s.exposures_s.size(); ++k)
    EXPECT_NEAR(again.exposures_s[k], s.exposures_s[k], 1e-9 * s.exposures_s[k]);  // 9 digits in the listing
  EXPECT_EQ(again.images[2].values()[0], s.images[2].values()[0]);
  EXPECT_FALSE(s.cfa);  // a monochrome camera
  EXPECT_THAT(listing, HasSubstr("pixel format Mono16"));
}

TEST(CaptureStack, ABayerCamerasStackKnowsItsFilterColours) {
  test::TempDir tmp;
  Rig rig;
  rig.scene(1e5);
  rig.camera.format = dev::PixelFormat::BayerGR16;  // G R / B G
  const calib::ExposureStack s = acq::capture_stack(rig.camera, rig.light, 0.0, {0.001, 0.01}, 1, false, tmp / "stack");
  ASSERT_TRUE(s.cfa);
  EXPECT_EQ(*s.cfa, (std::array<int, 4>{1, 0, 2, 1}));
  EXPECT_THAT(read_file(tmp / "stack" / "exposures.txt"), HasSubstr("pixel format BayerGR16"));
  EXPECT_EQ(acq::cfa_sites(dev::PixelFormat::BayerBG8), (std::array<int, 4>{2, 1, 1, 0}));
  EXPECT_FALSE(acq::cfa_sites(dev::PixelFormat::RGB8));
}

TEST(CaptureStack, ACameraThatFailsMidwayLeavesTheLedOffAndNoListing) {
  test::TempDir tmp;
  Rig rig;
  rig.scene(1e5);
  rig.camera.on_capture = [&](int n) {
    EXPECT_TRUE(rig.light.state) << "the LED is on while the stack is captured";
    if (n == 2) rig.camera.gone = true;
  };
  EXPECT_THROW(acq::capture_stack(rig.camera, rig.light, 0.0, {0.001, 0.002, 0.004}, 1, true, tmp / "stack"),
               DeviceError);
  EXPECT_FALSE(rig.light.state);
  EXPECT_FALSE(fs::exists(tmp / "stack" / "exposures.txt"));
  EXPECT_THROW(acq::capture_stack(rig.camera, rig.light, 0.0, {}, 1, true, tmp / "x"), UsageError);
}

TEST(ShotCapture, MovesLightsExposesSavesAndRemembersTheStepsExposure) {
  test::TempDir tmp;
  Rig rig;
  rig.scene(1e6);
  bool lit = false;
  rig.camera.on_capture = [&](int) { lit = rig.light.state; };
  acq::ShotCapture shots(rig.devices(), tmp / "captures", 0.5);
  acq::Linearizer lin;
  const double before = rig.clock.now_s();
  const acq::Shot a = shots.capture({"sphere", "sphere_angle-30", -30.0, true, 0.6, 0.999, std::nullopt}, lin);
  EXPECT_TRUE(lit);
  EXPECT_FALSE(rig.light.state);
  EXPECT_EQ(rig.table.angle_deg().value(), 330.0);                       // wrapped to [0, 360)
  EXPECT_GE(rig.clock.now_s() - before, 330.0 / rig.table.speed + 0.5);  // moved, settled, waited
  EXPECT_NEAR(level_of(1e6, a.exposure_s), 0.6, 0.06);
  EXPECT_TRUE(a.per_second);
  ASSERT_TRUE(a.table_angle_deg);
  EXPECT_EQ(*a.table_angle_deg, -30.0);
  EXPECT_EQ(a.file, tmp / "captures" / "sphere" / "sphere_angle-30.png");
  EXPECT_EQ(read_raw_image(a.file).pixels.values()[0], a.raw.values()[0]);
  // Linear DN/s (no response: the raw value above nothing, per second).
  EXPECT_NEAR(a.rate.values()[0], a.raw.values()[0] / a.exposure_s, 1e-3 * a.raw.values()[0] / a.exposure_s);

  // The next shot of the step starts where this one ended: one frame.
  const int frames = rig.camera.captures;
  shots.capture({"sphere", "sphere_angle0", 0.0, true, 0.6, 0.999, std::nullopt}, lin);
  EXPECT_EQ(rig.camera.captures, frames + 1);
  // A given exposure is used as it is.
  const acq::Shot fixed = shots.capture({"check", "drift_end", std::nullopt, true, 0.7, 0.9999, 0.002}, lin);
  EXPECT_DOUBLE_EQ(fixed.exposure_s, 0.002);
  EXPECT_EQ(rig.camera.captures, frames + 2);
  EXPECT_EQ(shots.captured().size(), 3u);
  EXPECT_EQ(lin.mergers_built(), 1);  // one geometry, one calibration: one merger
}

TEST(ShotCapture, ABayerCamerasShotIsItsBalancedLuminanceWithTheCameraRgbBeside) {
  test::TempDir tmp;
  Rig rig;
  rig.camera.format = dev::PixelFormat::BayerRG16;  // R G / G B
  rig.camera.width = 40;  // enough flat 2x2 blocks (>= 200) to measure the colour gains on
  rig.camera.height = 32;
  const double rate[3] = {3e5, 6e5, 1.5e5};  // DN/s of the red, green and blue sites
  rig.camera.image = [&](int x, int y, double t, bool on) {
    if (x == 6 && y == 4) return kFull;  // one clipped green site
    return kBlack + (on ? rate[dev::cfa_colour(dev::CfaPattern::RG, x, y)] * t : 0.0);
  };
  acq::ShotCapture shots(rig.devices(), tmp / "captures", 0.0);
  acq::Linearizer lin;
  const acq::Shot s = shots.capture({"sphere", "sphere_angle0", 0.0, true, 0.6, 0.5, 0.002}, lin);
  EXPECT_EQ(s.cfa, dev::CfaPattern::RG);
  ASSERT_EQ(s.raw.channels(), 1);  // the mosaic is what is kept (and saved)
  ASSERT_EQ(s.rgb.channels(), 3);
  // Linear DN/s (no calibration: the raw value above nothing, so the black level per second too).
  const double black = kBlack / s.exposure_s;
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(s.rgb.at(2, 2, c), rate[c] + black, 1e-3 * rate[c]) << c;
  // The luminance of the grey-balanced mosaic: every site scaled to green's gain (the gains
  // measured on the image, black level included).
  EXPECT_NEAR(s.rate.at(2, 2), rate[1] + black, 2e-3 * rate[1]);
  // A shot with too little grey in view (all dark but the clipped site) keeps the gains
  // measured before.
  rig.camera.image = [&](int x, int y, double t, bool on) {
    if (x == 20 && y == 16) return kBlack + (on ? rate[0] * t : 0.0);
    return kBlack + (x * 7 + y * 13) % 11;  // black with a little pattern noise
  };
  const acq::Shot dark = shots.capture({"light", "light_angle0", 0.0, true, 0.6, 0.5, 0.002}, lin);
  // The spot's red site divided by red's gain from the first shot ((3e5 + b) / (6e5 + b), b the
  // black level per second, which nothing subtracted), a quarter of it at its own pixel.
  const double gain_r = (rate[0] + black) / (rate[1] + black);
  EXPECT_NEAR(dark.rate.at(20, 16) - dark.rate.at(24, 16), 0.25 * rate[0] / gain_r, 0.02 * rate[0] / gain_r);
  // The clipped site spoils the luminance and colour of its 3x3 neighbourhood.
  for (int y = 3; y <= 5; ++y)
    for (int x = 5; x <= 7; ++x) EXPECT_EQ(s.saturated.at(x, y), 1) << x << "," << y;
  EXPECT_EQ(s.saturated.at(2, 2), 0);
  EXPECT_EQ(read_raw_image(s.file).pixels.at(6, 4), static_cast<std::uint16_t>(kFull));
}

TEST(ShotCapture, FailuresLeaveTheLedOffAndAnAngleWithoutATableIsRefused) {
  test::TempDir tmp;
  Rig rig;
  rig.scene(1e6);
  acq::Linearizer lin;
  acq::ShotCapture shots(rig.devices(), tmp / "captures", 0.0);
  rig.camera.gone = true;
  EXPECT_THROW(shots.capture({"light", "light_angle10", 10.0, true, 0.8, 1.0, std::nullopt}, lin), DeviceError);
  EXPECT_FALSE(rig.light.state);
  EXPECT_TRUE(shots.captured().empty());

  acq::ShotCapture no_table(rig.devices(false), tmp / "captures", 0.0);
  EXPECT_THAT(test::error_message<UsageError>([&] { no_table.capture({"sphere", "s", 20.0, true, 0.6, 0.999, std::nullopt}, lin); }),
              HasSubstr("no turntable"));
}

TEST(ShotNames, AnglesAndExposuresFromFileNames) {
  EXPECT_EQ(acq::angle_from_name("light_angle-150_exp2.5ms"), -150.0);
  EXPECT_EQ(acq::angle_from_name("sphere_ANGLE=12.5"), 12.5);
  EXPECT_FALSE(acq::angle_from_name("view03"));
  EXPECT_DOUBLE_EQ(*acq::exposure_from_name("light_angle-150_exp2.5ms"), 0.0025);
  EXPECT_DOUBLE_EQ(*acq::exposure_from_name("dark_exp500us"), 5e-4);
  EXPECT_DOUBLE_EQ(*acq::exposure_from_name("flat_EXP_2S"), 2.0);
  EXPECT_FALSE(acq::exposure_from_name("exposure_test"));
  EXPECT_FALSE(acq::exposure_from_name("exp3msx"));  // a unit must end the token
}

TEST(LoadShot, RawFilesAreLinearisedPerSecondAndMergedExrKeepTheirInvalidPixels) {
  test::TempDir tmp;
  Image<std::uint16_t> raw(4, 3, 1, 1000);
  raw.values()[5] = 65535;
  write_png(tmp / "light_angle-150_exp2.5ms.png", raw, 16);
  acq::Linearizer lin;
  const acq::Shot s = acq::load_shot(tmp / "light_angle-150_exp2.5ms.png", lin);
  EXPECT_EQ(s.name, "light_angle-150_exp2.5ms");
  EXPECT_EQ(*s.table_angle_deg, -150.0);
  EXPECT_DOUBLE_EQ(s.exposure_s, 0.0025);
  EXPECT_TRUE(s.per_second);
  EXPECT_EQ(s.raw.values()[0], 1000);
  EXPECT_NEAR(s.rate.values()[0], 1000 / 0.0025, 1.0);
  EXPECT_EQ(s.saturated.values()[5], 1);
  EXPECT_EQ(s.saturated.values()[0], 0);

  // Without an exposure in the name the values are per exposure, not per second.
  write_png(tmp / "view01.png", raw, 16);
  EXPECT_FALSE(acq::load_shot(tmp / "view01.png", lin).per_second);

  ExrImage e;
  ImageF y(4, 3, 1, 250.0f);
  ImageF valid(4, 3, 1, 1.0f);
  valid.values()[7] = 0.0f;
  e.add("Y", y);
  e.add("valid", valid);
  write_exr(tmp / "pos_003.exr", e);
  const acq::Shot m = acq::load_shot(tmp / "pos_003.exr", lin);
  EXPECT_TRUE(m.per_second);
  EXPECT_TRUE(m.raw.empty());
  EXPECT_FLOAT_EQ(m.rate.values()[2], 250.0f);
  EXPECT_EQ(m.saturated.values()[7], 1);
  EXPECT_EQ(m.saturated.values()[6], 0);
}

TEST(Linearizer, BuildsAMergerPerGeometryAndCalibration) {
  acq::Linearizer lin;
  Image<std::uint16_t> a(8, 6, 1, 2000), b(4, 4, 1, 2000);
  const auto r1 = lin.linearise(a, 16, 0.01);
  const auto r2 = lin.linearise(a, 16, 0.02);
  EXPECT_EQ(lin.mergers_built(), 1);
  EXPECT_NEAR(r1.rate.values()[0] / r2.rate.values()[0], 2.0, 1e-6);  // per second
  lin.linearise(b, 16, 0.01);
  EXPECT_EQ(lin.mergers_built(), 2);
  lin.linearise(b, 12, 0.01);
  EXPECT_EQ(lin.mergers_built(), 3);
  lin.set_calibration({});
  lin.linearise(b, 12, 0.01);
  EXPECT_EQ(lin.mergers_built(), 4);
}
