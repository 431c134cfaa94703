// The simulator's named scenes (sim/scene_render.h) and the fixed scenes a simulated rig's
// camera shows (SimRig::show): what `paintlab sim render` writes and what the calibration
// stages put in front of the simulated camera.
#include "paintlab/sim/scene_render.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <memory>

#include "paintlab/core/config.h"
#include "paintlab/core/error.h"
#include "paintlab/sim/paint.h"
#include "paintlab/sim/peers/sim_rig.h"
#include "sim_rigs.h"
#include "sim_test_util.h"
#include "test_util.h"

using namespace paintlab;
using ::testing::HasSubstr;

namespace {

double image_centre(const ImageF& img) { return img.at(img.width() / 2, img.height() / 2, 0); }

double peak_of(const ImageF& img) { return *std::max_element(img.values().begin(), img.values().end()); }

}  // namespace

TEST(SceneRender, EveryNamedSceneHasTheCamerasSizeAndTheRequestedChannels) {
  sim::SimWorld world(sim::test::small_config());
  for (const char* name : {"sphere", "white", "chessboard", "charuco", "flat", "dark", "colour-chart"}) {
    sim::SceneRequest q;
    q.kind = sim::scene_kind_from_string(name);
    q.chart.patch_rgb.assign(24, {0.2, 0.3, 0.4});
    EXPECT_STREQ(sim::to_string(q.kind), name);
    q.channels = 3;
    const sim::SceneRender r = sim::render_scene(world, q);
    EXPECT_EQ(r.radiance.width(), 320) << name;
    EXPECT_EQ(r.radiance.height(), 240) << name;
    EXPECT_EQ(r.radiance.channels(), 3) << name;
    EXPECT_FALSE(r.description.empty()) << name;
  }
}

TEST(SceneRender, TheColourChartShowsEachPatchInItsColourUnderTheLedsWhite) {
  sim::SimConfig config = sim::test::small_config(12.0, 640, 480);
  config.led.color = {1.0, 0.8, 0.6};
  sim::SimWorld world(config);
  sim::SceneRequest q;
  q.kind = sim::SceneKind::ColourChart;
  q.channels = 3;
  for (int k = 0; k < 24; ++k) q.chart.patch_rgb.push_back({0.05 + 0.03 * k, 0.5, 0.9 - 0.035 * k});
  q.chart.patch_rgb[5] = {-0.05, 0.4, 0.5};  // outside sRGB, as the ColorChecker's cyan is
  const sim::SceneRender r = sim::render_scene(world, q);
  EXPECT_THAT(r.description, ::testing::HasSubstr("6x4 colour chart of 40 mm patches, view 0"));
  const Rigid3 pose = sim::colour_chart_poses(world.camera(), q.chart, 1, config.seed).at(0);
  const double E = world.irradiance_for_fill(0.5, q.exposure_s, q.chart.max_albedo());
  for (int k = 0; k < 24; ++k) {
    const Vec2 c = q.chart.patch_centre(k);
    const Vec2 px = world.camera().project(pose * Vec3(c.x(), c.y(), 0.0));
    const int x = static_cast<int>(std::lround(px.x())), y = static_cast<int>(std::lround(px.y()));
    for (int ch = 0; ch < 3; ++ch) {
      const double expected =
          q.chart.patch_rgb[static_cast<std::size_t>(k)][static_cast<std::size_t>(ch)] * E / kPi * config.led.color[static_cast<std::size_t>(ch)];
      EXPECT_NEAR(r.radiance.at(x, y, ch), expected, 1e-4 * std::abs(E) + 1e-5 * std::abs(expected)) << "patch " << k << " channel " << ch;
    }
  }
  // The chart's body is black felt-like: darker than every patch.
  const Vec2 body = world.camera().project(pose * Vec3(-0.006, -0.006, 0.0));
  EXPECT_LT(r.radiance.at(static_cast<int>(body.x()), static_cast<int>(body.y()), 1), 0.04 * E / kPi);
  // A monochrome camera sees w . RGB.
  q.channels = 1;
  const sim::SceneRender mono = sim::render_scene(world, q);
  const auto& w = config.camera.mono_weights;
  const Vec2 c0 = world.camera().project(pose * Vec3(q.chart.patch_centre(0).x(), q.chart.patch_centre(0).y(), 0.0));
  const int x0 = static_cast<int>(std::lround(c0.x())), y0 = static_cast<int>(std::lround(c0.y()));
  EXPECT_NEAR(mono.radiance.at(x0, y0), w[0] * r.radiance.at(x0, y0, 0) + w[1] * r.radiance.at(x0, y0, 1) + w[2] * r.radiance.at(x0, y0, 2), 1e-6);
  q.chart.patch_rgb.pop_back();
  EXPECT_THROW(sim::render_scene(world, q), DataError);
}

TEST(SceneRender, TheFlatFieldReachesHalfTheFullWellAtTheGivenExposureAndTheDarkFieldIsBlack) {
  sim::SimWorld world(sim::test::small_config());
  sim::SceneRequest q{.kind = sim::SceneKind::Flat, .exposure_s = 0.004};
  const sim::SceneRender flat = sim::render_scene(world, q);
  EXPECT_NEAR(image_centre(flat.radiance), world.radiance_for_fill(0.5, 0.004), 1e-6 * world.radiance_for_fill(0.5, 0.004));
  EXPECT_FLOAT_EQ(peak_of(flat.radiance), static_cast<float>(world.radiance_for_fill(0.5, 0.004)));
  // Twice the exposure: half the radiance.
  q.exposure_s = 0.008;
  EXPECT_NEAR(image_centre(sim::render_scene(world, q).radiance), 0.5 * image_centre(flat.radiance),
              1e-6 * image_centre(flat.radiance));
  q.kind = sim::SceneKind::Dark;
  EXPECT_EQ(peak_of(sim::render_scene(world, q).radiance), 0.0f);
}

TEST(SceneRender, TheWhiteReferenceIsLitByTheLedAndNamesItsAlbedo) {
  sim::SimWorld world(sim::test::small_config());
  sim::SceneRequest q;
  q.kind = sim::SceneKind::White;
  q.albedo = 0.5;
  q.angle_deg = 30.0;
  const sim::SceneRender lit = sim::render_scene(world, q);
  EXPECT_THAT(lit.description, HasSubstr("albedo 0.5"));
  EXPECT_THAT(lit.description, HasSubstr("30 deg"));
  EXPECT_GT(peak_of(lit.radiance), 0.0f);
  q.albedo = 1.0;
  EXPECT_NEAR(peak_of(sim::render_scene(world, q).radiance), 2.0 * peak_of(lit.radiance), 1e-3 * peak_of(lit.radiance));
  q.led_on = false;
  const sim::SceneRender off = sim::render_scene(world, q);
  EXPECT_LT(peak_of(off.radiance), 1e-3 * peak_of(lit.radiance));
  EXPECT_THAT(off.description, HasSubstr("LED off"));
}

TEST(SceneRender, BoardViewsDifferAndRepeat) {
  sim::SimWorld world(sim::test::small_config());
  sim::SceneRequest q;
  q.kind = sim::SceneKind::Chessboard;
  const ImageF v0 = sim::render_scene(world, q).radiance;
  q.view = 1;
  const sim::SceneRender v1 = sim::render_scene(world, q);
  EXPECT_THAT(v1.description, HasSubstr("view 1"));
  EXPECT_NE(v0.values(), v1.radiance.values());
  EXPECT_EQ(sim::render_scene(world, q).radiance.values(), v1.radiance.values());
}

// The calibration stage shows view i of the N the procedure takes, of the board it names:
// pose i of chessboard_poses(N), and the board's own corner count in the description.
TEST(SceneRender, ABoardViewOfASetIsThatSetsPoseOfTheGivenBoard) {
  sim::SimWorld world(sim::test::small_config());
  sim::SceneRequest q;
  q.kind = sim::SceneKind::Chessboard;
  q.chessboard.cols = 7;
  q.chessboard.rows = 5;
  q.chessboard.square_m = 0.015;
  q.view = 2;
  q.views = 6;
  const sim::SceneRender r = sim::render_scene(world, q);
  EXPECT_THAT(r.description, HasSubstr("7x5 chessboard of 15 mm squares, view 2"));
  const auto poses = sim::chessboard_poses(world.camera(), q.chessboard, 6, world.config().seed);
  sim::PlaneLighting light;
  light.irradiance_w_m2 = world.irradiance_for_fill(0.5, q.exposure_s, q.chessboard.white_albedo);
  EXPECT_EQ(r.radiance.values(), sim::render_chessboard(world.camera(), q.chessboard, poses[2], light, 16, 1, 0).values());
  q.views = 2;  // fewer views than the one asked for
  EXPECT_THAT(test::error_message<UsageError>([&] { sim::render_scene(world, q); }), HasSubstr("scene views 2"));
  q.views = 0;
  q.chessboard.cols = 1;
  EXPECT_THAT(test::error_message<UsageError>([&] { sim::render_scene(world, q); }), HasSubstr("scene chessboard 1x5"));
}

TEST(SceneRender, BadRequestsAreRefusedNamingTheField) {
  sim::SimWorld world(sim::test::small_config());
  sim::SceneRequest q;
  q.channels = 2;
  EXPECT_THROW(sim::render_scene(world, q), UsageError);
  q = {};
  q.exposure_s = 0.0;
  EXPECT_THAT(test::error_message<UsageError>([&] { sim::render_scene(world, q); }),
              HasSubstr("exposure_s"));
  EXPECT_THAT(test::error_message<DataError>([&] { sim::scene_kind_from_string("board", "--scene"); }),
              ::testing::AllOf(HasSubstr("--scene"), HasSubstr("chessboard")));
}

TEST(SimRigShow, AFixedSceneIsExposedThroughTheSensorWithTheCamerasBlackLevel) {
  const std::string text = test::small_sim_rig();
  const RigConfig rig = RigConfig::parse(ConfigTable::parse_string(text, "rig.toml"), "rig.toml");
  sim::SimRigOptions o;
  o.turntable = o.camera = o.light = false;  // no peer: only the world and its sensor
  sim::SimRig sim_rig(rig, o);
  sim::SimWorld& w = sim_rig.world();
  const int width = w.camera().width(), height = w.camera().height();
  sim::FrameRequest r;
  r.exposure_s = 0.01;
  r.format = dev::PixelFormat::Mono16;
  r.width = width;
  r.height = height;
  std::vector<std::uint16_t> frame(static_cast<std::size_t>(width) * height);

  // The lens cap: the black level (moved to the camera's) plus dark noise only.
  r.black_level = 100.0;
  sim::SceneRequest dark;
  dark.kind = sim::SceneKind::Dark;
  sim_rig.static_source(std::make_shared<ImageF>(sim::render_scene(w, dark).radiance))(r, frame.data());
  const double scale16 = std::ldexp(1.0, 16 - w.config().sensor.adc_bits);
  std::vector<std::uint16_t> sorted = frame;
  std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
  EXPECT_NEAR(sorted[sorted.size() / 2], 100.0 * scale16, 3.0 * scale16);

  // A uniform field lit for half the full well at 10 ms: the centre sits near half the range.
  sim::SceneRequest flat;
  flat.kind = sim::SceneKind::Flat;
  flat.exposure_s = 0.01;
  r.black_level = w.config().sensor.black_level_dn;
  sim_rig.static_source(std::make_shared<ImageF>(sim::render_scene(w, flat).radiance))(r, frame.data());
  const double centre = frame[static_cast<std::size_t>(height / 2) * width + width / 2] / scale16;
  const double black = w.config().sensor.black_level_dn;
  const double half = 0.5 * (w.config().sensor.adc_max_dn() - black);
  EXPECT_NEAR(centre - black, half, 0.1 * half);
}

TEST(SceneRender, TheExrCarriesTheChannelsAndSaysWhatItShows) {
  sim::SimWorld world(sim::test::small_config());
  sim::SceneRequest q{.kind = sim::SceneKind::Flat, .channels = 3};
  const sim::SceneRender colour = sim::render_scene(world, q);
  const ExrImage exr = sim::scene_exr(colour, "/lab/rig.toml");
  EXPECT_EQ(exr.names, (std::vector<std::string>{"R", "G", "B"}));
  EXPECT_FLOAT_EQ(exr.plane("G").at(10, 20), colour.radiance.at(10, 20, 1));
  EXPECT_EQ(exr.attributes.at("paintlab.scene"), colour.description);
  EXPECT_EQ(exr.attributes.at("paintlab.rig"), "/lab/rig.toml");
  q.channels = 1;
  EXPECT_EQ(sim::scene_exr(sim::render_scene(world, q), "").names, (std::vector<std::string>{"Y"}));
}

TEST(SceneRender, AnOverexposedFrameCountsItsClippedValues) {
  sim::SimWorld world(sim::test::small_config());
  sim::SceneRequest q{.kind = sim::SceneKind::Flat, .exposure_s = 0.01};  // half the full well in 10 ms
  const sim::SceneRender flat = sim::render_scene(world, q);
  sim::ExposureSettings e;
  e.exposure_s = 0.01;
  e.frame_index = 1;
  const sim::SceneFrame half = sim::expose_scene(world, flat, e);
  EXPECT_EQ(half.raw.width(), 320);
  EXPECT_EQ(half.saturated, 0);
  e.exposure_s = 0.1;  // five times the full well
  const sim::SceneFrame over = sim::expose_scene(world, flat, e);
  EXPECT_GT(over.saturated, 320 * 240 / 2);
  EXPECT_LE(over.saturated, 320 * 240);
}
