// The radiometric calibration captured through a simulated rig's devices (GigE Vision
// camera on 127.0.0.1, Modbus turntable, LED): `paintlab calibrate dark|response|flat --rig R
// --capture`, with the simulator capping the lens, lighting the white reference from the
// side and holding a uniform field in front of the lens. The files are compared with the
// simulator's own truth (same config and seed): hot pixels, the response of a nonlinear
// sensor (within 1 %), the flat field's gain per pixel; then `paintlab hdr merge --rig R`.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fmt/format.h>

#include "paintlab/calibration/dark.h"
#include "paintlab/calibration/flat.h"
#include "paintlab/calibration/response.h"
#include "paintlab/core/image_io.h"
#include "paintlab/core/json.h"
#include "paintlab/core/rig.h"
#include "paintlab/sim/camera_model.h"
#include "paintlab/sim/config.h"
#include "paintlab/sim/sensor.h"
#include "sim_rigs.h"
#include "test_util.h"

using namespace paintlab;
using ::testing::HasSubstr;
namespace fs = std::filesystem;

namespace {

// 320x240, 12-bit ADC read out as Mono16, a nonlinear response R(x) = 0.7x + 0.5x^2 - 0.2x^3
// and mechanical vignetting on top of cos^4.
std::string rig_toml(const fs::path& calib) {
  test::SimRigSpec s;
  s.name = "radiometry-cli-rig";
  s.calibration = calib.string();
  s.focal_length_mm = 12;
  s.positions = 3;
  s.step_deg = 20;
  s.settle_s = 0.1;
  s.dark_frames = std::nullopt;
  s.exposures = 6;
  s.extra = R"([sim]
seed = 11
[sim.camera]
vignetting = [-0.25, 0.0]
[sim.sensor]
response = [0.7, 0.5, -0.2]
hot_pixel_frac = 3e-4
)";
  return test::sim_rig_toml(s);
}

}  // namespace

TEST(RadiometryCliSim, CapturedDarkResponseAndFlatMatchTheSimulatorsTruth) {
  test::TempDir dir;
  const fs::path calib = dir / "calib";
  test::write_text(dir / "rig.toml", rig_toml(calib));
  const std::string rig = (dir / "rig.toml").string();
  const RigConfig rig_config = RigConfig::load(rig);
  const sim::SimConfig truth = sim::SimConfig::from_rig(rig_config);
  const sim::CameraModel camera(truth.camera);
  const sim::Sensor sensor(camera, truth.sensor, truth.seed);
  const double shift = std::ldexp(1.0, 16 - truth.sensor.adc_bits);  // 12-bit ADC read out as 16-bit

  // --- dark: black level, read noise and hot pixels ---
  auto r = test::run_paintlab("calibrate dark --rig " + rig + " --capture", 120);
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_THAT(r.out, HasSubstr("hot pixels"));
  const calib::DarkFrame dark = calib::DarkFrame::load(calib / "dark.json");
  EXPECT_NEAR(dark.mean_bias_dn, truth.sensor.black_level_dn * shift, 1.0);
  // Read noise in raw DN: electrons x gain through the response's slope at black, plus the
  // 12-bit quantisation step.
  const double read_dn = truth.sensor.read_noise_e * sensor.gain_dn_per_e(0.0) * shift *
                         sim::ResponseCurve(truth.sensor.response_poly).slope(0.0);
  const double expected_read = std::sqrt(read_dn * read_dn + shift * shift / 12.0);
  EXPECT_NEAR(dark.read_noise_dn, expected_read, 0.05 * expected_read);
  long long found = 0;
  for (std::uint32_t p : sensor.hot_pixels()) found += dark.hot.data()[p] != 0;
  const auto truth_hot = static_cast<long long>(sensor.hot_pixels().size());
  std::printf("dark: bias %.2f DN, read noise %.2f DN (sim %.2f), hot %lld found, %lld of the sim's %lld among them\n",
              dark.mean_bias_dn, dark.read_noise_dn, expected_read, dark.hot_count, found, truth_hot);
  ASSERT_GT(truth_hot, 5);
  EXPECT_EQ(found, truth_hot);
  EXPECT_LE(dark.hot_count, truth_hot + 5);
  EXPECT_EQ(read_json_file(calib / "dark.json")["provenance"]["devices"]["camera"], "PAINTLAB-SIM-1");

  // --- response: within 1 % of the sensor's inverse response over the used range ---
  r = test::run_paintlab("calibrate response --rig " + rig + " --capture", 120);
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_THAT(r.out, HasSubstr("dark frame subtracted"));
  const calib::ResponseCurve resp = calib::ResponseCurve::load(calib / "response.json");
  EXPECT_TRUE(resp.dark_subtracted);
  const sim::ResponseCurve& R = sensor.response();
  const double span = (truth.sensor.adc_max_dn() - truth.sensor.black_level_dn) * shift;
  const auto g_truth = [&](double u) { return R.inverse(u / span) * span; };
  const double u_lo = 0.02 * resp.window.u_saturation(), u_hi = resp.window.u_saturation();
  double sgt = 0.0, sgg = 0.0;  // the least-squares scale of g against the truth (relative errors)
  for (double u = u_lo; u <= u_hi; u += 16.0) {
    const double g = resp.to_linear(0, u), t = g_truth(u);
    sgt += g / t;
    sgg += g * g / (t * t);
  }
  double worst = 0.0;
  for (double u = u_lo; u <= u_hi; u += 16.0)
    worst = std::max(worst, std::abs(sgt / sgg * resp.to_linear(0, u) / g_truth(u) - 1.0));
  std::printf("response: used range %.0f..%.0f DN above black, max relative error %.3f %% against the sim, "
              "nonlinearity %.2f %%\n",
              u_lo, u_hi, 100.0 * worst, 100.0 * resp.report.nonlinearity_rel[0]);
  EXPECT_LT(worst, 0.01);
  EXPECT_GT(resp.report.nonlinearity_rel[0], 0.03);  // the camera is clearly nonlinear
  EXPECT_GT(u_hi, 0.9 * span);                      // the used range reaches up to saturation

  // --- flat: gain per pixel against the sim's vignetting x pixel sensitivity ---
  r = test::run_paintlab("calibrate flat --rig " + rig + " --capture", 120);
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  const calib::FlatField flat = calib::FlatField::load(calib / "flat.json");
  ASSERT_EQ(flat.width(), 320);
  ASSERT_EQ(flat.height(), 240);
  ImageF want(320, 240, 1);
  double sum = 0.0;
  for (int y = 0; y < 240; ++y)
    for (int x = 0; x < 320; ++x) sum += want.at(x, y) = static_cast<float>(sensor.electrons_per_s_per_radiance(x, y));
  const double mean = sum / (320.0 * 240.0);
  double sq = 0.0, worst_block = 0.0;
  long n = 0;
  for (int y = 0; y < 240; ++y)
    for (int x = 0; x < 320; ++x) {
      if (dark.hot.at(x, y)) continue;
      const double d = flat.gain.at(x, y) / (want.at(x, y) / mean) - 1.0;
      sq += d * d;
      ++n;
    }
  for (int by = 0; by < 240; by += 16)
    for (int bx = 0; bx < 320; bx += 16) {
      double g = 0.0, w = 0.0;
      for (int y = by; y < by + 16; ++y)
        for (int x = bx; x < bx + 16; ++x) {
          g += flat.gain.at(x, y);
          w += want.at(x, y) / mean;
        }
      worst_block = std::max(worst_block, std::abs(g / w - 1.0));
    }
  const double rms = std::sqrt(sq / static_cast<double>(n));
  std::printf("flat: corner/centre %.4f, per-pixel gain RMS error %.3f %%, worst 16x16 block %.3f %%\n",
              flat.centre_to_corner, 100.0 * rms, 100.0 * worst_block);
  EXPECT_LT(rms, 0.006);          // shot noise of 8 frames at ~60 % of the full well: ~0.4 %
  // Vignetting itself: the flat frames are linearised by the recovered response, whose error
  // (up to 1 %, less between the levels of centre and corner) carries into the gain.
  EXPECT_LT(worst_block, 0.006);
  EXPECT_LT(flat.centre_to_corner, 0.8);
  EXPECT_NEAR(flat.prnu_rel, truth.sensor.prnu_rel, 0.3 * truth.sensor.prnu_rel);

  // --- hdr merge of the response's captures with the rig's calibration ---
  const fs::path exr = dir / "merged.exr";
  r = test::run_paintlab("hdr merge --rig " + rig + " --images " + (calib / "captures" / "response").string() +
                             " --out " + exr.string(),
                         60);
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  const ExrImage merged = read_exr(exr);
  for (const char* key : {"paintlab.response_sha256", "paintlab.dark_sha256", "paintlab.flat_sha256"})
    EXPECT_EQ(merged.attributes.count(key), 1u) << key;
  const ImageF& valid = merged.plane("valid");
  long valid_count = 0;
  for (float v : valid.values()) valid_count += v > 0.5f;
  EXPECT_GT(valid_count, 320 * 240 / 2);
  // Hot pixels are not trusted.
  for (std::uint32_t p : sensor.hot_pixels()) EXPECT_EQ(valid.data()[p], 0.0f) << "hot pixel " << p;
}
