// Sphere pose from the silhouette, on the simulated rig (truth known) and on synthetic
// geometry: the cone geometry, the limb profile, the centre within 0.1 mm.
#include <gtest/gtest.h>

#include <cstdio>

#include "paintlab/calibration/sphere.h"
#include "paintlab/core/error.h"
#include "sim_scenes.h"
#include "test_util.h"

using namespace paintlab;
using namespace paintlab::calib;
using namespace paintlab::calib::testing;

TEST(SphereGeometry, LimbProfileMatchesItsDefinition) {
  // H(x) = E[sqrt(x - Z) ; Z < x] for a standard normal Z; check by direct quadrature.
  for (double x : {-3.0, -0.5, 0.0, 0.7, 2.0, 10.0, 35.0, 60.0}) {
    double h = 0;
    const double du = 1e-4;
    for (double u = du / 2; u < x + 12; u += du) h += std::sqrt(u) * std::exp(-0.5 * (x - u) * (x - u)) / std::sqrt(2 * kPi) * du;
    double d = 0;
    EXPECT_NEAR(limb_profile(x, &d), h, 2e-4 * std::max(1.0, h)) << "x = " << x;
    const double num = (limb_profile(x + 1e-4) - limb_profile(x - 1e-4)) / 2e-4;
    EXPECT_NEAR(d, num, 1e-3) << "x = " << x;
  }
}

TEST(SphereGeometry, SilhouetteRaysMakeTheConeOfTheSphere) {
  CameraModel cam;
  cam.width_px = 1360;
  cam.height_px = 1024;
  cam.K << 7780, 0, 684, 0, 7778, 509, 0, 0, 1;
  cam.dist = {-0.21, 0.9, 0.0004, -0.0003, 0.0};
  const Vec3 c(0.03, -0.02, 1.2);
  for (const Vec2& p : silhouette_points(cam, c, 0.04, 64)) {
    Vec3 r = cam.ray(p);
    // Tangent: the ray's closest approach to the centre is the radius.
    EXPECT_NEAR((r.dot(c) * r - c).norm(), 0.04, 1e-9);
  }
  auto hit = intersect_sphere(c.normalized(), c, 0.04);
  ASSERT_TRUE(hit.has_value());
  EXPECT_NEAR((*hit - c).norm(), 0.04, 1e-12);
  EXPECT_NEAR(hit->norm(), c.norm() - 0.04, 1e-12);
  EXPECT_FALSE(intersect_sphere(Vec3(1, 0, 1), c, 0.04).has_value());
}

TEST(SphereSim, SideLitWhiteSphereCentreWithinATenthOfAMillimetre) {
  // The sphere step in isolation: true intrinsics, images linearised with the true response.
  sim::SimWorld world(sim_rig_config());
  std::vector<SphereImage> images;
  for (double angle : {90.0, 270.0})
    images.push_back({"white-" + std::to_string(static_cast<int>(angle)),
                      expose_linear(world, world.render_with(sim::reference_paint(0.99), angle, true))});
  SphereOptions o;
  o.radius_m = world.sphere_radius_m();
  SphereFit fit = fit_sphere(images, truth_camera(world), o);
  const Vec3 err = fit.centre_cam_m - world.sphere_centre_cam();
  const Vec3 sd = fit.centre_std_m();
  std::printf("sphere centre error (%.4f, %.4f, %.4f) mm, |e| %.4f mm, std (%.4f %.4f %.4f) mm; rms %.3f px, "
              "edges %d/%d, coverage %.2f, edge sigma %.3f px (width %.2f px), ellipse rms %.3f px\n",
              err.x() * 1e3, err.y() * 1e3, err.z() * 1e3, err.norm() * 1e3, sd.x() * 1e3, sd.y() * 1e3, sd.z() * 1e3,
              fit.rms_px, fit.edges_used, fit.edges_total, fit.coverage, fit.edge_sigma_px, fit.edge_width_px,
              fit.ellipse_rms_px);
  EXPECT_LT(err.norm(), 1e-4);
  // The depth, which the light step's arm radius hangs on (13 % per 0.1 mm, light_test.cpp).
  EXPECT_LT(std::abs(err.z()), 2e-5);
  EXPECT_LT(fit.rms_px, 0.05);
  EXPECT_LT(fit.ellipse_rms_px, 0.05);
  EXPECT_GT(fit.coverage, 0.6);
  // PSF 0.5 px and the pixel box: sigma about 0.58 px.
  EXPECT_NEAR(fit.edge_sigma_px, 0.55, 0.12);
  test::TempDir dir;
  fit.save(dir / "sphere.json");
  SphereFit back = SphereFit::load(dir / "sphere.json");
  EXPECT_LT((back.centre_cam_m - fit.centre_cam_m).norm(), 1e-12);
  EXPECT_DOUBLE_EQ(back.edge_width_px, fit.edge_width_px);
  EXPECT_EQ(back.provenance.kind, "sphere");
}

TEST(SphereSim, EachSideLitImageAloneFindsTheWholeLitLimbAtHalfResolution) {
  // The quick demo's camera (half resolution, same field of view). Lit from one side, the
  // bright blob is the lit part of the disc only, cut off by the terminator: the coarse
  // circle must come from the limb, not from the blob's enclosing circle (centred on the
  // cut, ~27 px off here), or the edge search around it finds only a handful of the lit
  // limb's edge points (4 to 10 of ~90 per image: too few to fit).
  sim::SimConfig cfg = sim_rig_config();
  const Mat3 K = cfg.camera.K();
  cfg.camera.width_px /= 2;
  cfg.camera.height_px /= 2;
  cfg.camera.fx_px = 0.5 * K(0, 0);
  cfg.camera.fy_px = 0.5 * K(1, 1);
  cfg.camera.cx_px = 0.5 * (K(0, 2) + 0.5) - 0.5;
  cfg.camera.cy_px = 0.5 * (K(1, 2) + 0.5) - 0.5;
  cfg.camera.pixel_size_m *= 2.0;
  cfg.camera.psf_sigma_px *= 0.5;
  sim::SimWorld world(cfg);
  SphereOptions o;
  o.radius_m = world.sphere_radius_m();
  for (double angle : {90.0, 270.0}) {
    const std::string name = "white-" + std::to_string(static_cast<int>(angle));
    SphereFit fit;
    ASSERT_NO_THROW(fit = fit_sphere({{name, expose_linear(world, world.render_with(sim::reference_paint(0.99), angle, true))}},
                                     truth_camera(world), o))
        << name;
    const Vec3 err = fit.centre_cam_m - world.sphere_centre_cam();
    std::printf("%s alone: %d edge points, coverage %.2f, rms %.3f px, centre error (%.3f, %.3f, %.3f) mm\n",
                name.c_str(), fit.edges_used, fit.coverage, fit.rms_px, err.x() * 1e3, err.y() * 1e3, err.z() * 1e3);
    // One side's limb: about 40 % of the outline.
    EXPECT_GT(fit.edges_used, 60) << name;
    EXPECT_GT(fit.coverage, 0.35) << name;
    EXPECT_LT(fit.rms_px, 0.05) << name;
    EXPECT_LT(err.norm(), 0.5e-3) << name;
  }
}

TEST(SphereSim, FrontalLightLeavesTheLimbDarkAndTheUncertaintyShowsIt) {
  // Lit from the camera side, a Lambertian limb rises like sqrt(t) from black: those edges
  // are left out, few remain, and the reported depth uncertainty is large.
  sim::SimWorld world(sim_rig_config());
  SphereOptions o;
  o.radius_m = world.sphere_radius_m();
  SphereFit fit = fit_sphere({{"white-0", expose_linear(world, world.render_with(sim::reference_paint(0.99), 0.0, true))}},
                             truth_camera(world), o);
  std::printf("frontal: coverage %.2f, depth std %.3f mm\n", fit.coverage, fit.centre_std_m().z() * 1e3);
  EXPECT_LT(fit.coverage, 0.6);
  EXPECT_GT(fit.centre_std_m().z(), 5 * 3.8e-6);
}

TEST(SphereSim, NoSphereInTheImageSaysSo) {
  sim::SimWorld world(sim_rig_config());
  SphereOptions o;
  o.radius_m = 0.04;
  ImageF dark(world.camera().width(), world.camera().height(), 1, 0.0f);
  EXPECT_THAT(test::error_message<CalibrationError>([&] { fit_sphere({{"lens-cap", dark}}, truth_camera(world), o); }),
              ::testing::HasSubstr("no bright sphere found in 'lens-cap'"));
}

// Found fuzzing sphere.json: a centre covariance of another shape was assigned to the 3 x 3
// matrix (an Eigen assertion in a debug build, memory overwritten in a release one).
TEST(SphereFitFile, ACovarianceOfTheWrongShapeIsADataError) {
  SphereFit s;
  s.radius_m = 0.04;
  s.centre_cam_m = Vec3(0.0, 0.0, 1.2);
  Json j = s.to_json();
  j["centre_cov_m2"] = Json::array({Json::array({1e-8, 0.0}), Json::array({0.0, 1e-8})});
  try {
    (void)SphereFit::from_json(j, "sphere.json");
    ADD_FAILURE() << "a 2 x 2 covariance was read";
  } catch (const DataError& e) {
    EXPECT_THAT(std::string(e.what()), ::testing::HasSubstr("sphere.json: key 'centre_cov_m2': expected a 3 x 3 matrix, got 2 x 2"));
  }
  j["centre_cov_m2"] = matrix_to_json(Eigen::Matrix3d::Identity() * 1e-8);
  EXPECT_DOUBLE_EQ(SphereFit::from_json(j, "sphere.json").centre_cov_m2(2, 2), 1e-8);
}
