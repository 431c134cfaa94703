// Dark frame (bias, dark current, read noise, hot pixels) and flat field (vignetting, pixel
// gain, photon transfer) on frames of the simulator's sensor, whose truth is known.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "paintlab/calibration/dark.h"
#include "paintlab/calibration/flat.h"
#include "paintlab/core/atomic_file.h"
#include "paintlab/core/error.h"
#include "paintlab/sim/scenes.h"
#include "radiometry_sim.h"
#include "test_util.h"

using namespace paintlab;
using namespace paintlab::calib;
using ::testing::HasSubstr;

namespace {

using Frames = ExposureStack;

Frames expose(sim::Sensor& s, const ImageF& scene, const std::vector<double>& times, std::uint64_t first) {
  Frames f;
  for (std::size_t j = 0; j < times.size(); ++j) {
    sim::ExposureSettings e;
    e.exposure_s = times[j];
    e.frame_index = first + j;
    f.images.push_back(s.expose(scene, e, 2));
    f.exposures_s.push_back(times[j]);
  }
  return f;
}

sim::SensorParams dark_params() {
  sim::SensorParams p;
  p.hot_pixel_frac = 2e-3;
  p.dark_current_e_per_s = 20.0;
  return p;
}

}  // namespace

TEST(Dark, BiasDarkCurrentReadNoiseAndHotPixels) {
  const auto cam = radiometry_test::small_camera(128, 96);
  const sim::SensorParams p = dark_params();
  sim::Sensor sensor(cam, p, test::seed());
  const Frames f = expose(sensor, sim::dark_field(cam), {0.01, 0.01, 0.01, 0.01, 2.0, 2.0, 2.0, 2.0}, 0);
  const DarkFrame d = calibrate_dark(f.frames(), 12);
  const double gain = sensor.gain_dn_per_e(0.0);
  std::printf("dark: bias %.2f DN (sim %.1f), rate %.3f DN/s (sim %.3f), read noise %.3f DN (sim %.3f), hot %lld "
              "(sim %zu)\n",
              d.mean_bias_dn, p.black_level_dn, d.mean_rate_dn_per_s, p.dark_current_e_per_s * gain, d.read_noise_dn,
              p.read_noise_e * gain, d.hot_count, sensor.hot_pixels().size());
  EXPECT_NEAR(d.mean_bias_dn, p.black_level_dn, 0.2);
  EXPECT_THAT(d.mean_rate_dn_per_s, test::NearRel(p.dark_current_e_per_s * gain, 0.1));
  ASSERT_TRUE(d.read_noise_measured);
  // Read noise plus quantisation (1/12 DN^2) plus the dark shot noise of 0.01 s.
  EXPECT_THAT(d.read_noise_dn, test::NearRel(std::sqrt(std::pow(p.read_noise_e * gain, 2) + 1.0 / 12.0), 0.05));
  // Every hot pixel is found; few others are flagged.
  for (std::uint32_t i : sensor.hot_pixels()) EXPECT_EQ(d.hot.data()[i], 1) << "hot pixel " << i << " missed";
  EXPECT_LE(d.hot_count, static_cast<long long>(sensor.hot_pixels().size()) + 5);
  EXPECT_EQ(d.exposures_s.size(), 2u);
  EXPECT_EQ(d.frame_count, 8);
}

TEST(Dark, OneExposureGivesBiasOnlyAndSingleFramesNoReadNoise) {
  const auto cam = radiometry_test::small_camera(64, 48);
  sim::Sensor sensor(cam, dark_params(), test::seed());
  const Frames one = expose(sensor, sim::dark_field(cam), {0.5}, 0);
  const DarkFrame d = calibrate_dark(one.frames(), 12);
  EXPECT_FALSE(d.read_noise_measured);
  EXPECT_EQ(d.mean_rate_dn_per_s, 0.0);
  EXPECT_GT(d.mean_bias_dn, 64.0);  // includes the dark current of 0.5 s
}

TEST(Dark, SaveLoadAndTamperedMaps) {
  const auto cam = radiometry_test::small_camera(64, 48);
  sim::Sensor sensor(cam, dark_params(), test::seed());
  const Frames f = expose(sensor, sim::dark_field(cam), {0.01, 0.01, 1.0, 1.0}, 0);
  DarkFrame d = calibrate_dark(f.frames(), 12);
  test::TempDir dir;
  test::write_text(dir / "d1.png", "x");
  d.provenance = Provenance::make("dark", {dir / "d1.png"});
  d.save(dir / "dark.json");
  ASSERT_TRUE(std::filesystem::exists(dir / "dark.exr"));
  const DarkFrame back = DarkFrame::load(dir / "dark.json");
  EXPECT_EQ(back.hot_count, d.hot_count);
  EXPECT_DOUBLE_EQ(back.read_noise_dn, d.read_noise_dn);
  for (std::size_t i = 0; i < d.bias_dn.size(); i += 97) {
    EXPECT_EQ(back.bias_dn.data()[i], d.bias_dn.data()[i]);
    EXPECT_EQ(back.rate_dn_per_s.data()[i], d.rate_dn_per_s.data()[i]);
  }
  const Json j = read_json_file(dir / "dark.json");
  EXPECT_EQ(j.at("provenance").at("kind"), "dark");
  EXPECT_EQ(j.at("maps").at("file"), "dark.exr");
  // An altered map no longer matches the checksum the JSON recorded.
  std::string bytes = read_file(dir / "dark.exr");
  bytes[bytes.size() / 2] ^= 0x5a;
  write_file_atomic(dir / "dark.exr", bytes);
  EXPECT_THAT(test::error_message<DataError>([&] { DarkFrame::load(dir / "dark.json"); }),
              HasSubstr("does not match the recorded SHA-256"));
}

TEST(Flat, VignettingPixelGainAndPhotonTransfer) {
  const auto cam = radiometry_test::small_camera(128, 96, -0.35);
  sim::SensorParams p;
  p.hot_pixel_frac = 0.0;
  p.prnu_rel = 0.01;
  sim::Sensor sensor(cam, p, test::seed());
  // Exposure for about half of the full well at the centre.
  const double t = 0.5 * p.full_well_e / sensor.electrons_per_s_per_radiance(64, 48);
  const Frames f = expose(sensor, sim::uniform_field(cam, 1.0), std::vector<double>(8, t), 0);
  ValueWindow w;
  w.black_dn = p.black_level_dn;
  w.saturation_dn = 4095.0;
  const ResponseCurve linear = ResponseCurve::identity(12, 1, w);
  const FlatField flat = calibrate_flat(f.frames(), 12, {}, &linear);
  // Truth: the sensor's sensitivity per pixel, normalised to mean 1.
  ImageF truth(128, 96, 1);
  double mean = 0.0;
  for (int y = 0; y < 96; ++y)
    for (int x = 0; x < 128; ++x) mean += truth.at(x, y) = static_cast<float>(sensor.electrons_per_s_per_radiance(x, y));
  mean /= truth.size();
  double sq = 0.0;
  for (std::size_t i = 0; i < truth.size(); ++i) {
    const double d = flat.gain.data()[i] / (truth.data()[i] / mean) - 1.0;
    sq += d * d;
  }
  const double rms = std::sqrt(sq / truth.size());
  // Shot noise of 8 frames of ~9000 e-: 0.4 % per pixel.
  auto block = [&](int x0, int y0) {  // mean over a 1/8 x 1/8 corner block, as FlatField reports
    double a = 0.0;
    for (int y = y0; y < y0 + 12; ++y)
      for (int x = x0; x < x0 + 16; ++x) a += truth.at(x, y);
    return a;
  };
  const double c[4] = {block(0, 0), block(112, 0), block(0, 84), block(112, 84)};
  const double corner_truth = *std::min_element(c, c + 4) / *std::max_element(c, c + 4);
  std::printf("flat: gain vs truth RMS %.4f, corner ratio %.3f, centre-to-corner %.3f, PRNU %.4f (sim %.4f), "
              "photon-transfer gain %.4f DN/e (sim %.4f)\n",
              rms, flat.corner_ratio, flat.centre_to_corner, flat.prnu_rel, p.prnu_rel, flat.noise.gain_dn_per_e,
              sensor.gain_dn_per_e(0.0));
  EXPECT_LT(rms, 0.006);
  EXPECT_NEAR(flat.corner_ratio, corner_truth, 0.005);
  EXPECT_LT(flat.centre_to_corner, 0.8);
  EXPECT_GT(flat.prnu_rel, 0.7 * p.prnu_rel);
  EXPECT_LT(flat.prnu_rel, 1.6 * p.prnu_rel);
  EXPECT_THAT(flat.noise.gain_dn_per_e, test::NearRel(sensor.gain_dn_per_e(0.0), 0.05));

  test::TempDir dir;
  flat.save(dir / "flat.json");
  const FlatField back = FlatField::load(dir / "flat.json");
  EXPECT_EQ(back.gain.data()[1234], flat.gain.data()[1234]);
  EXPECT_DOUBLE_EQ(back.corner_ratio, flat.corner_ratio);
}

TEST(Flat, AColourFilterArrayIsNormalisedPerColourSoTheFlatHoldsNoColour) {
  // A Bayer sensor (RG) with gains 0.6 / 1.0 / 0.8 under a white diffuser: the raw flat frames
  // carry a 2x2 colour pattern on top of vignetting and PRNU.
  sim::CameraTruth truth = radiometry_test::small_camera(128, 96, -0.35).truth();
  truth.rgb_gain = {0.6, 1.0, 0.8};
  const sim::CameraModel cam(truth);
  sim::SensorParams p;
  p.hot_pixel_frac = 0.0;
  p.prnu_rel = 0.01;
  sim::Sensor sensor(cam, p, test::seed());
  const double t = 0.5 * p.full_well_e / sensor.electrons_per_s_per_radiance(64, 48);
  Frames f;
  for (int j = 0; j < 8; ++j) {
    sim::ExposureSettings e;
    e.exposure_s = t;
    e.frame_index = static_cast<std::uint64_t>(j);
    e.cfa = std::array<int, 4>{0, 1, 1, 2};
    f.images.push_back(sensor.expose(sim::uniform_field(cam, 1.0, 3), e, 2));
    f.exposures_s.push_back(t);
  }
  ValueWindow w;
  w.black_dn = p.black_level_dn;
  w.saturation_dn = 4095.0;
  const ResponseCurve linear = ResponseCurve::identity(12, 1, w);
  FlatOptions per_colour;
  per_colour.cfa = std::array<int, 4>{0, 1, 1, 2};
  const FlatField flat = calibrate_flat(f.frames(), 12, per_colour, &linear);
  const FlatField mixed = calibrate_flat(f.frames(), 12, {}, &linear);
  // Against the sensor's sensitivity per pixel (vignetting x PRNU), normalised per colour.
  double mean[3] = {0, 0, 0}, count[3] = {0, 0, 0};
  const auto colour = [](int x, int y) { return (y & 1) ? ((x & 1) ? 2 : 1) : ((x & 1) ? 1 : 0); };
  for (int y = 0; y < 96; ++y)
    for (int x = 0; x < 128; ++x) {
      mean[colour(x, y)] += sensor.electrons_per_s_per_radiance(x, y);
      ++count[colour(x, y)];
    }
  double sq = 0.0;
  for (int y = 0; y < 96; ++y)
    for (int x = 0; x < 128; ++x) {
      const int c = colour(x, y);
      const double d = flat.gain.at(x, y) / (sensor.electrons_per_s_per_radiance(x, y) / (mean[c] / count[c])) - 1.0;
      sq += d * d;
    }
  const double rms = std::sqrt(sq / (128.0 * 96.0));
  std::printf("flat of a Bayer sensor: gain vs truth RMS %.4f, PRNU %.4f per colour (%.4f mixing colours; sim %.4f)\n",
              rms, flat.prnu_rel, mixed.prnu_rel, p.prnu_rel);
  EXPECT_LT(rms, 0.008);  // the shot noise of 8 frames, the blue sites' ~7000 e- the noisiest
  // Neighbouring sites of different colours have about the same gain (no colour left in it).
  EXPECT_NEAR(flat.gain.at(64, 48) / flat.gain.at(65, 48), 1.0, 0.05);
  EXPECT_NEAR(mixed.gain.at(64, 48) / mixed.gain.at(65, 48), 0.6, 0.05);  // R / G without the CFA
  EXPECT_GT(flat.prnu_rel, 0.7 * p.prnu_rel);
  EXPECT_LT(flat.prnu_rel, 1.6 * p.prnu_rel);
  EXPECT_GT(mixed.prnu_rel, 5.0 * p.prnu_rel);  // comparing colours with each other inflates it
  EXPECT_THAT(flat.describe(), HasSubstr("each filter colour normalised on its own"));
  test::TempDir dir;
  flat.save(dir / "flat.json");
  const FlatField back = FlatField::load(dir / "flat.json");
  ASSERT_TRUE(back.cfa);
  EXPECT_EQ(*back.cfa, (std::array<int, 4>{0, 1, 1, 2}));
  EXPECT_FALSE(FlatField::load([&] { mixed.save(dir / "mixed.json"); return dir / "mixed.json"; }()).cfa);
}

TEST(Flat, SaturatedOrDarkFramesAreRefused) {
  const auto cam = radiometry_test::small_camera(64, 48);
  sim::SensorParams p;
  sim::Sensor sensor(cam, p, test::seed());
  const double t_full = p.full_well_e / sensor.electrons_per_s_per_radiance(32, 24);
  const Frames bright = expose(sensor, sim::uniform_field(cam, 1.0), {2.0 * t_full}, 0);
  EXPECT_THAT(test::error_message<CalibrationError>([&] { calibrate_flat(bright.frames(), 12); }),
              ::testing::AllOf(HasSubstr("at or above saturation"), HasSubstr("lower the exposure")));
  const Frames dim = expose(sensor, sim::uniform_field(cam, 1.0), {0.001 * t_full}, 10);
  EXPECT_THAT(test::error_message<CalibrationError>([&] { calibrate_flat(dim.frames(), 12); }),
              HasSubstr("raise the exposure"));
}
