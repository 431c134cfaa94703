#include <gtest/gtest.h>

#include <cmath>
#include <numeric>

#include "paintlab/core/error.h"
#include "paintlab/sim/scenes.h"
#include "paintlab/sim/sensor.h"
#include "sim_test_util.h"
#include "test_util.h"

using namespace paintlab;

namespace {

struct Rig {
  sim::CameraModel cam;
  sim::SensorParams params;
  explicit Rig(sim::SensorParams p) : cam(sim::test::small_config(12.0, 96, 64).camera), params(std::move(p)) {}
};

sim::SensorParams quiet_params() {
  sim::SensorParams p;
  p.prnu_rel = 0.0;
  p.hot_pixel_frac = 0.0;
  return p;
}

// Mean and variance of the raw values in an image.
std::pair<double, double> stats(const Image<std::uint16_t>& img) {
  double s = 0, s2 = 0;
  for (std::uint16_t v : img.values()) {
    s += v;
    s2 += static_cast<double>(v) * v;
  }
  double n = static_cast<double>(img.size());
  return {s / n, s2 / n - (s / n) * (s / n)};
}

sim::ExposureSettings exposure(double t, double gain_db = 0.0, std::uint64_t frame = 0, int bits = 0) {
  sim::ExposureSettings e;
  e.exposure_s = t;
  e.gain_db = gain_db;
  e.frame_index = frame;
  e.output_bits = bits;
  return e;
}

}  // namespace

TEST(Sensor, ConversionFollowsThePhysics) {
  Rig rig(quiet_params());
  sim::Sensor s(rig.cam, rig.params, 1);
  // e-/s per radiance = QE * pixel area * pi / (4 N^2) * cos^4 / (h c / lambda).
  double photon = 6.62607015e-34 * 2.99792458e8 / 550e-9;
  double expected = 0.6 * 6.45e-6 * 6.45e-6 * kPi / (4 * 64) / photon;
  int cx = 48, cy = 32;
  EXPECT_NEAR(s.electrons_per_s_per_radiance(cx, cy), expected * rig.cam.vignetting(Vec2(cx, cy)), expected * 1e-6);
  EXPECT_NEAR(s.gain_dn_per_e(0.0), (4095.0 - 64.0) / 18000.0, 1e-12);
  EXPECT_NEAR(s.gain_dn_per_e(6.0), s.gain_dn_per_e(0.0) * std::pow(10.0, 0.3), 1e-12);
}

TEST(Sensor, ExposureIsLinearBeforeSaturation) {
  Rig rig(quiet_params());
  sim::Sensor s(rig.cam, rig.params, 2);
  ImageF flat = sim::uniform_field(rig.cam, 1.0);
  double g = s.electrons_per_s_per_radiance(48, 32);
  std::vector<double> signal;
  std::vector<double> times;
  for (double e : {1000.0, 2000.0, 4000.0, 8000.0, 14000.0}) {
    double t = e / g;
    auto img = s.expose(flat, exposure(t));
    signal.push_back(stats(img).first - 64.0 - 5.0 * t * s.gain_dn_per_e(0));
    times.push_back(t);
  }
  for (std::size_t i = 1; i < signal.size(); ++i)
    EXPECT_THAT(signal[i] / signal[0], test::NearRel(times[i] / times[0], 0.005)) << "exposure " << i;
}

TEST(Sensor, SaturationClips) {
  Rig rig(quiet_params());
  sim::Sensor s(rig.cam, rig.params, 3);
  ImageF flat = sim::uniform_field(rig.cam, 1.0);
  double g = s.electrons_per_s_per_radiance(48, 32);
  auto img = s.expose(flat, exposure(40000.0 / g));  // twice the full well
  for (std::uint16_t v : img.values()) ASSERT_EQ(v, 4095);
  // With gain the ADC clips before the full well.
  auto gained = s.expose(flat, exposure(12000.0 / g, 12.0));
  EXPECT_EQ(stats(gained).first, 4095.0);
  // Mono16 output of a 12-bit ADC: MSB aligned.
  auto out16 = s.expose(flat, exposure(40000.0 / g, 0.0, 0, 16));
  for (std::uint16_t v : out16.values()) ASSERT_EQ(v, 4095 << 4);
  auto out8 = s.expose(flat, exposure(40000.0 / g, 0.0, 0, 8));
  for (std::uint16_t v : out8.values()) ASSERT_EQ(v, 255);
}

TEST(Sensor, NoiseMatchesShotAndReadNoise) {
  sim::SensorParams p = quiet_params();
  p.adc_bits = 16;
  p.conversion_gain_dn_per_e = 1.0;  // 1 DN per electron: variances in electrons^2
  p.black_level_dn = 1000;
  p.full_well_e = 60000;
  Rig rig(p);
  sim::Sensor s(rig.cam, rig.params, 4);
  ImageF flat = sim::uniform_field(rig.cam, 1.0);
  double g = s.electrons_per_s_per_radiance(48, 32);
  for (double mean_e : {0.0, 3.0, 12.0, 400.0, 10000.0}) {
    double t = mean_e / g;
    // Many frames of the central pixels (vignetting is flat there to 1e-4).
    double sum = 0, sum2 = 0;
    int n = 0;
    for (std::uint64_t f = 0; f < 40; ++f) {
      auto img = s.expose(flat, exposure(t, 0.0, f));
      for (int y = 28; y < 36; ++y)
        for (int x = 42; x < 54; ++x) {
          double v = img.at(x, y) - 1000.0;
          sum += v;
          sum2 += v * v;
          ++n;
        }
    }
    double mean = sum / n, var = sum2 / n - mean * mean;
    double mu = mean_e + 5.0 * t;  // + dark current
    double expected_var = mu + 36.0 + 1.0 / 12.0;
    EXPECT_NEAR(mean, mu, 4.0 * std::sqrt(expected_var / n) + 0.05) << "mean electrons " << mean_e;
    EXPECT_THAT(var, test::NearRel(expected_var, 0.12)) << "mean electrons " << mean_e;
  }
}

TEST(Sensor, NonlinearResponseAndBlackLevel) {
  sim::SensorParams p = quiet_params();
  p.response_poly = {1.12, -0.16, 0.04};
  Rig rig(p);
  sim::Sensor s(rig.cam, rig.params, 5);
  const sim::ResponseCurve& r = s.response();
  EXPECT_FALSE(r.linear());
  EXPECT_NEAR(r(1.0), 1.0, 1e-12);
  EXPECT_NEAR(r(0.5), 1.12 * 0.5 - 0.16 * 0.25 + 0.04 * 0.125, 1e-12);
  EXPECT_NEAR(r.inverse(r(0.37)), 0.37, 1e-12);
  EXPECT_NEAR(r.slope(0.0), 1.12, 1e-12);
  ImageF flat = sim::uniform_field(rig.cam, 1.0);
  double g = s.electrons_per_s_per_radiance(48, 32);
  for (double e : {2000.0, 9000.0, 16000.0}) {
    double t = e / g;
    auto [mean, var] = stats(s.expose(flat, exposure(t)));
    double expected = s.expected_raw(1.0, 48, 32, t, 0.0);
    double x = (e + 5 * t) * s.gain_dn_per_e(0) / (4095.0 - 64.0);
    EXPECT_NEAR(expected, 64.0 + r(x) * (4095.0 - 64.0), 1e-9);
    // The noise-free prediction versus the noisy mean (vignetting varies over the small image).
    EXPECT_NEAR(mean, expected, 0.01 * (expected - 64.0)) << e;
    EXPECT_GT(mean - 64.0, 1.0001 * x * (4095.0 - 64.0) - 40.0);  // compressive: above the line
  }
}

TEST(Sensor, DarkFramesAndHotPixels) {
  sim::SensorParams p;
  p.hot_pixel_frac = 0.01;
  p.hot_pixel_dark_e_per_s = 5000.0;
  p.dark_current_e_per_s = 20.0;
  Rig rig(p);
  sim::Sensor s(rig.cam, rig.params, 6);
  double n = 96.0 * 64.0;
  EXPECT_NEAR(static_cast<double>(s.hot_pixels().size()), 0.01 * n, 4 * std::sqrt(0.01 * n));
  auto dark = s.expose(sim::dark_field(rig.cam), exposure(2.0));
  double G = s.gain_dn_per_e(0);
  double normal_sum = 0;
  int normal_n = 0;
  for (int y = 0; y < 64; ++y)
    for (int x = 0; x < 96; ++x) {
      double dark_rate = s.dark_e_per_s(x, y);
      if (dark_rate > 1000) {
        EXPECT_GT(dark.at(x, y), 64.0 + 0.8 * 10000.0 * G);
      } else {
        normal_sum += dark.at(x, y);
        ++normal_n;
      }
    }
  EXPECT_NEAR(normal_sum / normal_n, 64.0 + 40.0 * G, 0.2);
  // Hot pixels are the same in every frame (fixed pattern), the noise is not.
  auto dark2 = s.expose(sim::dark_field(rig.cam), exposure(2.0, 0.0, 1));
  EXPECT_NE(dark.values(), dark2.values());
  for (std::uint32_t i : s.hot_pixels()) EXPECT_GT(dark2.data()[i], 64.0 + 0.8 * 10000.0 * G);
}

TEST(Sensor, DeterministicWithASeed) {
  Rig rig(sim::SensorParams{});
  ImageF flat = sim::uniform_field(rig.cam, 3.0, 3);
  sim::Sensor a(rig.cam, rig.params, 11), b(rig.cam, rig.params, 11), c(rig.cam, rig.params, 12);
  sim::ExposureSettings e;
  e.exposure_s = 1e-3;
  auto a0 = a.expose(flat, e), a1 = a.expose(flat, e);
  auto b0 = b.expose(flat, e, 1), b1 = b.expose(flat, e, 2);
  EXPECT_EQ(a.frames(), 2u);
  EXPECT_EQ(a0.values(), b0.values());  // the same seed and frame counter: the same image
  EXPECT_EQ(a1.values(), b1.values());  // whatever the thread count
  EXPECT_NE(a0.values(), a1.values());  // the next frame: new noise
  EXPECT_NE(a0.values(), c.expose(flat, e).values());
  EXPECT_EQ(a0.channels(), 3);
  e.frame_index = 0;
  EXPECT_EQ(a.expose(flat, e).values(), a0.values());  // an explicit frame index replays it
  ImageF wrong(10, 10, 1);
  EXPECT_THROW(a.expose(wrong, e), DataError);
}

// ---- colour: the camera's channel mix, colour-filter arrays, a mono sensor behind a filter ----

namespace {

// A scene of one colour in linear sRGB, 3 channels.
ImageF uniform_colour(const sim::CameraModel& cam, double r, double g, double b) {
  ImageF img(cam.width(), cam.height(), 3);
  for (int y = 0; y < img.height(); ++y)
    for (int x = 0; x < img.width(); ++x) {
      img.at(x, y, 0) = static_cast<float>(r);
      img.at(x, y, 1) = static_cast<float>(g);
      img.at(x, y, 2) = static_cast<float>(b);
    }
  return img;
}

// Mean raw value over the pixels whose (x & 1, y & 1) is (sx, sy), and the sensor's expectation there.
std::pair<double, double> site_means(const sim::Sensor& s, const Image<std::uint16_t>& img, int sx, int sy, double L,
                                     double t) {
  double got = 0, want = 0;
  int n = 0;
  for (int y = sy; y < img.height(); y += 2)
    for (int x = sx; x < img.width(); x += 2) {
      got += img.at(x, y);
      want += s.expected_raw(L, x, y, t, 0.0);
      ++n;
    }
  return {got / n, want / n};
}

}  // namespace

TEST(SensorColour, ABayerFrameOfAGreySceneWithoutAMixIsTheMonoFrameBitForBit) {
  Rig rig(sim::SensorParams{});  // PRNU and hot pixels on
  sim::Sensor s(rig.cam, rig.params, 5);
  sim::ExposureSettings e = exposure(2e-3, 0.0, 3);
  const auto mono = s.expose(sim::uniform_field(rig.cam, 3.0, 1), e);
  e.cfa = std::array<int, 4>{0, 1, 1, 2};
  const auto bayer = s.expose(sim::uniform_field(rig.cam, 3.0, 3), e);
  EXPECT_EQ(bayer.channels(), 1);
  EXPECT_EQ(bayer.values(), mono.values());
}

TEST(SensorColour, EachSiteRecordsItsCameraChannelThroughTheMixAndGains) {
  sim::CameraTruth truth = sim::test::small_config(12.0, 96, 64).camera;
  truth.rgb_matrix = {0.8, 0.25, -0.05, 0.1, 0.85, 0.05, 0.02, 0.2, 0.78};
  truth.rgb_gain = {0.55, 1.0, 0.7};
  const sim::CameraModel cam(truth);
  sim::Sensor s(cam, quiet_params(), 9);
  const Eigen::Vector3d scene(2.0, 1.0, 0.5);  // an orange in linear sRGB
  Eigen::Matrix3d mix;
  mix << 0.8, 0.25, -0.05, 0.1, 0.85, 0.05, 0.02, 0.2, 0.78;
  const Eigen::Vector3d camera_rgb = Eigen::Vector3d(0.55, 1.0, 0.7).asDiagonal() * mix * scene;
  const double t = 4000.0 / s.electrons_per_s_per_radiance(48, 32) / camera_rgb.maxCoeff();
  sim::ExposureSettings e = exposure(t, 0.0, 1);
  e.cfa = std::array<int, 4>{1, 0, 2, 1};  // GenICam BayerGR: G R / B G
  const auto bayer = s.expose(uniform_colour(cam, scene.x(), scene.y(), scene.z()), e);
  const int site_colour[2][2] = {{1, 0}, {2, 1}};  // [y & 1][x & 1]
  for (int sy = 0; sy < 2; ++sy)
    for (int sx = 0; sx < 2; ++sx) {
      const auto [got, want] = site_means(s, bayer, sx, sy, camera_rgb[site_colour[sy][sx]], t);
      EXPECT_THAT(got, test::NearRel(want, 0.005)) << "site " << sx << "," << sy;
    }
  // Three channels out without a CFA: the same camera RGB per channel.
  e.cfa.reset();
  const auto rgb = s.expose(uniform_colour(cam, scene.x(), scene.y(), scene.z()), e);
  ASSERT_EQ(rgb.channels(), 3);
  for (int c = 0; c < 3; ++c) {
    double sum = 0;
    for (int y = 0; y < rgb.height(); ++y)
      for (int x = 0; x < rgb.width(); ++x) sum += rgb.at(x, y, c);
    EXPECT_THAT(sum / (rgb.width() * rgb.height()),
                test::NearRel(site_means(s, bayer, 0, 0, camera_rgb[c], t).second, 0.005))
        << "channel " << c;
  }
  // A mono sensor behind a filter: w . scene.
  e.mono_mix = std::array<double, 3>{0.05, 0.6, 0.02};
  const auto filtered = s.expose(uniform_colour(cam, scene.x(), scene.y(), scene.z()), e);
  ASSERT_EQ(filtered.channels(), 1);
  const auto [got, want] = site_means(s, filtered, 1, 1, 0.05 * 2.0 + 0.6 * 1.0 + 0.02 * 0.5, t);
  EXPECT_THAT(got, test::NearRel(want, 0.005));
}

TEST(SensorColour, ImpossibleColourExposuresAreRefused) {
  Rig rig(quiet_params());
  sim::Sensor s(rig.cam, rig.params, 1);
  sim::ExposureSettings e = exposure(1e-3);
  e.cfa = std::array<int, 4>{0, 1, 1, 2};
  EXPECT_THAT(test::error_message<DataError>([&] { s.expose(sim::uniform_field(rig.cam, 1.0, 1), e); }),
              ::testing::HasSubstr("needs a 3-channel (scene RGB) radiance image"));
  e.cfa = std::array<int, 4>{0, 1, 3, 2};
  EXPECT_THAT(test::error_message<DataError>([&] { s.expose(sim::uniform_field(rig.cam, 1.0, 3), e); }),
              ::testing::HasSubstr("must be 0 (R), 1 (G) or 2 (B)"));
  e.cfa = std::array<int, 4>{0, 1, 1, 2};
  e.mono_mix = std::array<double, 3>{1, 0, 0};
  EXPECT_THAT(test::error_message<DataError>([&] { s.expose(sim::uniform_field(rig.cam, 1.0, 3), e); }),
              ::testing::HasSubstr("not both"));
}
