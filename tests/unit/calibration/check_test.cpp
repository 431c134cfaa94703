// `paintlab check` logic on the simulated rig: a good rig passes; each check catches its
// bad rig (a moved sphere, a blurred camera, a saturated reference, a drifting LED, an LED
// that moved, a stale calibration, exchanged devices, a missing file) with its message.
#include <gtest/gtest.h>

#include <cstdio>
#include <memory>

#include "paintlab/brdf/cook_torrance.h"
#include "paintlab/calibration/check.h"
#include "paintlab/calibration/dark.h"
#include "paintlab/calibration/flat.h"
#include "paintlab/calibration/response.h"
#include "paintlab/core/error.h"
#include "sim_scenes.h"
#include "paintlab/sim/paint.h"
#include "test_util.h"

using namespace paintlab;
using namespace paintlab::calib;
using namespace paintlab::calib::testing;

namespace {

const Json kDevices = {{"camera", "SIM-CAM-0001"}, {"turntable", "sim-modbus"}, {"light", "sim-led"}};

SphereFit fit_sphere_now(sim::SimWorld& w, const CameraModel& cam) {
  std::vector<SphereImage> images;
  for (double a : {90.0, 270.0})
    images.push_back({"side-" + std::to_string(static_cast<int>(a)), expose_linear(w, w.render_with(sim::reference_paint(0.99), a, true))});
  SphereOptions o;
  o.radius_m = w.sphere_radius_m();
  return fit_sphere(images, cam, o);
}

ImageF rate_image(sim::SimWorld& w, const sim::SimPaint& paint, double angle, double exposure_s,
                  Image<std::uint8_t>* saturated = nullptr) {
  sim::ExposureSettings es;
  es.exposure_s = exposure_s;
  return linearise_raw(w, w.sensor().expose(w.render_with(paint, angle, true), es), exposure_s, saturated);
}

// A calibrated good rig, computed once: the files in a temporary calibration folder.
class CheckSim : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new test::TempDir();
    rig_ = new RigConfig(RigConfig::load(test::source_dir() / "examples" / "rig-sim.toml"));
    rig_->calibration_dir = dir_->path();
    world_ = new sim::SimWorld(sim_rig_config());
    cam_ = new CameraModel(truth_camera(*world_));
    IntrinsicsResult in;
    in.camera = *cam_;
    in.rms_px = 0.05;
    in.views_used = 12;
    in.provenance = Provenance::make("intrinsics", {}, kDevices);
    in.save(dir_->path() / kCameraFile);
    // The true sphere with the figures a sphere calibration of this rig records (the fit
    // itself is tested in sphere_test.cpp; this keeps the fixture fast).
    SphereFit s = truth_sphere(*world_);
    s.rms_px = 0.019;
    s.edge_sigma_px = 0.5;
    s.edge_width_px = 2.5631 * 0.5;
    s.edges_used = 370;
    s.coverage = 0.94;
    s.provenance = Provenance::make("sphere", {}, kDevices);
    s.save(dir_->path() / kSphereFile);
    LightCalibration l;
    l.model = truth_light(*world_);
    l.rms_deg = 0.004;
    l.max_deg = 0.008;
    l.used = 16;
    l.provenance = Provenance::make("light", {}, kDevices);
    l.save(dir_->path() / kLightFile);
    ScaleOptions so;
    so.albedo = 0.99;
    // The exposure that fills 60 % of the range with the reference.
    expose_linear(*world_, world_->render_with(sim::reference_paint(0.99), 0.0, true), 0.6, &exposure_);
    ReferenceImage ref{0.0, "white-0", rate_image(*world_, sim::reference_paint(0.99), 0.0, exposure_, nullptr), {}};
    ScaleCalibration sc = calibrate_scale({ref}, *cam_, s, l.model, so);
    sc.provenance = Provenance::make("scale", {}, kDevices);
    sc.save(dir_->path() / kScaleFile);
    // The radiometric files as the radiometry steps write them (small maps: the checks read
    // their figures).
    ResponseCurve response = ResponseCurve::identity(12, 1, ValueWindow{8.0, 4095.0, 64.0});
    response.report.linearity_error_rel = 0.004;
    response.provenance = Provenance::make("response", {}, kDevices);
    response.save(dir_->path() / kResponseFile);
    DarkFrame dark;
    dark.bit_depth = 12;
    dark.bias_dn = ImageF(100, 50, 1, 64.0f);
    dark.rate_dn_per_s = ImageF(100, 50, 1, 0.0f);
    dark.hot = ImageU8(100, 50, 1, 0);
    dark.hot.at(3, 4) = 1;  // 1 of 5000 pixels
    dark.hot_count = 1;
    dark.mean_bias_dn = 64.0;
    dark.frame_count = 16;
    dark.exposures_s = {1e-3, 0.3};
    dark.provenance = Provenance::make("dark", {}, kDevices);
    dark.save(dir_->path() / kDarkFile);
    FlatField flat;
    flat.gain = ImageF(100, 50, 1, 1.0f);
    flat.corner_ratio = 0.9;
    flat.frame_count = 8;
    flat.provenance = Provenance::make("flat", {}, kDevices);
    flat.save(dir_->path() / kFlatFile);
  }
  static void TearDownTestSuite() {
    delete world_;
    delete cam_;
    delete rig_;
    delete dir_;
  }
  static RigCalibration calibration() { return RigCalibration::load(dir_->path()); }
  static void expect_fails(const CheckReport& r, const std::string& id, const std::string& action_part) {
    const CheckItem* i = r.find(id);
    ASSERT_NE(i, nullptr) << "no check " << id;
    EXPECT_FALSE(i->pass) << id << " should fail:\n" << r.table();
    EXPECT_THAT(i->action, ::testing::HasSubstr(action_part));
    EXPECT_FALSE(r.passed());
    EXPECT_THAT(r.table(), ::testing::HasSubstr("RIG NOT FIT TO MEASURE"));
    std::printf("%s\n", r.table().c_str());
  }

  static test::TempDir* dir_;
  static RigConfig* rig_;
  static sim::SimWorld* world_;
  static CameraModel* cam_;
  static double exposure_;
};

test::TempDir* CheckSim::dir_ = nullptr;
RigConfig* CheckSim::rig_ = nullptr;
sim::SimWorld* CheckSim::world_ = nullptr;
CameraModel* CheckSim::cam_ = nullptr;
double CheckSim::exposure_ = 0.0;

}  // namespace

TEST_F(CheckSim, GoodRigPassesEveryCheckAndWritesCheckJson) {
  LiveEvidence live;
  live.sphere = fit_sphere_now(*world_, *cam_);
  const RigCalibration cal = calibration();  // keeps the sphere below alive
  const SphereFit& cal_sphere = *cal.sphere();
  for (double a : {-60.0, 0.0, 60.0}) {
    HighlightImage im{a, "glossy", expose_linear(*world_, world_->render_with(sim::glossy_black_sphere_paint(), a, true), 0.8, nullptr, nullptr, 1.0)};
    live.highlights.push_back(find_highlight(im, *cam_, cal_sphere, rig_->geometry));
  }
  std::vector<ImageF> repeated = {rate_image(*world_, sim::reference_paint(0.99), 0.0, exposure_),
                                  rate_image(*world_, sim::reference_paint(0.99), 0.0, exposure_)};
  live.drift_rel = intensity_drift_rel(repeated, *cam_, cal_sphere);
  live.devices = kDevices;
  CheckReport r = run_checks(*rig_, cal, live);
  std::printf("%s\n", r.table().c_str());
  EXPECT_TRUE(r.passed());
  EXPECT_GE(r.items.size(), 30u);
  r.save(dir_->path() / kCheckFile);
  Json j = read_json_file(dir_->path() / kCheckFile);
  EXPECT_TRUE(j["passed"].get<bool>());
  EXPECT_EQ(j["checks"].size(), r.items.size());
}

TEST_F(CheckSim, MovedSphereFails) {
  sim::SimConfig cfg = sim_rig_config();
  cfg.sphere.centre_rig_m += Vec3(0.0, 0.0008, 0.0005);  // knocked 0.9 mm sideways and up
  sim::SimWorld moved(cfg);
  LiveEvidence live;
  live.sphere = fit_sphere_now(moved, *cam_);
  CheckReport r = run_checks(*rig_, calibration(), live);
  expect_fails(r, "sphere.shift_mm", "seat it in its holder");
  EXPECT_NEAR(r.find("sphere.shift_mm")->value, std::hypot(0.8, 0.5), 0.15);
}

TEST_F(CheckSim, BlurredCameraFails) {
  sim::SimConfig cfg = sim_rig_config();
  cfg.camera.psf_sigma_px = 1.6;  // misfocused
  sim::SimWorld blurred(cfg);
  LiveEvidence live;
  live.sphere = fit_sphere_now(blurred, *cam_);
  CheckReport r = run_checks(*rig_, calibration(), live);
  expect_fails(r, "sphere.live_edge_width_px", "refocus the lens");
  EXPECT_TRUE(r.find("sphere.shift_mm")->pass) << "blur alone must not look like a moved sphere";
}

TEST_F(CheckSim, SaturatedReferenceFails) {
  // The scale calibrated from a reference exposed 3 times too long: its bright part clips.
  test::TempDir dir;
  for (const auto& e : std::filesystem::directory_iterator(dir_->path()))
    std::filesystem::copy_file(e.path(), dir / e.path().filename().string());
  RigCalibration good = calibration();
  Image<std::uint8_t> sat;
  ReferenceImage ref{0.0, "white-0-overexposed", rate_image(*world_, sim::reference_paint(0.99), 0.0, 3 * exposure_, &sat), sat};
  ScaleOptions so;
  so.albedo = 0.99;
  ScaleCalibration sc = calibrate_scale({ref}, *cam_, *good.sphere(), good.light()->model, so);
  ASSERT_GT(sc.saturated, 0);
  sc.provenance = Provenance::make("scale", {}, kDevices);
  sc.save(dir / kScaleFile);
  RigConfig rig = *rig_;
  rig.calibration_dir = dir.path();
  CheckReport r = run_checks(rig, RigCalibration::load(dir.path()));
  expect_fails(r, "scale.saturated", "shorter exposure");
  LiveEvidence live;
  live.reference_saturated_frac = sc.saturated_frac;
  expect_fails(run_checks(*rig_, calibration(), live), "scale.live_saturated", "shorten the exposure");
}

TEST_F(CheckSim, DriftingLedFails) {
  // The LED output falls by 4 % between the first and the last capture of the check.
  sim::SimConfig cfg = sim_rig_config();
  cfg.led.intensity_w_sr *= 0.96;
  sim::SimWorld dimmer(cfg);
  std::vector<ImageF> repeated = {rate_image(*world_, sim::reference_paint(0.99), 0.0, exposure_),
                                  rate_image(dimmer, sim::reference_paint(0.99), 0.0, exposure_)};
  LiveEvidence live;
  live.drift_rel = intensity_drift_rel(repeated, *cam_, *calibration().sphere());
  CheckReport r = run_checks(*rig_, calibration(), live);
  expect_fails(r, "light.drift", "let it warm up");
  EXPECT_NEAR(r.find("light.drift")->value, 0.04, 0.005);
}

TEST_F(CheckSim, MovedLedFails) {
  // The arm slipped by 0.5 deg on the table.
  sim::SimConfig cfg = sim_rig_config();
  cfg.led.zero_deg += 0.5;
  sim::SimWorld slipped(cfg);
  LiveEvidence live;
  for (double a : {-60.0, 0.0, 60.0}) {
    HighlightImage im{a, "glossy", expose_linear(slipped, slipped.render_with(sim::glossy_black_sphere_paint(), a, true), 0.8, nullptr, nullptr, 1.0)};
    live.highlights.push_back(find_highlight(im, *cam_, *calibration().sphere(), rig_->geometry));
  }
  CheckReport r = run_checks(*rig_, calibration(), live);
  expect_fails(r, "light.live_angle_deg", "tighten the arm");
  const std::string& detail = r.find("light.live_angle_deg")->detail;
  const auto at = detail.find("azimuth off by ");
  ASSERT_NE(at, std::string::npos) << detail;
  EXPECT_NEAR(std::stod(detail.substr(at + 15)), 0.5, 0.05) << detail;
}

TEST_F(CheckSim, StaleCalibrationFails) {
  test::TempDir dir;
  for (const auto& e : std::filesystem::directory_iterator(dir_->path()))
    std::filesystem::copy_file(e.path(), dir / e.path().filename().string());
  Json j = read_json_file(dir / kSphereFile);
  j["provenance"]["date"] = "2020-01-02T03:04:05Z";
  write_json_file(dir / kSphereFile, j);
  RigConfig rig = *rig_;
  rig.calibration_dir = dir.path();
  CheckReport r = run_checks(rig, RigCalibration::load(dir.path()));
  expect_fails(r, "sphere.age_days", "stale: recalibrate");
  EXPECT_GT(r.find("sphere.age_days")->value, 365.0);
  EXPECT_TRUE(r.find("intrinsics.age_days")->pass);
}

TEST_F(CheckSim, OtherDeviceSerialsFail) {
  // Offline: the files agree with each other; the connected camera is another one.
  LiveEvidence live;
  live.devices = kDevices;
  live.devices["camera"] = "SIM-CAM-0002";
  CheckReport r = run_checks(*rig_, calibration(), live);
  expect_fails(r, "devices.serials", "a device was exchanged");
  EXPECT_THAT(r.find("devices.serials")->detail, ::testing::HasSubstr("SIM-CAM-0001"));
  EXPECT_THAT(r.find("devices.serials")->detail, ::testing::HasSubstr("SIM-CAM-0002"));
}

TEST_F(CheckSim, MissingFileFailsWithTheCommandToRun) {
  test::TempDir dir;
  for (const auto& e : std::filesystem::directory_iterator(dir_->path()))
    if (e.path().filename() != kLightFile) std::filesystem::copy_file(e.path(), dir / e.path().filename().string());
  RigConfig rig = *rig_;
  rig.calibration_dir = dir.path();
  RigCalibration cal = RigCalibration::load(dir.path());
  expect_fails(run_checks(rig, cal), "light.file", "paintlab calibrate light");
  EXPECT_THAT(test::error_message<CalibrationError>([&] { cal.require({kCameraFile, kLightFile}); }),
              ::testing::HasSubstr("light.json: run `paintlab calibrate light"));
}

TEST_F(CheckSim, BundleGivesRaysSpherePointsAndBrdf) {
  RigCalibration cal = calibration();
  const Vec2 c = cal.camera().project(cal.sphere()->centre_cam_m);
  auto sp = cal.sphere_point_at(c);
  ASSERT_TRUE(sp.has_value());
  EXPECT_NEAR(sp->normal.dot(sp->to_camera), 1.0, 1e-3);
  EXPECT_FALSE(cal.sphere_point_at(Vec2(5, 5)).has_value());
  // A grey sphere rendered at 30 deg: the bundle's BRDF is albedo / pi.
  ImageF rate = rate_image(*world_, sim::reference_paint(0.5), 30.0, exposure_);
  std::vector<double> f;
  for (int dy = -60; dy <= 60; dy += 6)
    for (int dx = -60; dx <= 60; dx += 6) {
      const Vec2 px(std::round(c.x()) + dx, std::round(c.y()) + dy);
      auto p = cal.sphere_point_at(px);
      if (!p) continue;
      const double v = cal.brdf(rate.at(static_cast<int>(px.x()), static_cast<int>(px.y())), 30.0, *p);
      if (std::isfinite(v)) f.push_back(v);
    }
  std::sort(f.begin(), f.end());
  EXPECT_THAT(f[f.size() / 2], test::NearRel(0.5 / kPi, 0.01));
  EXPECT_LT((cal.led_position_cam(30.0) - world_->led_position_cam(30.0)).norm(), 1e-6);
}
