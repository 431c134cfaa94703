// HDR merging on synthetic brackets with known radiance: accuracy within the noise, a
// variance estimate that matches the actual scatter, validity, dark and flat correction,
// 12- and 16-bit data, streaming == batch, and agreement with OpenCV's MergeRobertson.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <opencv2/photo.hpp>
#include <random>

#include "paintlab/acquisition/hdr_merge.h"
#include "paintlab/calibration/exposure_stack.h"
#include "paintlab/calibration/record.h"
#include "paintlab/core/error.h"
#include "paintlab/core/hash.h"
#include "test_util.h"

using namespace paintlab;
using ::testing::HasSubstr;
namespace fs = std::filesystem;

namespace {

// A camera with Gaussian shot + read noise: z = black + dark_rate t + f(flat X t) + noise,
// clipped to [0, 2^bits - 1]; X in DN/s of linear signal.
struct Camera {
  int bits = 16;
  double black = 200.0;
  double read_dn = 3.0;
  double gain_dn_per_e = 0.5;  // shot variance = gain x signal
  double full_dn = 60000.0;    // signal clips here (full well)
  std::function<double(double)> f = [](double x) { return x; };  // response on linear DN
  const ImageF* flat = nullptr;
  const ImageF* dark_rate = nullptr;
  const ImageF* bias = nullptr;

  Image<std::uint16_t> expose(const ImageF& x, double t, std::mt19937_64& rng) const {
    std::normal_distribution<double> n(0.0, 1.0);
    const double top = std::ldexp(1.0, bits) - 1.0;
    Image<std::uint16_t> img(x.width(), x.height(), x.channels());
    for (std::size_t i = 0; i < img.size(); ++i) {
      double s = x.data()[i] * t * (flat ? flat->data()[i] : 1.0);
      s += std::sqrt(std::max(s, 0.0) * gain_dn_per_e) * n(rng);
      s = std::min(s, full_dn);
      const double b = (bias ? bias->data()[i] : black) + (dark_rate ? dark_rate->data()[i] * t : 0.0);
      // The response is defined on signal >= 0; shot noise on a dark pixel can take s below 0
      // (the normal approximation), where the odd extension keeps a linear camera unchanged and
      // a power law finite (pow of a negative number is NaN, and its cast undefined).
      const double fs = s >= 0.0 ? f(s) : -f(-s);
      const double z = std::round(b + fs + read_dn * n(rng));
      img.data()[i] = static_cast<std::uint16_t>(std::clamp(z, 0.0, top));
    }
    return img;
  }
};

ImageF log_uniform(int w, int h, int c, double lo, double hi, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(std::log(lo), std::log(hi));
  ImageF img(w, h, c);
  for (auto& v : img.values()) v = static_cast<float>(std::exp(u(rng)));
  return img;
}

using Stack = calib::ExposureStack;

Stack bracket(const Camera& cam, const ImageF& x, int count, double t0, double ratio, std::uint64_t seed) {
  Stack s;
  std::mt19937_64 rng(seed);
  for (int j = 0; j < count; ++j) {
    s.exposures_s.push_back(t0 * std::pow(ratio, j));
    s.images.push_back(cam.expose(x, s.exposures_s.back(), rng));
  }
  return s;
}

// Normalised errors (E - truth) / sqrt(var) over valid values.
struct ZStats {
  double rms = 0.0, mean = 0.0;
  long n = 0;
};
ZStats z_stats(const acq::HdrResult& r, const ImageF& truth, const std::string& y = "Y") {
  const ImageF& e = r.image.plane(y);
  const ImageF& v = r.image.plane("var." + y);
  const ImageF& ok = r.image.plane("valid");
  ZStats z;
  double s = 0.0, s2 = 0.0;
  for (std::size_t p = 0; p < e.size(); ++p) {
    if (ok.data()[p] != 1.0f) continue;
    const double d = (e.data()[p] - truth.data()[p]) / std::sqrt(v.data()[p]);
    s += d;
    s2 += d * d;
    ++z.n;
  }
  z.mean = s / z.n;
  z.rms = std::sqrt(s2 / z.n);
  return z;
}

// The test camera as a linear camera: its black level, noise floor, saturation and noise.
acq::HdrCalibration linear_calibration(const Camera& cam) {
  calib::ValueWindow w;
  w.black_dn = cam.black;
  w.floor_dn = 3.0 * cam.read_dn;
  w.saturation_dn = std::min(cam.black + cam.full_dn, std::ldexp(1.0, cam.bits) - 1.0) - 100.0;
  acq::HdrCalibration cal;
  cal.response = calib::ResponseCurve::identity(cam.bits, 1, w);
  cal.response->noise = {cam.read_dn, cam.gain_dn_per_e, "test camera"};
  return cal;
}

}  // namespace

TEST(HdrMerge, SixteenBitRadianceWithinTheNoiseAndVarianceMatchesTheScatter) {
  Camera cam;
  // Radiance (DN/s) over 6 decades; 12 exposures x2 cover them.
  const ImageF x = log_uniform(96, 64, 1, 30.0, 3e7, test::seed());
  const Stack s = bracket(cam, x, 12, 1e-3, 2.0, test::seed() + 1);
  const acq::HdrCalibration cal = linear_calibration(cam);
  const auto frames = s.frames();
  const acq::HdrResult r = acq::merge_hdr(frames, 16, cal);
  EXPECT_EQ(r.stats.weighting, "inverse-variance");
  EXPECT_EQ(r.image.names, (std::vector<std::string>{"Y", "var.Y", "valid"}));
  EXPECT_GT(r.stats.valid, r.stats.pixels * 95 / 100);
  const ZStats z = z_stats(r, x);
  std::printf("16-bit linear: %ld valid, normalised error RMS %.3f, mean %.3f\n", z.n, z.rms, z.mean);
  EXPECT_NEAR(z.rms, 1.0, 0.1);      // the variance estimate describes the actual scatter
  EXPECT_NEAR(z.mean, 0.0, 0.1);     // no bias
}

TEST(HdrMerge, InvalidWhereNoExposureMeasuresAndValuesAreBounds) {
  Camera cam;
  ImageF x(4, 1, 1);
  x.at(0, 0) = 1e3f;   // fine
  x.at(1, 0) = 1e10f;  // saturated even at the shortest exposure
  x.at(2, 0) = 1e-2f;  // below the noise floor at the longest
  x.at(3, 0) = 1e5f;
  const Stack s = bracket(cam, x, 6, 1e-3, 2.0, test::seed());
  const acq::HdrCalibration cal = linear_calibration(cam);
  const auto frames = s.frames();
  const acq::HdrResult r = acq::merge_hdr(frames, 16, cal);
  const ImageF& v = r.image.plane("valid");
  const ImageF& y = r.image.plane("Y");
  const ImageF& var = r.image.plane("var.Y");
  EXPECT_EQ(v.at(0, 0), 1.0f);
  EXPECT_EQ(v.at(1, 0), 0.0f);
  EXPECT_EQ(v.at(2, 0), 0.0f);
  EXPECT_EQ(v.at(3, 0), 1.0f);
  EXPECT_TRUE(std::isinf(var.at(1, 0)));
  EXPECT_TRUE(std::isinf(var.at(2, 0)));
  // Saturated: a lower bound g(saturation) / t_min, far below the truth but above every
  // measurable value.
  EXPECT_GT(y.at(1, 0), 0.9 * (cal.response->window.u_saturation()) / 1e-3);
  EXPECT_LT(y.at(2, 0), 3.0 * cam.read_dn / 0.032 + 1.0);
  EXPECT_EQ(r.stats.saturated, 1);
  EXPECT_EQ(r.stats.dark, 1);
  EXPECT_EQ(r.stats.valid, 2);
}

TEST(HdrMerge, StreamingEqualsBatch) {
  Camera cam;
  const ImageF x = log_uniform(50, 30, 1, 30.0, 3e7, test::seed());
  const Stack s = bracket(cam, x, 8, 1e-3, 2.5, test::seed() + 2);
  const acq::HdrCalibration cal = linear_calibration(cam);
  acq::HdrOptions opt;
  opt.tile_values = 128;  // several tiles, one partial
  acq::HdrMerger merger(cal, opt, 50, 30, 1, 16);
  const auto frames = s.frames();
  const acq::HdrResult batch = merger.merge(frames);
  acq::HdrAccumulator acc = merger.accumulator();
  for (std::size_t j = 0; j < s.images.size(); ++j) acc.add(s.images[j], s.exposures_s[j]);
  EXPECT_EQ(acc.frames(), 8);
  const acq::HdrResult stream = acc.finish();
  for (const std::string name : {"Y", "var.Y", "valid"}) {
    const ImageF& a = batch.image.plane(name);
    const ImageF& b = stream.image.plane(name);
    for (std::size_t p = 0; p < a.size(); ++p) ASSERT_EQ(a.data()[p], b.data()[p]) << name << " at " << p;
  }
  EXPECT_THROW(acc.finish(), DataError);
}

// A per-pixel dark map (bias, dark current, one hot pixel) and flat field for w x h x c values.
struct DarkAndFlat {
  ImageF bias, rate, gain;
  calib::DarkFrame dark;
  calib::FlatField flat;
};
DarkAndFlat dark_and_flat(int w, int h, int c, std::uint64_t seed) {
  DarkAndFlat d{ImageF(w, h, c), ImageF(w, h, c), ImageF(w, h, c), {}, {}};
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> n(0.0, 1.0);
  for (std::size_t i = 0; i < d.bias.size(); ++i) {
    d.bias.data()[i] = static_cast<float>(180.0 + 8.0 * n(rng));
    d.rate.data()[i] = static_cast<float>(std::max(0.0, 50.0 + 20.0 * n(rng)));
    d.gain.data()[i] = static_cast<float>(1.0 + 0.05 * n(rng));
  }
  d.dark.bit_depth = 16;
  d.dark.bias_dn = d.bias;
  d.dark.rate_dn_per_s = d.rate;
  d.dark.hot = ImageU8(w, h, 1, 0);
  d.dark.hot.at(1, 1) = 1;
  d.dark.read_noise_dn = 3.0;
  d.dark.read_noise_measured = true;
  d.dark.mean_bias_dn = 180.0;
  d.flat.gain = d.gain;
  return d;
}

calib::ResponseCurve quadratic_response(int channels) {
  calib::ResponseCurve r;
  r.bit_depth = 16;
  r.channels = channels;
  r.window.black_dn = 180.0;
  r.window.floor_dn = 9.0;
  r.window.saturation_dn = 60000.0;
  r.linear.resize(static_cast<std::size_t>(channels));
  for (int k = 0; k < 256; ++k) {
    const double u = -200.0 + 65535.0 * k / 255.0;
    r.knots_dn.push_back(u);
    for (int c = 0; c < channels; ++c) r.linear[c].push_back(u + (0.2 + 0.1 * c) * u * std::abs(u) / 65535.0);
  }
  r.noise = {3.0, 0.5, "test camera"};
  return r;
}

TEST(HdrMerge, StreamingEqualsBatchWithDarkMapAndFlatFieldInRgb) {
  // Odd size: partial blocks and tiles; the dark-map kernels with per-channel tables.
  const int W = 37, H = 23;
  const DarkAndFlat d = dark_and_flat(W, H, 3, test::seed());
  Camera cam;
  cam.bias = &d.bias;
  cam.dark_rate = &d.rate;
  cam.flat = &d.gain;
  const ImageF x = log_uniform(W, H, 3, 100.0, 1e7, test::seed() + 1);
  const Stack s = bracket(cam, x, 9, 2e-3, 2.3, test::seed() + 2);
  acq::HdrCalibration cal;
  cal.response = quadratic_response(3);
  cal.dark = d.dark;
  cal.flat = d.flat;
  acq::HdrOptions opt;
  opt.tile_values = 300;  // tiles of 100 pixels: blocks of 240 and 60 values
  acq::HdrMerger merger(cal, opt, W, H, 3, 16);
  const auto frames = s.frames();
  const acq::HdrResult batch = merger.merge(frames);
  acq::HdrAccumulator acc = merger.accumulator();
  for (std::size_t j = 0; j < s.images.size(); ++j) acc.add(s.images[j], s.exposures_s[j]);
  const acq::HdrResult stream = acc.finish();
  EXPECT_EQ(batch.stats.hot, 1);
  EXPECT_GT(batch.stats.valid, batch.stats.pixels * 9 / 10);
  EXPECT_EQ(stream.stats.valid, batch.stats.valid);
  for (const std::string name : {"R", "G", "B", "var.R", "var.G", "var.B", "valid"}) {
    const ImageF& a = batch.image.plane(name);
    const ImageF& b = stream.image.plane(name);
    for (std::size_t p = 0; p < a.size(); ++p) ASSERT_EQ(a.data()[p], b.data()[p]) << name << " at " << p;
  }
}

TEST(HdrMerge, BaselineAndSimdInnerLoopsAgreeWithinFloatRounding) {
  // The x86-64 baseline loops against the ones this CPU runs (AVX2 + FMA where it has them):
  // mono and RGB, with and without a dark map.
  const int W = 41, H = 19;
  for (int channels : {1, 3}) {
    const DarkAndFlat d = dark_and_flat(W, H, channels, test::seed() + channels);
    Camera cam;
    cam.bias = &d.bias;
    cam.dark_rate = &d.rate;
    cam.flat = &d.gain;
    const ImageF x = log_uniform(W, H, channels, 30.0, 3e7, test::seed() + 10 + channels);
    const Stack s = bracket(cam, x, 12, 1e-3, 2.0, test::seed() + 20 + channels);
    const auto frames = s.frames();
    for (bool with_dark : {false, true}) {
      acq::HdrCalibration cal;
      cal.response = quadratic_response(channels);
      if (with_dark) {
        cal.dark = d.dark;
        cal.flat = d.flat;
      }
      acq::HdrOptions opt;
      const acq::HdrMerger fast(cal, opt, W, H, channels, 16);
      opt.baseline_simd = true;
      const acq::HdrMerger base(cal, opt, W, H, channels, 16);
      const acq::HdrResult a = fast.merge(frames);
      const acq::HdrResult b = base.merge(frames);
      std::printf("%d channel(s), %s: %s against %s\n", channels, with_dark ? "dark + flat" : "response only",
                  fast.simd(), base.simd());
      EXPECT_EQ(a.stats.valid, b.stats.valid);
      EXPECT_GT(a.stats.valid, a.stats.pixels * 8 / 10);
      ASSERT_EQ(a.image.names, b.image.names);
      for (std::size_t i = 0; i < a.image.names.size(); ++i) {
        const ImageF& pa = a.image.planes[i];
        const ImageF& pb = b.image.planes[i];
        double worst = 0.0;
        for (std::size_t p = 0; p < pa.size(); ++p) {
          const float u = pa.data()[p], v = pb.data()[p];
          if (std::isinf(u) || std::isinf(v)) {
            ASSERT_EQ(u, v) << a.image.names[i] << " at " << p;
            continue;
          }
          worst = std::max(worst, std::abs(double{u} - v) / std::max(std::abs(double{v}), 1e-30));
        }
        EXPECT_LT(worst, 1e-5) << a.image.names[i] << (with_dark ? " with dark + flat" : "");
      }
    }
  }
}

TEST(HdrMerge, DarkFrameAndFlatFieldAreApplied) {
  // Per-pixel bias, dark current and gain (vignetting): the merged radiance is the scene's,
  // not the sensor's.
  const int W = 80, H = 60;
  ImageF bias(W, H, 1), rate(W, H, 1), gain(W, H, 1);
  std::mt19937_64 rng(test::seed());
  std::normal_distribution<double> n(0.0, 1.0);
  for (int yy = 0; yy < H; ++yy)
    for (int xx = 0; xx < W; ++xx) {
      bias.at(xx, yy) = static_cast<float>(180.0 + 8.0 * n(rng));
      rate.at(xx, yy) = static_cast<float>(std::max(0.0, 50.0 + 20.0 * n(rng)));
      const double r2 = (std::pow(xx - W / 2.0, 2) + std::pow(yy - H / 2.0, 2)) / (W * W / 4.0);
      gain.at(xx, yy) = static_cast<float>(1.0 - 0.4 * r2);
    }
  Camera cam;
  cam.bias = &bias;
  cam.dark_rate = &rate;
  cam.flat = &gain;
  const ImageF x = log_uniform(W, H, 1, 100.0, 1e7, test::seed() + 3);
  const Stack s = bracket(cam, x, 10, 2e-3, 2.2, test::seed() + 4);

  calib::DarkFrame dark;
  dark.bit_depth = 16;
  dark.bias_dn = bias;
  dark.rate_dn_per_s = rate;
  dark.hot = ImageU8(W, H, 1, 0);
  dark.hot.at(5, 5) = 1;
  dark.read_noise_dn = cam.read_dn;
  dark.read_noise_measured = true;
  dark.mean_bias_dn = 180.0;
  calib::FlatField flat;
  flat.gain = gain;
  calib::ValueWindow w;
  w.black_dn = 180.0;
  w.floor_dn = 9.0;
  w.saturation_dn = 60000.0;
  acq::HdrCalibration cal;
  cal.response = calib::ResponseCurve::identity(16, 1, w);
  cal.response->noise = {cam.read_dn, cam.gain_dn_per_e, "test camera"};
  cal.dark = dark;
  cal.flat = flat;
  const auto frames = s.frames();
  const acq::HdrResult r = acq::merge_hdr(frames, 16, cal);
  EXPECT_EQ(r.image.plane("valid").at(5, 5), 0.0f);
  EXPECT_EQ(r.stats.hot, 1);
  const ZStats z = z_stats(r, x);
  std::printf("dark + flat: normalised error RMS %.3f, mean %.3f\n", z.rms, z.mean);
  EXPECT_NEAR(z.rms, 1.0, 0.12);
  EXPECT_NEAR(z.mean, 0.0, 0.12);
  // Without them the corner pixels come out 40 % low.
  acq::HdrCalibration bare;
  bare.response = cal.response;
  const acq::HdrResult b = acq::merge_hdr(frames, 16, bare);
  EXPECT_LT(b.image.plane("Y").at(0, 0) / x.at(0, 0), 0.75);
  EXPECT_THAT(r.image.plane("Y").at(0, 0), test::NearRel(x.at(0, 0), 0.05));
}

TEST(HdrMerge, TwelveBitNonlinearCameraThroughItsResponse) {
  const Camera cam{.bits = 12, .black = 64.0, .read_dn = 1.5, .gain_dn_per_e = 0.2, .full_dn = 4000.0,
                   .f = [](double s) { return 4000.0 * std::pow(s / 4000.0, 0.8); }};
  // The response the calibration would have found: g = f^-1 on knots every 4 DN.
  calib::ResponseCurve resp;
  resp.bit_depth = 12;
  resp.channels = 1;
  resp.window.black_dn = 64.0;
  resp.window.floor_dn = 5.0;
  resp.window.saturation_dn = 4064.0 - 8.0;
  resp.linear.resize(1);
  for (double u = -64.0; u <= 4032.0; u += 4.0) {
    resp.knots_dn.push_back(u);
    resp.linear[0].push_back(u <= 0.0 ? u : 4000.0 * std::pow(u / 4000.0, 1.25));
  }
  resp.noise = {cam.read_dn, cam.gain_dn_per_e, "test camera"};
  const ImageF x = log_uniform(64, 48, 1, 30.0, 3e6, test::seed());
  const Stack s = bracket(cam, x, 12, 1e-3, 2.0, test::seed() + 5);
  acq::HdrCalibration cal;
  cal.response = resp;
  const auto frames = s.frames();
  const acq::HdrResult r = acq::merge_hdr(frames, 12, cal);
  const ImageF& y = r.image.plane("Y");
  const ImageF& ok = r.image.plane("valid");
  // Within the middle decades: no bias (mean relative error), scatter as the noise says.
  double sum_rel = 0.0;
  long n = 0;
  for (std::size_t p = 0; p < y.size(); ++p) {
    if (ok.data()[p] != 1.0f || x.data()[p] < 1e3 || x.data()[p] > 1e6) continue;
    sum_rel += y.data()[p] / x.data()[p] - 1.0;
    ++n;
  }
  std::printf("12-bit nonlinear: %ld pixels in the middle decades, mean relative error %.5f\n", n, sum_rel / n);
  EXPECT_GT(n, 1000);
  EXPECT_LT(std::abs(sum_rel / n), 0.002);
  const ZStats z = z_stats(r, x);
  std::printf("12-bit nonlinear: normalised error RMS %.3f, mean %.3f\n", z.rms, z.mean);
  EXPECT_NEAR(z.rms, 1.0, 0.15);
  EXPECT_NEAR(z.mean, 0.0, 0.1);
}

TEST(HdrMerge, MatchesOpenCvMergeRobertsonWithTheSameCurveAndWeights) {
  // 8-bit RGB, gamma camera; OpenCV gets our curve as its response table.
  const Camera cam{.bits = 8, .black = 0.0, .read_dn = 0.0, .gain_dn_per_e = 0.0, .full_dn = 255.0,
                   .f = [](double s) { return 255.0 * std::pow(std::max(s, 0.0) / 255.0, 1.0 / 2.2); }};
  const ImageF x = log_uniform(64, 48, 3, 1.0, 1e5, test::seed());
  const Stack s = bracket(cam, x, 10, 1e-3, 2.0, test::seed() + 6);
  calib::ValueWindow w;
  w.saturation_dn = 255.0;
  calib::ResponseCurve resp;
  resp.bit_depth = 8;
  resp.channels = 3;
  resp.window = w;
  resp.linear.resize(3);
  for (int z = 0; z < 256; ++z) {
    resp.knots_dn.push_back(z);
    for (int c = 0; c < 3; ++c) resp.linear[c].push_back(255.0 * std::pow(z / 255.0, 2.2) + 1e-3);
  }
  acq::HdrCalibration cal;
  cal.response = resp;
  acq::HdrOptions opt;
  opt.weighting = calib::Weighting::Robertson;
  const auto frames = s.frames();
  const acq::HdrResult ours = acq::merge_hdr(frames, 8, cal, opt);

  cv::Mat lut(256, 1, CV_32FC3);
  for (int z = 0; z < 256; ++z)
    for (int c = 0; c < 3; ++c) lut.at<cv::Vec3f>(z)[c] = static_cast<float>(resp.linear[c][z]);
  std::vector<cv::Mat> images;
  std::vector<float> times;
  for (std::size_t j = 0; j < s.images.size(); ++j) {
    cv::Mat m(48, 64, CV_8UC3);
    for (std::size_t i = 0; i < s.images[j].size(); ++i) m.data[i] = static_cast<std::uint8_t>(s.images[j].data()[i]);
    images.push_back(m);
    times.push_back(static_cast<float>(s.exposures_s[j]));
  }
  cv::Mat hdr;
  cv::createMergeRobertson()->process(images, hdr, times, lut);
  const ImageF* planes[3] = {&ours.image.plane("R"), &ours.image.plane("G"), &ours.image.plane("B")};
  const ImageF& ok = ours.image.plane("valid");
  double worst = 0.0;
  long n = 0;
  for (std::size_t p = 0; p < ok.size(); ++p) {
    if (ok.data()[p] != 1.0f) continue;
    for (int c = 0; c < 3; ++c) {
      const double theirs = hdr.ptr<float>()[3 * p + c];
      if (!(theirs > 0.0)) continue;
      worst = std::max(worst, std::abs(planes[c]->data()[p] / theirs - 1.0));
      ++n;
    }
  }
  std::printf("vs OpenCV MergeRobertson: %ld values, worst relative difference %.2e\n", n, worst);
  EXPECT_GT(n, 3000);
  EXPECT_LT(worst, 0.005);
}

TEST(HdrMerge, RejectsFramesAndCalibrationsThatDoNotFit) {
  Camera cam;
  const acq::HdrCalibration cal = linear_calibration(cam);
  Image<std::uint16_t> a(8, 8, 1, 1000), b(9, 8, 1, 1000), rgb(8, 8, 3, 1000);
  std::vector<calib::StackFrame> mixed{{&a, 0.01}, {&b, 0.02}};
  EXPECT_THAT(test::error_message<DataError>([&] { acq::merge_hdr(mixed, 16, cal); }),
              HasSubstr("frame 2 is 9x8x1"));
  std::vector<calib::StackFrame> colour{{&rgb, 0.01}};
  EXPECT_THAT(test::error_message<DataError>([&] { acq::merge_hdr(colour, 16, cal); }),
              HasSubstr("the response has 1 channel(s), the frames 3"));
  std::vector<calib::StackFrame> bad_t{{&a, 0.0}};
  EXPECT_THROW(acq::merge_hdr(bad_t, 16, cal), DataError);
  EXPECT_THROW(acq::merge_hdr(std::vector<calib::StackFrame>{}, 16, cal), DataError);
  EXPECT_THROW(acq::merge_hdr(mixed, 12, cal), DataError);  // response made from 16-bit data
}

TEST(HdrFiles, EachGivenFileStandsAndTheRigsFillTheRestWithTheirChecksumsRecorded) {
  test::TempDir tmp;
  fs::create_directories(tmp / "calib");
  calib::ResponseCurve::identity(12, 1, {}).save(tmp / "calib" / calib::kResponseFile);
  calib::DarkFrame dark;
  dark.bit_depth = 12;
  dark.bias_dn = ImageF(4, 3, 1, 64.0f);
  dark.rate_dn_per_s = ImageF(4, 3, 1, 0.0f);
  dark.hot = ImageU8(4, 3, 1, 0);
  fs::create_directories(tmp / "mine");
  dark.save(tmp / "mine" / "dark.json");
  dark.bias_dn = ImageF(4, 3, 1, 70.0f);
  dark.save(tmp / "calib" / calib::kDarkFile);  // the rig's, not used: one is given

  acq::HdrFiles files;
  EXPECT_TRUE(files.empty());
  files.dark = tmp / "mine" / "dark.json";
  files.complete_from(tmp / "calib");
  EXPECT_EQ(files.response, tmp / "calib" / calib::kResponseFile);
  EXPECT_EQ(files.dark, tmp / "mine" / "dark.json");
  EXPECT_TRUE(files.flat.empty());  // the rig has none
  const acq::HdrCalibration cal = files.load();
  ASSERT_TRUE(cal.response && cal.dark);
  EXPECT_EQ(cal.response->bit_depth, 12);
  EXPECT_FLOAT_EQ(cal.dark->bias_dn.at(0, 0), 64.0f);
  EXPECT_FALSE(cal.flat);
  ExrImage image;
  files.stamp(image);
  EXPECT_EQ(image.attributes.at("paintlab.response_sha256"), sha256_file(files.response));
  EXPECT_EQ(image.attributes.at("paintlab.dark_sha256"), sha256_file(files.dark));
  EXPECT_EQ(image.attributes.count("paintlab.flat_sha256"), 0u);
}
