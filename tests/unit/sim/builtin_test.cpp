// What the simulator carries built in (sim/builtin.h): the rig `paintlab demo` writes, at full
// size and --quick, and the paint a simulated sample wears unless told.
#include "paintlab/sim/builtin.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "paintlab/core/config.h"
#include "paintlab/core/error.h"
#include "paintlab/devices/device_config.h"
#include "paintlab/core/rig.h"
#include "paintlab/sim/config.h"
#include "test_util.h"

using namespace paintlab;

namespace {

RigConfig parse_rig_text(const std::string& text) {
  return RigConfig::parse(ConfigTable::parse_string(text, "rig.toml"), "/lab/demo/rig.toml");
}

}  // namespace

TEST(Builtin, TheDemoRigIsTheBuiltInRigWithItsCalibrationBesideIt) {
  const RigConfig built_in = parse_rig_text(sim::builtin_rig_toml());
  const std::string text = sim::demo_rig_toml(false);
  EXPECT_EQ(text.rfind("# paintlab demo:", 0), 0u);
  const RigConfig demo = parse_rig_text(text);
  EXPECT_EQ(demo.calibration_dir, std::filesystem::path("/lab/demo/calib"));
  EXPECT_EQ(demo.geometry.image_width_px, built_in.geometry.image_width_px);
  EXPECT_EQ(demo.plan.angles_deg(), built_in.plan.angles_deg());
  EXPECT_EQ(demo.plan.exposures_s, built_in.plan.exposures_s);
}

TEST(Builtin, TheQuickDemoRigHasHalfTheResolutionWithTheSameOpticsAndAShortPlan) {
  const RigConfig full = parse_rig_text(sim::builtin_rig_toml());
  const RigConfig quick = parse_rig_text(sim::demo_rig_toml(true));
  EXPECT_EQ(quick.geometry.image_width_px, full.geometry.image_width_px / 2);
  EXPECT_EQ(quick.geometry.image_height_px, full.geometry.image_height_px / 2);
  EXPECT_NEAR(quick.geometry.pixel_size_um, 2 * full.geometry.pixel_size_um, 1e-5 * full.geometry.pixel_size_um);
  const Mat3 kf = sim::SimConfig::from_rig(full).camera.K();
  const Mat3 kq = sim::SimConfig::from_rig(quick).camera.K();
  EXPECT_NEAR(kq(0, 0), kf(0, 0) / 2, 1e-5 * kf(0, 0));
  // The same point of the scene at the same place: pixel centres x' + 0.5 = (x + 0.5) / 2.
  EXPECT_NEAR(kq(0, 2) + 0.5, (kf(0, 2) + 0.5) / 2, 1e-3);
  EXPECT_NEAR(kq(1, 2) + 0.5, (kf(1, 2) + 0.5) / 2, 1e-3);
  EXPECT_EQ(quick.plan.exposures_s.size(), 8u);
  ASSERT_GE(quick.plan.angles_deg().size(), 2u);
  EXPECT_NEAR(quick.plan.angles_deg()[1] - quick.plan.angles_deg()[0], 10.0, 1e-9);
}

TEST(Builtin, TheColourDemoRigHasABayerCameraWithItsOwnMixUnderAWarmLed) {
  const std::string text = sim::demo_rig_toml(true, sim::DemoCamera::Bayer);
  const RigConfig rig = parse_rig_text(text);
  EXPECT_EQ(dev::camera_config(rig.camera, rig.geometry).pixel_format, dev::PixelFormat::BayerRG16);
  const sim::SimConfig truth = sim::SimConfig::from_rig(rig);
  EXPECT_EQ(truth.camera.rgb_gain, (std::array<double, 3>{0.55, 1.0, 0.75}));
  EXPECT_DOUBLE_EQ(truth.camera.rgb_matrix[1], 0.22);
  EXPECT_DOUBLE_EQ(truth.led.color[2], 0.86);
  EXPECT_THAT(text, ::testing::HasSubstr("BayerRG16 colour camera"));
  // The monochrome one is the built-in rig's camera.
  const RigConfig mono = parse_rig_text(sim::demo_rig_toml(true, sim::DemoCamera::Mono));
  EXPECT_EQ(dev::camera_config(mono.camera, mono.geometry).pixel_format, dev::PixelFormat::Mono16);
  EXPECT_EQ(sim::demo_camera_from_string("bayer", "--camera"), sim::DemoCamera::Bayer);
  // The filter-wheel camera: the monochrome one behind a simulated wheel, R, G, B in slots 1-3.
  const RigConfig wheel = parse_rig_text(sim::demo_rig_toml(true, sim::DemoCamera::Wheel));
  EXPECT_EQ(dev::camera_config(wheel.camera, wheel.geometry).pixel_format, dev::PixelFormat::Mono16);
  ASSERT_TRUE(wheel.filter_wheel.has_value());
  EXPECT_EQ(dev::filter_wheel_config(*wheel.filter_wheel).channel_slot, (std::array<int, 3>{1, 2, 3}));
  EXPECT_EQ(wheel.filter_wheel->kind, "sim");
  EXPECT_THAT(test::error_message<UsageError>([] { sim::demo_camera_from_string("rgb", "demo --camera"); }),
              ::testing::HasSubstr("demo --camera rgb: one of bayer"));
}

TEST(Builtin, TheDefaultSamplePaintIsTheSilverMetallic) {
  const brdf::PaintSpec p = sim::builtin_paint();
  EXPECT_EQ(p.name, "silver-metallic");
  ASSERT_NE(p.cook_torrance(), nullptr);
  EXPECT_GE(p.cook_torrance()->lobes.size(), 2u);
}
