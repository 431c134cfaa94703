// What each calibration result tells the technician (describe(): the lines `paintlab
// calibrate` prints and the reports show): the figures with their units and standard
// deviations, what was left out and why.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "paintlab/calibration/dark.h"
#include "paintlab/calibration/flat.h"
#include "paintlab/calibration/intrinsics.h"
#include "paintlab/calibration/light.h"
#include "paintlab/calibration/response.h"
#include "paintlab/calibration/scale.h"
#include "paintlab/calibration/sphere.h"

using namespace paintlab;
using ::testing::HasSubstr;
using ::testing::Not;

TEST(Describe, IntrinsicsGiveEachParameterWithItsDeviationAndTheDroppedViews) {
  calib::IntrinsicsResult r;
  r.camera.K << 2400.5, 0, 1023.25, 0, 2399.75, 767.5, 0, 0, 1;
  r.camera.dist = {-0.12, 0.3, 0.001, -0.002, 0.0};
  r.std.fx = 0.41;
  r.std.cy = 0.07;
  r.rms_px = 0.0421;
  r.worst_px = 0.2;
  r.views_used = 2;
  for (const char* name : {"a.png", "b.png", "c.png"}) {
    calib::ViewReport v;
    v.name = name;
    v.used = v.detected = std::string(name) != "c.png";
    if (!v.used) v.reason = "no chessboard found";
    r.views.push_back(v);
  }
  r.k3.note = "k3 fixed at 0: the free fit left it less certain than its value";
  const std::string s = r.describe();
  EXPECT_THAT(s, HasSubstr("2 of 3 views, RMS 0.042 px (worst corner 0.200 px)"));
  EXPECT_THAT(s, HasSubstr("fx 2400.50 +- 0.41"));
  EXPECT_THAT(s, HasSubstr("cy 767.50 +- 0.07 px"));
  EXPECT_THAT(s, HasSubstr("dist [-0.12, 0.3, 0.001, -0.002, 0]"));
  EXPECT_THAT(s, HasSubstr("\n  k3 fixed at 0"));
  EXPECT_THAT(s, HasSubstr("\n  dropped c.png: no chessboard found"));
  EXPECT_THAT(s, Not(HasSubstr("dropped a.png")));
}

TEST(Describe, TheSphereCentreIsInMillimetresWithItsDeviation) {
  calib::SphereFit f;
  f.centre_cam_m = Vec3(0.0012, -0.0034, 0.9);
  f.centre_cov_m2 = Vec3(1e-10, 4e-10, 2.5e-9).asDiagonal();
  f.rms_px = 0.0312;
  f.edges_used = 900;
  f.coverage = 0.62;
  f.edge_width_px = 2.41;
  const std::string s = f.describe();
  EXPECT_THAT(s, HasSubstr("centre (1.20, -3.40, 900.00) mm +- (0.010, 0.020, 0.050) mm"));
  EXPECT_THAT(s, HasSubstr("silhouette RMS 0.031 px over 900 edge points (62 % of the outline), edge width 2.41 px"));
}

TEST(Describe, TheLightSaysWhereItsBlurCameFromAndWhichHighlightsItLeftOut) {
  calib::LightCalibration l;
  l.model.arm_radius_m = 0.5;
  l.arm_radius_std_m = 0.0002;
  l.used = 1;
  l.rms_deg = 0.0123;
  l.blur_sigma_px = 0.8;
  l.blur_source = "sphere";
  calib::Highlight used, clipped;
  used.used = true;
  used.name = "light_angle10.png";
  clipped.name = "light_angle-150.png";
  clipped.table_angle_deg = -150;
  clipped.reason = "the highlight is off the sphere";
  l.highlights = {used, clipped};
  const std::string s = l.describe();
  EXPECT_THAT(s, HasSubstr("1 of 2 highlights, residual RMS 0.0123 deg"));
  EXPECT_THAT(s, HasSubstr("arm radius 500.00 +- 0.20 mm"));
  EXPECT_THAT(s, HasSubstr("highlight blur 0.800 px (the silhouette's edge blur: too few highlights to fit it)"));
  EXPECT_THAT(s, HasSubstr("not used light_angle-150.png (-150 deg): the highlight is off the sphere"));
  l.blur_source = "highlights";
  l.blur_std_px = 0.02;
  EXPECT_THAT(l.describe(), HasSubstr("0.800 px +- 0.020 (fitted to the highlights)"));
}

TEST(Describe, ScaleDarkResponseAndFlatGiveTheirFiguresInTheirUnits) {
  calib::ScaleCalibration sc;
  sc.scale = 123456.7;
  sc.uncertainty_rel = 0.0021;
  sc.saturated = 3;
  sc.pixels = 1000;
  sc.saturated_frac = 0.003;
  EXPECT_THAT(sc.describe(), HasSubstr("scale: 123457 DN/s per (1/sr W/m^2 per W/sr) +- 0.210 %"));
  EXPECT_THAT(sc.describe(), HasSubstr("1000 pixels, 3 saturated (0.300 %)"));

  calib::DarkFrame d;
  d.frame_count = 16;
  d.exposures_s = {0.001, 0.3};
  d.mean_bias_dn = 64.25;
  EXPECT_THAT(d.describe(), HasSubstr("16 frames at 2 exposure(s); black level 64.25 DN"));
  EXPECT_THAT(d.describe(), HasSubstr("read noise not measured"));
  d.read_noise_measured = true;
  d.read_noise_dn = 2.5;
  EXPECT_THAT(d.describe(), HasSubstr("read noise 2.5 DN"));

  calib::ResponseCurve r = calib::ResponseCurve::identity(12, 1, {});
  r.report.exposure_ratio = {1.0, 1.0, 1.0};
  r.report.linearity_error_rel = 0.0012;
  r.report.nonlinearity_rel = {0.01, 0.034};
  const std::string rs = r.describe();
  EXPECT_THAT(rs, HasSubstr("robertson method, 12-bit, 1 channel(s)"));
  EXPECT_THAT(rs, HasSubstr("3 images"));
  EXPECT_THAT(rs, HasSubstr("linearity error 0.12 %"));
  EXPECT_THAT(rs, HasSubstr("nonlinearity of the camera 3.40 %"));
  EXPECT_THAT(rs, Not(HasSubstr("noise:")));
  r.noise.read_noise_dn = 2.0;
  r.noise.gain_dn_per_e = 0.25;
  r.noise.source = "photon transfer";
  EXPECT_THAT(r.describe(), HasSubstr("noise: read 2 DN, shot 0.25 DN/e (photon transfer)"));

  calib::FlatField f;
  f.frame_count = 8;
  f.corner_ratio = 0.912;
  f.prnu_rel = 0.0043;
  EXPECT_THAT(f.describe(), HasSubstr("8 frames"));
  EXPECT_THAT(f.describe(), HasSubstr("darkest/brightest corner 0.912"));
  EXPECT_THAT(f.describe(), HasSubstr("pixel non-uniformity 0.43 %"));
}
