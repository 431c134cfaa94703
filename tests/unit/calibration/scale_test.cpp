// Absolute BRDF scale from the white reference sphere on the simulated rig: the scale
// against the simulator's camera gain and LED intensity, a grey sphere's BRDF recovered in
// 1/sr, the LED profile exponent, saturated references counted.
#include <gtest/gtest.h>

#include <cstdio>

#include "paintlab/calibration/scale.h"
#include "paintlab/core/error.h"
#include "sim_scenes.h"
#include "test_util.h"

using namespace paintlab;
using namespace paintlab::calib;
using namespace paintlab::calib::testing;

namespace {

// A reference image: linear DN per second and the clipped pixels.
ReferenceImage reference(sim::SimWorld& w, const sim::SimPaint& paint, double angle, double fill) {
  double t = 0;
  Image<std::uint16_t> raw;
  ImageF lin = expose_linear(w, w.render_with(paint, angle, true), fill, &t, &raw, 0.999);
  ReferenceImage r;
  r.table_angle_deg = angle;
  r.name = "white-" + std::to_string(static_cast<int>(angle));
  r.rate = lin;
  for (float& v : r.rate.values()) v = static_cast<float>(v / t);
  r.saturated = Image<std::uint8_t>(raw.width(), raw.height(), 1, 0);
  const auto max = static_cast<std::uint16_t>(w.config().sensor.adc_max_dn());
  for (std::size_t i = 0; i < raw.size(); ++i) r.saturated.values()[i] = raw.values()[i] >= max ? 1 : 0;
  return r;
}

}  // namespace

TEST(ScaleSim, WhiteReferenceGivesTheScaleAndAGreySphereIn1PerSr) {
  sim::SimWorld world(sim_rig_config());
  const CameraModel cam = truth_camera(world);
  const SphereFit sphere = truth_sphere(world);
  LightModel light = truth_light(world);
  light.profile_exponent = 0.0;  // to be measured
  const double albedo = 0.99;
  std::vector<ReferenceImage> refs;
  for (double a : {-40.0, 0.0, 40.0}) refs.push_back(reference(world, sim::reference_paint(albedo), a, 0.7));
  ScaleOptions o;
  o.albedo = albedo;
  ScaleCalibration sc = calibrate_scale(refs, cam, sphere, light, o);
  // Truth: linear DN/s per radiance = electrons/s per radiance x DN per electron; times the
  // LED's on-axis intensity. Averaged over the reference's image.
  const double g = world.sensor().gain_dn_per_e(0.0);
  const Vec2 c = cam.project(sphere.centre_cam_m);
  double truth = 0;
  int n = 0;
  for (int y = static_cast<int>(c.y()) - 100; y <= static_cast<int>(c.y()) + 100; y += 5)
    for (int x = static_cast<int>(c.x()) - 100; x <= static_cast<int>(c.x()) + 100; x += 5, ++n)
      truth += world.led_intensity_w_sr() * world.sensor().electrons_per_s_per_radiance(x, y) * g;
  truth /= n;
  std::printf("scale %.6g (truth %.6g, %+.3f %%), uncertainty %.3f %%, spread %.3f %%, profile n %.2f +- %.2f (true %.2f), "
              "%lld pixels, residual %.3f %%, saturated %lld\n",
              sc.scale, truth, 100 * (sc.scale / truth - 1), 100 * sc.uncertainty_rel, 100 * sc.spread_rel,
              sc.profile_exponent, sc.profile_exponent_std, world.config().led.profile_exponent, sc.pixels,
              100 * sc.residual_rel, sc.saturated);
  EXPECT_THAT(sc.scale, test::NearRel(truth, 0.01));
  EXPECT_EQ(sc.saturated, 0);
  EXPECT_LT(sc.uncertainty_rel, 0.01);

  // A grey Lambertian sphere (albedo 0.5) at another angle: BRDF = 0.5 / pi in 1/sr.
  light.profile_exponent = sc.profile_exponent;
  ReferenceImage grey = reference(world, sim::reference_paint(0.5), 25.0, 0.7);
  std::vector<double> f;
  for (int y = static_cast<int>(c.y()) - 150; y <= static_cast<int>(c.y()) + 150; y += 3)
    for (int x = static_cast<int>(c.x()) - 150; x <= static_cast<int>(c.x()) + 150; x += 3) {
      auto X = intersect_sphere(cam.ray(Vec2(x, y)), sphere.centre_cam_m, sphere.radius_m);
      if (!X) continue;
      const Vec3 nrm = (*X - sphere.centre_cam_m) / sphere.radius_m;
      const double E = light.irradiance(25.0, *X, nrm);
      if (E <= 0 || nrm.dot((-*X).normalized()) < 0.3 || nrm.dot((light.led_position_cam(25.0) - *X).normalized()) < 0.3)
        continue;
      f.push_back(sc.brdf(grey.rate.at(x, y), E));
    }
  std::sort(f.begin(), f.end());
  const double med = f[f.size() / 2];
  std::printf("grey sphere: median BRDF %.5f 1/sr (true %.5f, %+.3f %%) over %zu pixels\n", med, 0.5 / kPi,
              100 * (med * kPi / 0.5 - 1), f.size());
  EXPECT_THAT(med, test::NearRel(0.5 / kPi, 0.01));

  test::TempDir dir;
  sc.save(dir / "scale.json");
  ScaleCalibration back = ScaleCalibration::load(dir / "scale.json");
  EXPECT_DOUBLE_EQ(back.scale, sc.scale);
  EXPECT_DOUBLE_EQ(back.profile_exponent, sc.profile_exponent);
}

TEST(ScaleSim, LedProfileExponentFromFlatFieldedReferences) {
  // The emission profile varies by ~0.3 % across the sphere, as much as the lens
  // vignetting: the exponent is only meaningful on flat-fielded images. Here the simulator's
  // own per-pixel gain stands in for calib/flat.json.
  sim::SimWorld world(sim_rig_config());
  std::vector<ReferenceImage> refs;
  for (double a : {-40.0, 0.0, 40.0}) refs.push_back(reference(world, sim::reference_paint(0.99), a, 0.7));
  const int w = world.camera().width(), h = world.camera().height();
  const double g0 = world.sensor().electrons_per_s_per_radiance(w / 2, h / 2);
  for (auto& r : refs)
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) r.rate.at(x, y) = static_cast<float>(r.rate.at(x, y) * g0 / world.sensor().electrons_per_s_per_radiance(x, y));
  ScaleOptions o;
  o.albedo = 0.99;
  LightModel light = truth_light(world);
  ScaleCalibration sc = calibrate_scale(refs, truth_camera(world), truth_sphere(world), light, o);
  std::printf("flat-fielded: profile n %.2f +- %.2f (true %.2f)\n", sc.profile_exponent, sc.profile_exponent_std,
              world.config().led.profile_exponent);
  EXPECT_NEAR(sc.profile_exponent, world.config().led.profile_exponent, 0.3);
}

TEST(ScaleSim, SaturatedReferenceIsCounted) {
  sim::SimWorld world(sim_rig_config());
  ScaleOptions o;
  o.albedo = 0.99;
  // Four times too long an exposure: the bright half of the sphere clips.
  ScaleCalibration sc = calibrate_scale({reference(world, sim::reference_paint(0.99), 0.0, 2.8)}, truth_camera(world),
                                        truth_sphere(world), truth_light(world), o);
  std::printf("over-exposed reference: %.1f %% of the lit reference pixels saturated\n", 100 * sc.saturated_frac);
  EXPECT_GT(sc.saturated_frac, 0.2);
  EXPECT_GT(sc.saturated, 1000);
}

TEST(ScaleSim, LedOffIsAnErrorThatSaysWhy) {
  sim::SimWorld world(sim_rig_config());
  ScaleOptions o;
  o.albedo = 0.99;
  ReferenceImage dark;
  dark.name = "led-off";
  dark.rate = ImageF(world.camera().width(), world.camera().height(), 1, 0.0f);
  EXPECT_THAT(test::error_message<CalibrationError>([&] { calibrate_scale({dark}, truth_camera(world), truth_sphere(world), truth_light(world), o); }),
              ::testing::AllOf(::testing::HasSubstr("only 0 usable reference pixels"), ::testing::HasSubstr("led-off")));
}

TEST(ScaleFile, AColourCamerasPerChannelScaleRoundTripsAndIsChecked) {
  ScaleCalibration s;
  s.scale = 2.5e5;
  s.scale_rgb = std::array<double, 3>{1.5e5, 2.5e5, 2.0e5};
  const ScaleCalibration back = ScaleCalibration::from_json(s.to_json(), "scale.json");
  ASSERT_TRUE(back.scale_rgb);
  EXPECT_EQ(*back.scale_rgb, *s.scale_rgb);
  EXPECT_THAT(back.describe(), ::testing::HasSubstr("white balance under the LED R/G 0.6000, B/G 0.8000"));
  ScaleCalibration mono;
  mono.scale = 1.0;
  EXPECT_FALSE(ScaleCalibration::from_json(mono.to_json(), "scale.json").scale_rgb);
  Json bad = s.to_json();
  bad["scale_rgb"] = Json::array({1.0, 0.0, 1.0});
  EXPECT_THAT(test::error_message<DataError>([&] { ScaleCalibration::from_json(bad, "scale.json"); }),
              ::testing::HasSubstr("scale.json: key 'scale_rgb' must hold three scales > 0 (R, G, B)"));
}
