#include <gtest/gtest.h>

#include <opencv2/calib3d.hpp>

#include "paintlab/core/error.h"
#include "paintlab/sim/paint.h"
#include "paintlab/sim/world.h"
#include "sim_test_util.h"
#include "test_util.h"

using namespace paintlab;

namespace {

sim::SimConfig analytic_config() {
  sim::SimConfig c = sim::test::small_config(12.0);
  c.camera.fx_px = 1872.0;
  c.camera.fy_px = 1869.0;
  c.camera.cx_px = 161.2;
  c.camera.cy_px = 118.7;
  c.camera.dist = {-0.6, 2.0, 0.002, -0.001, 0.0};
  c.camera.roll_deg = 0.4;
  c.camera.look_at_rig_m = Vec3(0.001, -0.002, 0.001);
  c.sphere.centre_rig_m = Vec3(0.002, -0.001, 0.0015);
  c.led.zero_deg = 0.7;
  c.led.arm_height_m = 0.01;
  c.led.profile_exponent = 2.0;
  c.led.color = {1.0, 0.9, 0.7};
  c.sensor.prnu_rel = 0.0;
  c.sensor.hot_pixel_frac = 0.0;
  c.sensor.response_poly = {1.12, -0.16, 0.04};
  return c;
}

// The ray through a pixel centre by OpenCV's undistortion (independent of the renderer).
Vec3 cv_ray_cam(const sim::SimWorld& w, double u, double v, Vec2* xn_out = nullptr) {
  Mat3 k = w.K();
  cv::Mat K = (cv::Mat_<double>(3, 3) << k(0, 0), 0, k(0, 2), 0, k(1, 1), k(1, 2), 0, 0, 1);
  std::vector<cv::Point2d> in{{u, v}}, out;
  cv::undistortPoints(in, out, K, cv::Mat(w.dist()), cv::noArray(), cv::noArray(),
                      cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 200, 1e-15));
  if (xn_out) *xn_out = Vec2(out[0].x, out[0].y);
  return Vec3(out[0].x, out[0].y, 1.0).normalized();
}

// The radiance the test predicts for a sphere pixel, from the formulas of the design.
bool predict_sphere(const sim::SimWorld& w, const brdf::Brdf& f, double angle_deg, double x, double y,
                    brdf::Rgb* out) {
  const sim::SimConfig& c = w.config();
  Rigid3 rig_from_cam = w.cam_from_rig().inverse();
  Vec3 o = rig_from_cam.translation;
  Vec3 d = rig_from_cam.rotation * cv_ray_cam(w, x, y);
  Vec3 oc = o - c.sphere.centre_rig_m;
  double b = oc.dot(d), disc = b * b - (oc.squaredNorm() - c.sphere.radius_m * c.sphere.radius_m);
  if (disc < 0) return false;
  Vec3 p = o + (-b - std::sqrt(disc)) * d;
  Vec3 n = (p - c.sphere.centre_rig_m).normalized();
  double a = deg_to_rad(angle_deg + c.led.zero_deg);
  Vec3 led(c.led.arm_radius_m * std::cos(a), c.led.arm_radius_m * std::sin(a), c.led.arm_height_m);
  Vec3 axis = (c.led.aim_rig_m - led).normalized();
  Vec3 wi = (led - p).normalized(), wo = (o - p).normalized();
  double dist2 = (led - p).squaredNorm();
  double intensity = c.led.intensity_w_sr * std::pow(axis.dot(-wi), c.led.profile_exponent);
  // Local frame: any tangent works for this isotropic lobe.
  Vec3 t = n.unitOrthogonal(), s = n.cross(t);
  Vec3 wi_l(wi.dot(t), wi.dot(s), wi.dot(n)), wo_l(wo.dot(t), wo.dot(s), wo.dot(n));
  double cos_i = n.dot(wi);
  if (cos_i <= 0) return false;
  *out = f.eval(wi_l, wo_l) * brdf::Rgb(c.led.color[0], c.led.color[1], c.led.color[2]) * (intensity * cos_i / dist2);
  return true;
}

}  // namespace

TEST(Render, SpherePixelEqualsTheAnalyticPrediction) {
  sim::SimWorld world(analytic_config());
  auto brdf = std::make_shared<sim::test::TestLobeBrdf>(0.3, 0.2, 0.3);
  world.set_paint({brdf, std::nullopt});
  const double angle = 40.0;
  world.set_table_angle_deg(angle);
  sim::RenderOptions rgb_opt;
  rgb_opt.mono = false;
  ImageF rgb = world.render(rgb_opt);
  ImageF mono = world.render();
  ASSERT_EQ(rgb.channels(), 3);
  ASSERT_EQ(mono.channels(), 1);
  Vec2 c = world.camera().project(world.sphere_centre_cam());
  const auto& mw = world.config().camera.mono_weights;
  int checked = 0;
  for (int dy : {-40, -20, 0, 15, 35})
    for (int dx : {-45, -10, 0, 25, 50}) {
      int x = static_cast<int>(c.x()) + dx, y = static_cast<int>(c.y()) + dy;
      brdf::Rgb expected;
      if (!predict_sphere(world, *brdf, angle, x, y, &expected) || expected.maxCoeff() < 1e-6) continue;
      ++checked;
      for (int k = 0; k < 3; ++k) EXPECT_THAT(rgb.at(x, y, k), test::NearRel(expected[k], 1e-5)) << x << "," << y;
      EXPECT_THAT(mono.at(x, y), test::NearRel(mw[0] * expected[0] + mw[1] * expected[1] + mw[2] * expected[2], 1e-5));
    }
  EXPECT_GE(checked, 15);

  // Through the sensor: BRDF x irradiance x exposure x gain, through the response curve.
  int x = static_cast<int>(c.x()) - 10, y = static_cast<int>(c.y()) - 20;
  brdf::Rgb e_rgb;
  ASSERT_TRUE(predict_sphere(world, *brdf, angle, x, y, &e_rgb));
  double radiance = mw[0] * e_rgb[0] + mw[1] * e_rgb[1] + mw[2] * e_rgb[2];
  Vec2 xn;
  cv_ray_cam(world, x, y, &xn);
  double cos2 = 1.0 / (1.0 + xn.squaredNorm());
  const auto& sp = world.config().sensor;
  double photon = 6.62607015e-34 * 2.99792458e8 / (sp.wavelength_nm * 1e-9);
  double e_per_s = sp.qe * std::pow(6.45e-6, 2) * kPi / (4 * 64.0) * cos2 * cos2 / photon * radiance;
  const double gain_db = 3.0;
  double G = (4095.0 - 64.0) / 18000.0 * std::pow(10.0, gain_db / 20.0);
  double t = 6000.0 / e_per_s;  // about 6000 electrons
  double mu = e_per_s * t + sp.dark_current_e_per_s * t;
  double xs = mu * G / (4095.0 - 64.0);
  double expected_raw = 64.0 + (1.12 * xs - 0.16 * xs * xs + 0.04 * xs * xs * xs) * (4095.0 - 64.0);
  double sum = 0;
  const int frames = 32;
  ImageF once = world.render();  // one render serves every exposure
  for (int f = 0; f < frames; ++f) {
    sim::ExposureSettings e;
    e.exposure_s = t;
    e.gain_db = gain_db;
    sum += world.sensor().expose(once, e).at(x, y);
  }
  double sigma = G * 1.12 * std::sqrt(mu + 36.0) / std::sqrt(frames) + 0.3;
  EXPECT_NEAR(sum / frames, expected_raw, 4.0 * sigma) << "sigma of the mean " << sigma << " DN";
  EXPECT_NEAR(world.sensor().expected_raw(radiance, x, y, t, gain_db), expected_raw, 1e-3 * expected_raw);
}

TEST(Render, WhiteReferenceSphereHasItsAlbedo) {
  sim::SimWorld world(analytic_config());
  ImageF img = world.render_with(sim::reference_paint(0.9), 25.0, true);
  brdf::Lambertian white(brdf::Rgb::Constant(0.9));
  Vec2 c = world.camera().project(world.sphere_centre_cam());
  const auto& mw = world.config().camera.mono_weights;
  int checked = 0;
  for (int dx : {-30, 0, 20, 40}) {
    brdf::Rgb e;
    int x = static_cast<int>(c.x()) + dx, y = static_cast<int>(c.y()) - 5;
    if (!predict_sphere(world, white, 25.0, x, y, &e)) continue;
    ++checked;
    EXPECT_THAT(img.at(x, y), test::NearRel(mw[0] * e[0] + mw[1] * e[1] + mw[2] * e[2], 1e-5));
  }
  EXPECT_GE(checked, 3);
  EXPECT_THROW(sim::reference_paint(1.5), DataError);
}

TEST(Render, LedTruthAccessors) {
  sim::SimConfig cfg = analytic_config();
  sim::SimWorld world(cfg);
  double a = deg_to_rad(30.0 + 0.7);
  Vec3 led = world.led_position_rig(30.0);
  EXPECT_NEAR((led - Vec3(0.5 * std::cos(a), 0.5 * std::sin(a), 0.01)).norm(), 0.0, 1e-12);
  EXPECT_NEAR((world.led_position_cam(30.0) - world.cam_from_rig() * led).norm(), 0.0, 1e-12);
  EXPECT_NEAR((world.sphere_centre_cam() - world.cam_from_rig() * cfg.sphere.centre_rig_m).norm(), 0.0, 1e-12);
  brdf::Rgb on_axis = world.led_radiant_intensity(30.0, Vec3::Zero());
  EXPECT_NEAR(on_axis[0], 0.1, 1e-12);
  EXPECT_NEAR(on_axis[2], 0.07, 1e-12);
  EXPECT_NEAR(world.led_profile(deg_to_rad(60.0)), 0.25, 1e-12);  // cos^2
  EXPECT_EQ(world.led_profile(deg_to_rad(100.0)), 0.0);
  EXPECT_NEAR(world.reference_footprint_m2(),
              (world.camera().centre_rig() - cfg.sphere.centre_rig_m).squaredNorm() / (1872.0 * 1869.0), 1e-18);
}

TEST(Render, FeltBackdropIsLitAndShadowed) {
  sim::SimConfig cfg = sim::test::small_config(12.0);
  sim::SimWorld world(cfg);
  world.set_table_angle_deg(0.0);  // LED on the camera side, shining at the backdrop
  ImageF img = world.render();
  Rigid3 rig_from_cam = world.cam_from_rig().inverse();
  Vec3 o = rig_from_cam.translation;
  Vec3 led = world.led_position_rig(0.0);
  auto predict = [&](int x, int y) {
    Vec3 d = rig_from_cam.rotation * cv_ray_cam(world, x, y);
    Vec3 p = o + ((-cfg.scene.backdrop_distance_m - o.x()) / d.x()) * d;
    Vec3 wi = (led - p).normalized();
    double prof = (-led.normalized()).dot(-wi);  // Lambertian LED aimed at the origin
    return cfg.scene.felt_albedo / kPi * cfg.led.intensity_w_sr * prof * wi.x() / (led - p).squaredNorm();
  };
  EXPECT_THAT(img.at(5, 5), test::NearRel(predict(5, 5), 1e-4));
  EXPECT_THAT(img.at(310, 8), test::NearRel(predict(310, 8), 1e-4));
  // Just outside the sphere's silhouette the backdrop lies in its shadow.
  Vec2 c = world.camera().project(world.sphere_centre_cam());
  double r_px = cfg.camera.fx_px * cfg.sphere.radius_m / world.sphere_centre_cam().norm();
  int x = static_cast<int>(c.x() + r_px * 1.15), y = static_cast<int>(c.y());
  EXPECT_GT(predict(x, y), 0.0);
  EXPECT_EQ(img.at(x, y), 0.0f);
  // LED off: nothing.
  ImageF off = world.render_at(0.0, false);
  for (float v : off.values()) ASSERT_EQ(v, 0.0f);
}

TEST(Render, ArmPostIsDrawnAndMovesWithTheTable) {
  sim::SimConfig cfg = sim::test::small_config(12.0);
  cfg.scene.arm_post_radius_m = 0.01;
  sim::SimWorld world(cfg);
  sim::SimConfig no_arm_cfg = cfg;
  no_arm_cfg.scene.arm_post_radius_m = 0.0;
  sim::SimWorld no_arm(no_arm_cfg);
  Vec2 px = world.camera().project_rig(Vec3(0.5, 0.0, -0.02));  // the post at table angle 0
  int x = static_cast<int>(std::lround(px.x())), y = static_cast<int>(std::lround(px.y()));
  ASSERT_TRUE(x > 2 && y > 2 && x < 317 && y < 237);
  ImageF with = world.render_at(0.0, true), without = no_arm.render_at(0.0, true);
  EXPECT_GT(without.at(x, y), 0.0f);   // lit backdrop behind
  EXPECT_EQ(with.at(x, y), 0.0f);      // the post below the LED gets no light
  // Away from the post both images agree.
  EXPECT_EQ(with.at(x + 30, y), without.at(x + 30, y));
  // At 20 deg the post has moved away from that pixel.
  EXPECT_EQ(world.render_at(20.0, true).at(x, y), no_arm.render_at(20.0, true).at(x, y));
}

TEST(Render, SilhouetteIsSubPixelAccurate) {
  sim::SimConfig cfg = sim::test::small_config(12.0);
  cfg.render.edge_samples = 64;
  sim::SimWorld world(cfg);
  ImageF cov = world.sphere_coverage();
  Vec3 c = world.sphere_centre_cam();
  double r = cfg.sphere.radius_m;
  const auto& k = cfg.camera;
  Vec2 cp = world.camera().project(c);
  double worst = 0;
  for (int dy : {-3, 0, 2}) {
    int y = static_cast<int>(cp.y()) + dy;
    double yn = (y - k.cy_px) / k.fy_px;
    // Rays (x, yn, 1) tangent to the sphere: (c . d)^2 = |d|^2 (|c|^2 - r^2).
    double a = c.x(), b = c.y() * yn + c.z(), C = c.squaredNorm() - r * r, kk = yn * yn + 1;
    double qa = a * a - C, qb = 2 * a * b, qc = b * b - kk * C;
    double disc = std::sqrt(qb * qb - 4 * qa * qc);
    double x1 = (-qb - disc) / (2 * qa), x2 = (-qb + disc) / (2 * qa);
    double chord_px = std::abs(x2 - x1) * k.fx_px;
    double sum = 0;
    for (int x = 0; x < cov.width(); ++x) sum += cov.at(x, y);
    worst = std::max(worst, std::abs(sum - chord_px));
  }
  std::printf("silhouette chord error: %.4f px\n", worst);
  EXPECT_LT(worst, 0.02);
}

TEST(Render, DeterministicAndThreadIndependent) {
  sim::SimWorld a(analytic_config()), b(analytic_config());
  auto brdf = std::make_shared<sim::test::TestLobeBrdf>(0.3, 0.2, 0.3);
  sim::Sparkle sp;
  sp.density = 1.0;
  sp.flake_part = std::make_shared<sim::test::TestLobeBrdf>(0.0, 0.2, 0.3);
  a.set_paint({brdf, sp});
  b.set_paint({brdf, sp});
  sim::RenderOptions one, two;
  one.threads = 1;
  two.threads = 2;
  ImageF ra = a.render_at(35.0, true, one), rb = b.render_at(35.0, true, two);
  EXPECT_EQ(ra.values(), rb.values());
  EXPECT_EQ(a.render_at(35.0, true).values(), ra.values());
  EXPECT_NE(a.render_at(36.0, true).values(), ra.values());
  sim::ExposureSettings e;
  e.exposure_s = 0.01;
  EXPECT_EQ(a.capture(e).values(), b.capture(e).values());
  EXPECT_THROW(a.set_paint({nullptr, std::nullopt}), DataError);
}

// A camera pixel integrates the radiance over its area: a highlight 2-3 px across is the mean
// over each pixel (the test's own 16 x 16 grid of rays through OpenCV's undistortion), not its
// centre value; with interior_samples = 1 the centres are what the renderer gives.
TEST(Render, ANarrowHighlightIsIntegratedOverEachPixel) {
  sim::SimConfig config = analytic_config();
  config.camera.psf_sigma_px = 0.0;
  auto brdf = std::make_shared<sim::test::TestLobeBrdf>(0.05, 0.5, 0.03);
  const double angle = 30.0;
  auto render = [&](int samples) {
    sim::SimConfig c = config;
    c.render.interior_samples = samples;
    sim::SimWorld world(c);
    world.set_paint({brdf, std::nullopt});
    world.set_table_angle_deg(angle);
    sim::RenderOptions opt;
    opt.mono = false;
    return world.render(opt);
  };
  const ImageF integrated = render(4), centres = render(1);
  sim::SimWorld world(config);
  int bx = 0, by = 0;
  for (int y = 0; y < centres.height(); ++y)
    for (int x = 0; x < centres.width(); ++x)
      if (centres.at(x, y, 0) > centres.at(bx, by, 0)) bx = x, by = y;
  const int n = 16;
  int checked = 0, differ = 0;
  for (int y = by - 3; y <= by + 3; ++y)
    for (int x = bx - 3; x <= bx + 3; ++x) {
      brdf::Rgb centre, sum = brdf::Rgb::Zero();
      ASSERT_TRUE(predict_sphere(world, *brdf, angle, x, y, &centre));
      EXPECT_THAT(centres.at(x, y, 0), test::NearRel(centre[0], 1e-4)) << x << "," << y;
      for (int b = 0; b < n; ++b)
        for (int a = 0; a < n; ++a) {
          brdf::Rgb v;
          ASSERT_TRUE(predict_sphere(world, *brdf, angle, x - 0.5 + (a + 0.5) / n, y - 0.5 + (b + 0.5) / n, &v));
          sum += v;
        }
      const brdf::Rgb mean = sum / (n * n);
      if (mean[0] < 0.05 * centres.at(bx, by, 0)) continue;
      ++checked;
      for (int k = 0; k < 3; ++k) EXPECT_THAT(integrated.at(x, y, k), test::NearRel(mean[k], 0.01)) << x << "," << y;
      if (std::abs(centre[0] / mean[0] - 1.0) > 0.05) ++differ;
    }
  EXPECT_GE(checked, 9);
  EXPECT_GE(differ, 4) << "the highlight is not narrow enough for the test to tell centres from means";
}
