// Response recovery (Robertson, Debevec) on synthetic stacks with a known curve, for 8-, 12-
// and 16-bit data; the exposure-stack helpers and their error messages.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

#include "paintlab/calibration/dark.h"
#include "paintlab/calibration/exposure_stack.h"
#include "paintlab/calibration/response.h"
#include "paintlab/core/error.h"
#include "paintlab/core/image_io.h"
#include "radiometry_sim.h"
#include "test_util.h"

using namespace paintlab;
using namespace paintlab::calib;
using ::testing::HasSubstr;

namespace {

using GammaStack = ExposureStack;

// Exposure steps of 2 x (1, 1.37, 1.71, ...): ratios that are not all equal. With one
// constant ratio r any curve g h(log_r g), h periodic, fits the data as well as g does
// (Grossberg and Nayar's self-similar ambiguity); only the smoothness prior then decides.
std::vector<double> mixed_bracket(double t0, int count) {
  auto t = calib::radiometry_test::geometric_exposures(t0, 2.0, count);
  const double m[3] = {1.0, 1.37, 1.71};
  for (std::size_t j = 0; j < t.size(); ++j) t[j] *= m[j % 3];
  return t;
}

GammaStack gamma_stack(const calib::radiometry_test::GammaCamera& cam, int channels) {
  GammaStack s;
  ImageF x = calib::radiometry_test::log_uniform_radiance(96, 64, channels, 1e-3, 50.0, test::seed());
  s.exposures_s = mixed_bracket(1.0 / 1024, 12);
  std::mt19937_64 rng(test::seed() + 1);
  for (double t : s.exposures_s) s.images.push_back(cam.expose(x, t, rng));
  return s;
}

// A 12- or 16-bit sim sensor with a nonlinear response; radiance scaled so the longest of
// 16 exposures (ratio 2) saturates the brightest pixels.
struct SimSetup {
  sim::CameraModel camera = calib::radiometry_test::small_camera(128, 96);
  sim::SensorParams params;
  std::vector<double> exposures = mixed_bracket(0.328 / 32768.0 / 1.71, 16);
  ImageF radiance;

  explicit SimSetup(int adc_bits, std::vector<double> poly) {
    params.adc_bits = adc_bits;
    params.response_poly = std::move(poly);
    params.black_level_dn = adc_bits == 16 ? 1000.0 : 64.0;
    params.hot_pixel_frac = 1e-3;
    sim::Sensor probe(camera, params, 1);
    const double g = probe.electrons_per_s_per_radiance(camera.width() / 2, camera.height() / 2);
    const double scale = params.full_well_e / (g * exposures.back());
    radiance = calib::radiometry_test::log_uniform_radiance(camera.width(), camera.height(), 1, 1e-4 * scale, 3.0 * scale,
                                                    test::seed() + 7);
  }
  // The true g on u = raw - black: R^-1 in DN units.
  double truth(const sim::Sensor& s, double u) const {
    const double span = params.adc_max_dn() - params.black_level_dn;
    return s.response().inverse(u / span) * span;
  }
};

}  // namespace

TEST(ExposureList, ParsesNumbersAndFractions) {
  auto t = parse_exposure_list("0.25,1/1024, 2e-3");
  ASSERT_EQ(t.size(), 3u);
  EXPECT_DOUBLE_EQ(t[0], 0.25);
  EXPECT_DOUBLE_EQ(t[1], 1.0 / 1024);
  EXPECT_DOUBLE_EQ(t[2], 2e-3);
}

TEST(ExposureList, NamesTheBadEntry) {
  EXPECT_THAT(test::error_message<UsageError>([] { parse_exposure_list("0.1,abc,0.3"); }), HasSubstr("entry 2 'abc'"));
  EXPECT_THAT(test::error_message<UsageError>([] { parse_exposure_list("0.1,-0.2"); }), HasSubstr("entry 2"));
  EXPECT_THAT(test::error_message<UsageError>([] { parse_exposure_list("0.1,,0.3"); }), HasSubstr("entry 2"));
  EXPECT_THAT(test::error_message<UsageError>([] { parse_exposure_list("1/0"); }), HasSubstr("entry 1"));
  EXPECT_THAT(test::error_message<UsageError>([] { parse_exposure_list("0.1,0"); }), HasSubstr("entry 2 '0'"));
}

TEST(ExposureFile, MatchesImagesByNameAndNamesBadLines) {
  test::TempDir dir;
  test::write_text(dir / "times.txt", "# name time\nb.png 0.5\n\na.png 1/4  # comment\n");
  auto t = read_exposure_file(dir / "times.txt", {"/some/where/a.png", "b.png"});
  ASSERT_EQ(t.size(), 2u);
  EXPECT_DOUBLE_EQ(t[0], 0.25);
  EXPECT_DOUBLE_EQ(t[1], 0.5);
  EXPECT_THAT(test::error_message<DataError>([&] { read_exposure_file(dir / "times.txt", {"c.png"}); }),
              HasSubstr("no exposure time for image 'c.png'"));
  test::write_text(dir / "bad.txt", "a.png 0.5\nb.png fast\n");
  EXPECT_THAT(test::error_message<DataError>([&] { read_exposure_file(dir / "bad.txt", {"a.png"}); }),
              HasSubstr("bad.txt:2: 'fast'"));
  test::write_text(dir / "extra.txt", "a.png 0.5 8\n");
  EXPECT_THAT(test::error_message<DataError>([&] { read_exposure_file(dir / "extra.txt", {"a.png"}); }),
              HasSubstr("extra.txt:1: expected 'name time'"));
  EXPECT_THROW(read_exposure_file(dir / "missing.txt", {"a.png"}), IoError);
}

TEST(ExposureStack, LoadChecksCountsSizesAndDepth) {
  test::TempDir dir;
  Image<std::uint16_t> a(8, 6, 1, 100), b(8, 6, 1, 200), c(9, 6, 1, 100);
  write_png(dir / "a.png", a, 16);
  write_png(dir / "b.png", b, 16);
  write_png(dir / "c.png", c, 16);
  EXPECT_THAT(test::error_message<UsageError>([&] { load_exposure_stack({dir / "a.png", dir / "b.png"}, {0.1}); }),
              HasSubstr("2 images but 1 exposure times"));
  EXPECT_THAT(test::error_message<DataError>([&] { load_exposure_stack({dir / "a.png", dir / "c.png"}, {0.1, 0.2}); }),
              HasSubstr("c.png: 9x6"));
  test::write_text(dir / "junk.png", "not an image");
  EXPECT_THAT(test::error_message<DataError>([&] { load_exposure_stack({dir / "a.png", dir / "junk.png"}, {0.1, 0.2}); }),
              HasSubstr("junk.png"));
  EXPECT_THROW(load_exposure_stack({dir / "a.png", dir / "none.png"}, {0.1, 0.2}), IoError);
  auto s = load_exposure_stack({dir / "a.png", dir / "b.png"}, {0.1, 0.2});
  EXPECT_EQ(s.bit_depth, 16);
  EXPECT_EQ(s.images[1].at(3, 2), 200);
}

TEST(ExposureStack, TwelveBitDataMsbAlignedIsShiftedDown) {
  test::TempDir dir;
  Image<std::uint16_t> msb(4, 4, 1, 4000 << 4), lsb(4, 4, 1, 4000);
  write_png(dir / "msb.png", msb, 16);
  write_png(dir / "lsb.png", lsb, 16);
  auto s = load_exposure_stack({dir / "lsb.png"}, {0.1}, 12);
  EXPECT_EQ(s.bit_depth, 12);
  EXPECT_EQ(s.images[0].at(0, 0), 4000);
  auto m = load_exposure_stack({dir / "msb.png"}, {0.1}, 12);
  EXPECT_EQ(m.images[0].at(1, 1), 4000);
  Image<std::uint16_t> odd(4, 4, 1, 5001);
  write_png(dir / "odd.png", odd, 16);
  EXPECT_THAT(test::error_message<DataError>([&] { load_exposure_stack({dir / "odd.png"}, {0.1}, 12); }),
              HasSubstr("exceed 4095"));
}

TEST(Weights, ZeroAtTheNoiseFloorAndAtSaturation) {
  ValueWindow w;
  w.floor_dn = 10.0;
  w.saturation_dn = 250.0;
  w.black_dn = 5.0;
  for (auto kind : {Weighting::Robertson, Weighting::Hat, Weighting::InverseVariance}) {
    EXPECT_EQ(certainty(kind, 10.0, w), 0.0) << to_string(kind);
    EXPECT_EQ(certainty(kind, 5.0, w), 0.0) << to_string(kind);
    EXPECT_EQ(certainty(kind, 245.0, w), 0.0) << to_string(kind);
    EXPECT_EQ(certainty(kind, 300.0, w), 0.0) << to_string(kind);
    EXPECT_NEAR(certainty(kind, 127.5, w), 1.0, 1e-12) << to_string(kind);
    EXPECT_GT(certainty(kind, 11.0, w), 0.0) << to_string(kind);
  }
}

TEST(Response, EightBitGammaCurveWithinOnePercentByDebevec) {
  // A gamma-encoded 8-bit camera (the usual PNG/JPEG): Debevec's log-domain form recovers it;
  // Robertson's linear-domain form is printed for comparison (docs/radiometry.md).
  calib::radiometry_test::GammaCamera cam;
  auto stack = gamma_stack(cam, 1);
  const ResponseCurve r = recover_response(stack.frames(), 8, {.method = ResponseMethod::Debevec});
  const ResponseCurve rob = recover_response(stack.frames(), 8, {});
  EXPECT_EQ(r.weighting, Weighting::Hat);
  EXPECT_EQ(r.knots_dn.size(), 256u);
  EXPECT_DOUBLE_EQ(r.window.saturation_dn, 255.0);
  // Used range: codes 13..250 (5 % of full scale to just below saturation).
  auto truth = [&](double u) { return cam.truth(u); };
  const double err = calib::radiometry_test::max_relative_error(r, 0, truth, 13, 250);
  const double err_rob = calib::radiometry_test::max_relative_error(rob, 0, truth, 13, 250);
  std::printf("8-bit gamma 2.2 over codes 13..250: Debevec max relative error %.3f %%, Robertson %.3f %%; "
              "linearity error %.4f\n",
              100 * err, 100 * err_rob, r.report.linearity_error_rel);
  EXPECT_LT(err, 0.01);
  // Well-exposed values scatter by 0.6 DN x 2.2 / code (1-2 %) around the merged value.
  EXPECT_LT(r.report.linearity_error_rel, 0.035);
  EXPECT_GT(r.report.nonlinearity_rel[0], 0.3);  // gamma 2.2 is far from linear
  for (double ratio : r.report.exposure_ratio) {
    if (!std::isnan(ratio)) {
      EXPECT_NEAR(ratio, 1.0, 0.015);
    }
  }
  // The residual spread near mid-range: the camera noise (0.6 DN x slope) plus the error of
  // the merged value it is compared with.
  const double u = 128.0;
  const double sd = std::sqrt(r.variance(0, u));
  EXPECT_GT(sd, 0.8 * 0.6 * r.slope(0, u));
  EXPECT_LT(sd, 2.5 * 0.6 * r.slope(0, u));
}

TEST(Response, DebevecRgbGammaCurve) {
  calib::radiometry_test::GammaCamera cam;
  auto stack = gamma_stack(cam, 3);
  const ResponseCurve r = recover_response(stack.frames(), 8, {.method = ResponseMethod::Debevec});
  for (int c = 0; c < 3; ++c) {
    const double err = calib::radiometry_test::max_relative_error(r, c, [&](double u) { return cam.truth(u); }, 13, 250);
    std::printf("8-bit gamma 2.2, Debevec, channel %d: max relative error %.3f %%\n", c, 100 * err);
    EXPECT_LT(err, 0.015);
  }
}

TEST(Response, TwelveBitSimulatedNonlinearSensorWithinOnePercent) {
  SimSetup setup(12, {1.3, -0.3});
  auto stack = calib::radiometry_test::sim_stack(setup.camera, setup.params, setup.radiance, setup.exposures, test::seed());
  auto frames = stack.frames();
  ResponseOptions opt;
  opt.black_dn = setup.params.black_level_dn;
  ResponseCurve r = recover_response(frames, 12, opt);
  const double u_sat = r.window.u_saturation();
  const double u_lo = 0.02 * u_sat;
  const double err = calib::radiometry_test::max_relative_error(
      r, 0, [&](double u) { return setup.truth(*stack.sensor, u); }, u_lo, u_sat, 4.0);
  std::printf("12-bit sim sensor R(x) = 1.3x - 0.3x^2: %zu knots, max relative error %.3f %% over u %.0f..%.0f DN, "
              "nonlinearity %.3f, noise read %.2f DN gain %.4f DN/e (sim: read %.2f DN, gain %.4f)\n",
              r.knots_dn.size(), 100 * err, u_lo, u_sat, r.report.nonlinearity_rel[0],
              r.noise.read_noise_dn, r.noise.gain_dn_per_e, setup.params.read_noise_e * stack.sensor->gain_dn_per_e(0),
              stack.sensor->gain_dn_per_e(0));
  EXPECT_LT(err, 0.01);
  EXPECT_GT(r.report.nonlinearity_rel[0], 0.03);
}

TEST(Response, SixteenBitSimulatedSensorWithDarkFrameWithinOnePercent) {
  SimSetup setup(16, {1.2, -0.1, -0.1});
  auto stack = calib::radiometry_test::sim_stack(setup.camera, setup.params, setup.radiance, setup.exposures, test::seed());
  // Dark frames (same sensor, no light) at the shortest and longest exposure, 4 each.
  ImageF black(setup.camera.width(), setup.camera.height(), 1, 0.0f);
  std::vector<Image<std::uint16_t>> darks;
  std::vector<double> dark_t;
  for (int i = 0; i < 8; ++i) {
    sim::ExposureSettings e;
    e.exposure_s = i < 4 ? setup.exposures.front() : setup.exposures.back();
    e.frame_index = 1000 + i;
    darks.push_back(stack.sensor->expose(black, e, 2));
    dark_t.push_back(e.exposure_s);
  }
  std::vector<StackFrame> dark_frames;
  for (std::size_t i = 0; i < darks.size(); ++i) dark_frames.push_back({&darks[i], dark_t[i]});
  DarkFrame dark = calibrate_dark(dark_frames, 16);
  auto frames = stack.frames();
  ResponseCurve r = recover_response(frames, 16, {}, &dark);
  EXPECT_TRUE(r.dark_subtracted);
  EXPECT_LE(r.knots_dn.size(), 1024u);
  EXPECT_NEAR(r.window.floor_dn, 3.0 * dark.read_noise_dn, 1e-9);
  const double u_sat = r.window.u_saturation();
  const double u_lo = 0.02 * u_sat;
  const double err = calib::radiometry_test::max_relative_error(
      r, 0, [&](double u) { return setup.truth(*stack.sensor, u); }, u_lo, u_sat, 16.0);
  std::printf("16-bit sim sensor R(x) = 1.2x - 0.1x^2 - 0.1x^3, dark frame: %zu knots, max relative error %.3f %% "
              "over u %.0f..%.0f DN, linearity error %.4f\n",
              r.knots_dn.size(), 100 * err, u_lo, u_sat, r.report.linearity_error_rel);
  EXPECT_LT(err, 0.01);
}

TEST(Response, FindsAFullWellBelowTheAdcRange) {
  // Conversion gain such that the full well fills only ~80 % of the 12-bit range: values
  // pile up at the clip level, which becomes the saturation level.
  SimSetup setup(12, {1.0});
  setup.params.conversion_gain_dn_per_e = 0.8 * (4095.0 - 64.0) / setup.params.full_well_e;
  auto stack = calib::radiometry_test::sim_stack(setup.camera, setup.params, setup.radiance, setup.exposures, test::seed());
  auto frames = stack.frames();
  ResponseOptions opt;
  opt.black_dn = 64.0;
  ResponseCurve r = recover_response(frames, 12, opt);
  const double clip = 64.0 + setup.params.full_well_e * setup.params.conversion_gain_dn_per_e;
  EXPECT_LT(r.window.saturation_dn, clip);
  EXPECT_GT(r.window.saturation_dn, clip - 40.0);
  EXPECT_LT(r.report.nonlinearity_rel[0], 0.01);  // a linear sensor stays linear
}

TEST(Response, JsonRoundTrip) {
  calib::radiometry_test::GammaCamera cam;
  auto stack = gamma_stack(cam, 3);
  auto frames = stack.frames();
  ResponseCurve r = recover_response(frames, 8, {});
  test::TempDir dir;
  test::write_text(dir / "in.png", "x");
  r.provenance = Provenance::make("response", {dir / "in.png"});
  r.save(dir / "response.json");
  ResponseCurve back = ResponseCurve::load(dir / "response.json");
  EXPECT_EQ(back.channels, 3);
  EXPECT_EQ(back.bit_depth, 8);
  EXPECT_EQ(back.provenance.kind, "response");
  ASSERT_EQ(back.provenance.inputs.size(), 1u);
  for (int c = 0; c < 3; ++c)
    for (double u : {20.0, 100.5, 240.0}) {
      EXPECT_DOUBLE_EQ(back.to_linear(c, u), r.to_linear(c, u));
      EXPECT_DOUBLE_EQ(back.variance(c, u), r.variance(c, u));
    }
  Json j = read_json_file(dir / "response.json");
  j["linear"][1].erase(0);
  write_json_file(dir / "bad.json", j);
  EXPECT_THAT(test::error_message<DataError>([&] { ResponseCurve::load(dir / "bad.json"); }), HasSubstr("bad.json"));
}

TEST(Response, RejectsStacksWithoutUsableData) {
  Image<std::uint16_t> a(32, 32, 1, 100), b(32, 32, 1, 120);
  std::vector<StackFrame> same{{&a, 0.1}, {&b, 0.1}};
  EXPECT_THAT(test::error_message<DataError>([&] { recover_response(same, 8, {}); }), HasSubstr("same exposure time"));
  Image<std::uint16_t> full(32, 32, 1, 255);
  std::vector<StackFrame> saturated{{&full, 0.1}, {&full, 0.2}};
  EXPECT_THAT(test::error_message<CalibrationError>([&] { recover_response(saturated, 8, {}); }), HasSubstr("usable"));
  std::vector<StackFrame> one{{&a, 0.1}};
  EXPECT_THAT(test::error_message<DataError>([&] { recover_response(one, 8, {}); }), HasSubstr("at least 2"));
}

TEST(Response, NoDataColourIsIgnored) {
  // Half the pixels of every image carry a marker colour and wrong values otherwise; with
  // the marker declared as no-data the curve is as good as without them.
  calib::radiometry_test::GammaCamera cam;
  auto stack = gamma_stack(cam, 3);
  std::mt19937_64 rng(test::seed());
  for (auto& img : stack.images)
    for (int y = 0; y < img.height(); ++y)
      for (int x = 0; x < img.width() / 2; ++x) {
        img.at(x, y, 0) = 0;
        img.at(x, y, 1) = 0;
        img.at(x, y, 2) = 255;
      }
  auto frames = stack.frames();
  ResponseOptions opt;
  opt.method = ResponseMethod::Debevec;
  opt.no_data = {0, 0, 255};
  ResponseCurve r = recover_response(frames, 8, opt);
  for (int c = 0; c < 3; ++c)
    EXPECT_LT(calib::radiometry_test::max_relative_error(r, c, [&](double u) { return cam.truth(u); }, 13, 250), 0.02);
}

TEST(ResponseOptions, TheNoDataColourIsOneValueOrThreeNamedByTheFlag) {
  EXPECT_TRUE(calib::parse_no_data("", "--no-data").empty());
  EXPECT_EQ(calib::parse_no_data("0", "--no-data"), (std::vector<std::uint16_t>{0}));
  EXPECT_EQ(calib::parse_no_data("255,0,65535", "--no-data"), (std::vector<std::uint16_t>{255, 0, 65535}));
  for (const char* bad : {"1,2", "70000", "-1", "a,b,c", "1,,2", "1.5"}) {
    try {
      calib::parse_no_data(bad, "--no-data");
      ADD_FAILURE() << bad << ": no error";
    } catch (const UsageError& e) {
      EXPECT_THAT(e.what(), ::testing::StartsWith("--no-data: ")) << bad;
    }
  }
}

TEST(ExposureStack, TheTimesComeFromTheListTheFileOrTheFoldersExposuresTxt) {
  test::TempDir dir;
  std::filesystem::create_directories(dir / "stack");
  write_png(dir / "stack" / "a.png", Image<std::uint16_t>(8, 6, 1, 100), 16);
  write_png(dir / "stack" / "b.png", Image<std::uint16_t>(8, 6, 1, 200), 16);
  const std::string folder = (dir / "stack").string();
  EXPECT_EQ(load_stack_files({folder}, "0.1,1/5", "").exposures_s, (std::vector<double>{0.1, 0.2}));
  test::write_text(dir / "times.txt", "a.png 0.3\nb.png 0.6\n");
  EXPECT_EQ(load_stack_files({folder}, "", dir / "times.txt").exposures_s, (std::vector<double>{0.3, 0.6}));
  EXPECT_THAT(test::error_message<UsageError>([&] { load_stack_files({folder}, "", ""); }),
              HasSubstr("give the exposure times: --exposures LIST or --exposure-file F"));
  test::write_text(dir / "stack" / "exposures.txt", "a.png 0.01\nb.png 0.02\n");  // the folder's own
  EXPECT_EQ(load_stack_files({folder}, "", "").exposures_s, (std::vector<double>{0.01, 0.02}));
  EXPECT_THAT(test::error_message<UsageError>([&] { load_stack_files({folder}, "0.1", dir / "times.txt"); }),
              HasSubstr("not both"));
  EXPECT_THAT(test::error_message<UsageError>([&] { load_stack_files({folder}, "0.1", ""); }),
              HasSubstr("--exposures gives 1 times for 2 images"));
}
