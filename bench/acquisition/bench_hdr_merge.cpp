// HDR merge throughput on the reference rig's stack size: 16 exposures of 1360 x 1024.
//  1. 8-bit RGB, ours against OpenCV 4.6's MergeRobertson (which takes only 8-bit input) with
//     the same response curve and Robertson's weights: first the radiance of both is compared
//     (relative difference where both are valid; must stay within 0.5 %), then both are timed
//     and the ratio printed.
//  2. 16-bit mono, the rig's case: response only (one table per raw value) and response + dark
//     frame + flat field (per-pixel dark subtraction), in GB/s of input, against memcpy.
//  3. BayerRG12 colour (issue 14): the mosaic merged with response, dark and flat, then
//     demosaiced with its variance and mapped by a colour matrix (what `paintlab measure` stores
//     per light position), in GB/s of raw input (2 bytes a pixel); against OpenCV: each frame
//     demosaiced (cv::demosaicing, bilinear, 16-bit), scaled to 8 bits for MergeRobertson (which
//     takes only 8-bit input), merged, and the same matrix applied (cv::transform).
// Run: build/bench/acquisition/bench_acquisition_hdr [--benchmark_filter=...]
//      [--benchmark_out=hdr.json --benchmark_out_format=json]
// The argument of our runs is the number of threads TBB may use (tbb::global_control); OpenCV
// runs with its own thread setting (cv::getNumThreads(), printed). CPU times are of the whole
// process (all threads), so "per core" figures do not depend on what else the machine runs.
#include <benchmark/benchmark.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <map>
#include <opencv2/core.hpp>
#include <opencv2/photo.hpp>
#include <random>
#include <string>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "paintlab/acquisition/demosaic.h"
#include "paintlab/acquisition/hdr_merge.h"

using namespace paintlab;

namespace {

constexpr int kWidth = 1360, kHeight = 1024, kExposures = 16;

// The reference rig's bracket: 0.25 ms to 328 ms, geometric.
std::vector<double> bracket() {
  std::vector<double> t(kExposures);
  for (int j = 0; j < kExposures; ++j) t[j] = 0.25e-3 * std::pow(328.0 / 0.25, j / (kExposures - 1.0));
  return t;
}

// Scene radiance log-uniform over 5 decades, in units where exposure x radiance = 1 fills the range.
std::vector<float> scene(int values, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(std::log(1.0), std::log(1e5));
  std::vector<float> x(static_cast<std::size_t>(values));
  for (auto& v : x) v = static_cast<float>(std::exp(u(rng)) / 0.3);
  return x;
}

// --- 8-bit RGB: a gamma 2.2 camera ------------------------------------------------------

struct RgbStack {
  std::vector<Image<std::uint16_t>> ours;  // our frames (values 0..255)
  std::vector<cv::Mat> cv;                 // the same as CV_8UC3
  std::vector<double> t;
  calib::ResponseCurve response;
  cv::Mat cv_response;                     // 256 x 1 CV_32FC3, the same curve
  std::size_t input_bytes = 0;             // 8-bit input, as OpenCV reads it
};

const RgbStack& rgb_stack() {
  static RgbStack s = [] {
    RgbStack s;
    s.t = bracket();
    const std::vector<float> x = scene(kWidth * kHeight * 3, 11);
    std::mt19937_64 rng(12);
    std::normal_distribution<float> noise(0.0f, 0.5f);
    for (double t : s.t) {
      Image<std::uint16_t> img(kWidth, kHeight, 3);
      cv::Mat m(kHeight, kWidth, CV_8UC3);
      for (std::size_t i = 0; i < img.size(); ++i) {
        const double e = std::min(1.0, x[i] * t / 1000.0);
        const float z = std::clamp(std::round(255.0f * static_cast<float>(std::pow(e, 1.0 / 2.2)) + noise(rng)), 0.0f, 255.0f);
        img.data()[i] = static_cast<std::uint16_t>(z);
        m.data[i] = static_cast<std::uint8_t>(z);
      }
      s.ours.push_back(std::move(img));
      s.cv.push_back(m);
      s.input_bytes += m.total() * m.elemSize();
    }
    s.response.bit_depth = 8;
    s.response.channels = 3;
    s.response.window.floor_dn = 0.0;
    s.response.window.saturation_dn = 255.0;
    s.response.window.black_dn = 0.0;
    s.cv_response = cv::Mat(256, 1, CV_32FC3);
    s.response.linear.assign(3, std::vector<double>(256));
    for (int k = 0; k < 256; ++k) {
      s.response.knots_dn.push_back(k);
      const double g = 255.0 * std::pow(k / 255.0, 2.2);
      for (int c = 0; c < 3; ++c) {
        s.response.linear[c][k] = g;
        s.cv_response.at<cv::Vec3f>(k)[c] = static_cast<float>(g);
      }
    }
    return s;
  }();
  return s;
}

acq::HdrOptions robertson() {
  acq::HdrOptions o;
  o.weighting = calib::Weighting::Robertson;
  return o;
}

std::vector<calib::StackFrame> frames_of(const std::vector<Image<std::uint16_t>>& images, const std::vector<double>& t) {
  std::vector<calib::StackFrame> f;
  for (std::size_t j = 0; j < images.size(); ++j) f.push_back({&images[j], t[j]});
  return f;
}

cv::Mat opencv_merge(const RgbStack& s) {
  std::vector<float> times(s.t.begin(), s.t.end());
  cv::Mat out;
  cv::createMergeRobertson()->process(s.cv, out, times, s.cv_response);
  return out;
}

// The instruction set our merge's inner loops use on this CPU.
std::string simd_name() {
  const RgbStack& s = rgb_stack();
  acq::HdrCalibration cal;
  cal.response = s.response;
  return acq::HdrMerger(cal, robertson(), kWidth, kHeight, 3, 8).simd();
}

// Same radiance where both are valid (ours: valid = 1; OpenCV: a positive weight sum).
void compare_with_opencv() {
  const RgbStack& s = rgb_stack();
  acq::HdrCalibration cal;
  cal.response = s.response;
  acq::HdrMerger merger(cal, robertson(), kWidth, kHeight, 3, 8);
  const auto frames = frames_of(s.ours, s.t);
  const acq::HdrResult ours = merger.merge(frames);
  const cv::Mat theirs = opencv_merge(s);
  const ImageF& valid = ours.image.plane("valid");
  const char* names[3] = {"R", "G", "B"};
  double worst = 0.0;
  long long compared = 0;
  std::vector<double> rel;
  for (int c = 0; c < 3; ++c) {
    const ImageF& p = ours.image.plane(names[c]);
    for (int y = 0; y < kHeight; ++y)
      for (int x = 0; x < kWidth; ++x) {
        const std::size_t i = static_cast<std::size_t>(y) * kWidth + x;
        const double b = theirs.at<cv::Vec3f>(y, x)[c];
        if (valid.data()[i] != 1.0f || !(b > 0.0)) continue;
        const double d = std::abs(p.data()[i] / b - 1.0);
        worst = std::max(worst, d);
        ++compared;
      }
  }
  std::printf("8-bit RGB %dx%d x %d exposures: ours vs OpenCV MergeRobertson (same curve and weights): %lld values "
              "compared, worst relative difference %.3g (limit 0.5 %%): %s\n",
              kWidth, kHeight, kExposures, compared, worst, worst <= 0.005 ? "OK" : "DIFFERENT");
}

void BM_OpenCvMergeRobertson8BitRgb(benchmark::State& state) {
  const RgbStack& s = rgb_stack();
  for (auto _ : state) {
    cv::Mat out = opencv_merge(s);
    benchmark::DoNotOptimize(out.data);
  }
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * s.input_bytes));
  state.counters["threads"] = cv::getNumThreads();
}

void BM_OursMerge8BitRgb(benchmark::State& state) {
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(state.range(0)));
  const RgbStack& s = rgb_stack();
  acq::HdrCalibration cal;
  cal.response = s.response;
  acq::HdrMerger merger(cal, robertson(), kWidth, kHeight, 3, 8);
  const auto frames = frames_of(s.ours, s.t);
  for (auto _ : state) {
    acq::HdrResult r = merger.merge(frames);
    benchmark::DoNotOptimize(r.image.planes.front().data());
  }
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * s.input_bytes));
  state.counters["threads"] = static_cast<double>(state.range(0));
}

// One-plane raw frames of the log-uniform scene at exposures `t`: black + (max - black) R(e)
// with e the exposure (clipped at 1), shot noise (0.3 DN per DN) and read noise of
// sqrt(read_var) DN; their size in bytes is added to `bytes`.
template <class Response>
std::vector<Image<std::uint16_t>> raw_stack(const std::vector<double>& t, std::uint64_t seed, double black,
                                            double max_dn, double read_var, Response response, std::size_t* bytes) {
  const std::vector<float> x = scene(kWidth * kHeight, seed);
  std::mt19937_64 rng(seed + 1);
  std::normal_distribution<float> noise(0.0f, 1.0f);
  std::vector<Image<std::uint16_t>> images;
  for (double ti : t) {
    Image<std::uint16_t> img(kWidth, kHeight, 1);
    for (std::size_t i = 0; i < img.size(); ++i) {
      const double v = black + (max_dn - black) * response(std::min(1.0, x[i] * ti / 1000.0));
      img.data()[i] =
          static_cast<std::uint16_t>(std::clamp(std::round(v + std::sqrt(v * 0.3 + read_var) * noise(rng)), 0.0, max_dn));
    }
    *bytes += img.size() * sizeof(std::uint16_t);
    images.push_back(std::move(img));
  }
  return images;
}

// A one-channel response curve: 256 knots over the span above `black`, the linear value of
// each from `linear(u)`, noise read_noise DN and 0.3 DN per electron.
template <class Linear>
calib::ResponseCurve mono_response(int bit_depth, double black, double max_dn, double floor_dn, double read_noise,
                                   Linear linear) {
  calib::ResponseCurve r;
  r.bit_depth = bit_depth;
  r.channels = 1;
  r.window.black_dn = black;
  r.window.floor_dn = floor_dn;
  r.window.saturation_dn = max_dn;
  r.linear.resize(1);
  for (int k = 0; k < 256; ++k) {
    const double u = (max_dn - black) * k / 255.0;
    r.knots_dn.push_back(u);
    r.linear[0].push_back(linear(u));
  }
  r.noise = {read_noise, 0.3, "benchmark"};
  return r;
}

// A uniform dark map (bias `black`, dark current `rate` DN/s) and a flat with 10 % vignetting.
void add_dark_and_flat(acq::HdrCalibration& cal, int bit_depth, double black, float rate, double read_noise) {
  calib::DarkFrame d;
  d.bit_depth = bit_depth;
  d.bias_dn = ImageF(kWidth, kHeight, 1, static_cast<float>(black));
  d.rate_dn_per_s = ImageF(kWidth, kHeight, 1, rate);
  d.hot = ImageU8(kWidth, kHeight, 1, 0);
  d.read_noise_dn = read_noise;
  d.read_noise_measured = true;
  d.mean_bias_dn = black;
  calib::FlatField f;
  f.gain = ImageF(kWidth, kHeight, 1, 1.0f);
  for (int y = 0; y < kHeight; ++y)
    for (int x = 0; x < kWidth; ++x) {
      const double rx = (x - kWidth / 2.0) / kWidth, ry = (y - kHeight / 2.0) / kWidth;
      f.gain.at(x, y) = static_cast<float>(1.1 - 0.4 * (rx * rx + ry * ry));
    }
  cal.dark = d;
  cal.flat = f;
}

// --- 16-bit mono: the rig's camera ------------------------------------------------------

struct MonoStack {
  std::vector<Image<std::uint16_t>> images;
  std::vector<double> t;
  acq::HdrCalibration response_only;
  acq::HdrCalibration full;  // response + dark + flat
  std::size_t input_bytes = 0;
};

const MonoStack& mono_stack() {
  static MonoStack s = [] {
    MonoStack s;
    s.t = bracket();
    const double black = 1000.0, span = 65535.0 - black;
    s.images = raw_stack(s.t, 21, black, 65535.0, 100.0,
                         [](double e) { return 1.12 * e - 0.16 * e * e + 0.04 * e * e * e; }, &s.input_bytes);
    s.response_only.response = mono_response(16, black, 65535.0, 30.0, 10.0, [&](double u) {
      // Inverse of the cubic by Newton's method.
      const double y = u / span;
      double e = y;
      for (int it = 0; it < 30; ++it) e -= (1.12 * e - 0.16 * e * e + 0.04 * e * e * e - y) / (1.12 - 0.32 * e + 0.12 * e * e);
      return span * e;
    });
    s.full = s.response_only;
    add_dark_and_flat(s.full, 16, black, 2.0f, 10.0);
    return s;
  }();
  return s;
}

void mono_merge(benchmark::State& state, bool with_dark_and_flat, bool baseline = false) {
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(state.range(0)));
  const MonoStack& s = mono_stack();
  acq::HdrOptions options;
  options.baseline_simd = baseline;
  acq::HdrMerger merger(with_dark_and_flat ? s.full : s.response_only, options, kWidth, kHeight, 1, 16);
  const auto frames = frames_of(s.images, s.t);
  for (auto _ : state) {
    acq::HdrResult r = merger.merge(frames);
    benchmark::DoNotOptimize(r.image.planes.front().data());
  }
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * s.input_bytes));
  state.counters["threads"] = static_cast<double>(state.range(0));
}

void BM_OursMerge16BitMonoResponse(benchmark::State& s) { mono_merge(s, false); }
void BM_OursMerge16BitMonoResponseDarkFlat(benchmark::State& s) { mono_merge(s, true); }
// The same with the x86-64 baseline inner loops (a rig computer without AVX2).
void BM_OursMerge16BitMonoResponseDarkFlatBaselineSimd(benchmark::State& s) { mono_merge(s, true, true); }

// Memory bandwidth for scale: the 16-bit stack copied once (bytes counted once, as input).
void BM_MemcpyStack16BitMono(benchmark::State& state) {
  const MonoStack& s = mono_stack();
  std::vector<std::uint16_t> dst(s.images.front().size());
  for (auto _ : state) {
    for (const auto& img : s.images) std::memcpy(dst.data(), img.data(), img.size() * sizeof(std::uint16_t));
    benchmark::DoNotOptimize(dst.data());
    benchmark::ClobberMemory();
  }
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * s.input_bytes));
}

// --- BayerRG12 colour: merge the mosaic, demosaic, colour matrix -------------------------

struct BayerStack {
  std::vector<Image<std::uint16_t>> images;  // 12-bit values
  std::vector<double> t;
  acq::HdrCalibration full;                  // response + dark + flat (per filter colour)
  acq::ColourMap map;
  cv::Mat cv_response;                       // 256 x 1 CV_32FC3 for the 8-bit OpenCV path
  cv::Matx33f cv_matrix;
  std::size_t input_bytes = 0;
};

const BayerStack& bayer_stack() {
  static BayerStack s = [] {
    BayerStack s;
    s.t = bracket();
    const double black = 64.0;
    s.images = raw_stack(s.t, 31, black, 4095.0, 10.0, [](double e) { return e; }, &s.input_bytes);
    s.full.response = mono_response(12, black, 4095.0, 8.0, 3.0, [](double u) { return u; });
    add_dark_and_flat(s.full, 12, black, 0.5f, 3.0);
    s.full.flat->cfa = std::array<int, 4>{0, 1, 1, 2};
    const std::array<double, 9> m{1.6, -0.5, -0.1, -0.2, 1.4, -0.2, 0.0, -0.4, 1.4};
    s.map.pattern = dev::CfaPattern::RG;
    s.map.balance = {1.8, 1.0, 1.3};
    s.map.matrix = m;
    for (int i = 0; i < 9; ++i) s.cv_matrix.val[i] = static_cast<float>(m[static_cast<std::size_t>(i)] * s.map.balance[static_cast<std::size_t>(i % 3)]);
    s.cv_response = cv::Mat(256, 1, CV_32FC3);
    for (int k = 0; k < 256; ++k) s.cv_response.at<cv::Vec3f>(k) = cv::Vec3f(1.0f, 1.0f, 1.0f) * static_cast<float>(k);
    return s;
  }();
  return s;
}

void BM_OursMergeBayerRG12DemosaicMatrix(benchmark::State& state) {
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(state.range(0)));
  const BayerStack& s = bayer_stack();
  acq::HdrMerger merger(s.full, acq::HdrOptions{}, kWidth, kHeight, 1, 12);
  const auto frames = frames_of(s.images, s.t);
  for (auto _ : state) {
    acq::HdrResult r = merger.merge(frames);
    ExrImage rgb = acq::demosaic_to_colour(r.image, s.map);
    benchmark::DoNotOptimize(rgb.planes.front().data());
  }
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * s.input_bytes));
  state.counters["threads"] = static_cast<double>(state.range(0));
}

// OpenCV's way to the same: demosaic every frame, 8 bits for MergeRobertson, merge, matrix.
void BM_OpenCvDemosaicMergeRobertsonBayerRG12(benchmark::State& state) {
  const BayerStack& s = bayer_stack();
  std::vector<float> times(s.t.begin(), s.t.end());
  auto merge = cv::createMergeRobertson();
  for (auto _ : state) {
    std::vector<cv::Mat> rgb8(s.images.size());
    for (std::size_t j = 0; j < s.images.size(); ++j) {
      const cv::Mat mosaic(kHeight, kWidth, CV_16UC1, const_cast<std::uint16_t*>(s.images[j].data()));
      cv::Mat rgb16;
      cv::demosaicing(mosaic, rgb16, cv::COLOR_BayerBG2RGB);  // GenICam BayerRG is OpenCV's BayerBG
      rgb16.convertTo(rgb8[j], CV_8UC3, 1.0 / 16.0);
    }
    cv::Mat hdr, out;
    merge->process(rgb8, hdr, times, s.cv_response);
    cv::transform(hdr, out, s.cv_matrix);
    benchmark::DoNotOptimize(out.data);
  }
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * s.input_bytes));
  state.counters["opencv_threads"] = cv::getNumThreads();
}

BENCHMARK(BM_OpenCvMergeRobertson8BitRgb)->Unit(benchmark::kMillisecond)->UseRealTime()->MeasureProcessCPUTime()->MinTime(2.0);
BENCHMARK(BM_OursMerge8BitRgb)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime()->MeasureProcessCPUTime()->MinTime(1.0);
BENCHMARK(BM_OursMerge16BitMonoResponse)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime()->MeasureProcessCPUTime()->MinTime(1.0);
BENCHMARK(BM_OursMerge16BitMonoResponseDarkFlat)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime()->MeasureProcessCPUTime()->MinTime(1.0);
BENCHMARK(BM_OursMerge16BitMonoResponseDarkFlatBaselineSimd)->Arg(1)->Unit(benchmark::kMillisecond)->UseRealTime()->MeasureProcessCPUTime()->MinTime(1.0);
BENCHMARK(BM_MemcpyStack16BitMono)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(1.0);
BENCHMARK(BM_OursMergeBayerRG12DemosaicMatrix)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime()->MeasureProcessCPUTime()->MinTime(1.0);
BENCHMARK(BM_OpenCvDemosaicMergeRobertsonBayerRG12)->Unit(benchmark::kMillisecond)->UseRealTime()->MeasureProcessCPUTime()->MinTime(2.0);

// Keeps each benchmark's real time per iteration (ms) for the summary.
class Collecting : public benchmark::ConsoleReporter {
 public:
  std::map<std::string, double> ms, cpu_ms;
  void ReportRuns(const std::vector<Run>& runs) override {
    for (const Run& r : runs)
      if (r.run_type == Run::RT_Iteration) {
        ms[r.benchmark_name()] = r.GetAdjustedRealTime();
        cpu_ms[r.benchmark_name()] = r.GetAdjustedCPUTime();
      }
    ConsoleReporter::ReportRuns(runs);
  }
};

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  compare_with_opencv();
  Collecting reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  // The time of the run whose name starts with `prefix` (names carry /min_time:.../real_time).
  auto find = [](const std::map<std::string, double>& m, const std::string& prefix) {
    for (const auto& [name, v] : m)
      if (name.rfind(prefix, 0) == 0) return v;
    return std::nan("");
  };
  auto get = [&](const std::string& prefix) { return find(reporter.ms, prefix); };
  // CPU time of the whole process (every thread): the work, whatever else the machine runs.
  auto cpu = [&](const std::string& prefix) { return find(reporter.cpu_ms, prefix); };
  const double cv_ms = get("BM_OpenCvMergeRobertson8BitRgb/");
  const double cv_cpu = cpu("BM_OpenCvMergeRobertson8BitRgb/");
  const double ours1 = get("BM_OursMerge8BitRgb/1/");
  const double ours1_cpu = cpu("BM_OursMerge8BitRgb/1/");
  const double ours2 = get("BM_OursMerge8BitRgb/2/");
  const double ours2_cpu = cpu("BM_OursMerge8BitRgb/2/");
  const double rgb_bytes = static_cast<double>(rgb_stack().input_bytes);
  const double mono_bytes = static_cast<double>(mono_stack().input_bytes);
  std::printf("\nsummary (per 16-exposure stack; real time and CPU time of all threads of the process)\n");
  std::printf("  ours: inner loops %s; OpenCV %s with cv::getNumThreads() = %d\n", simd_name().c_str(),
              CV_VERSION, cv::getNumThreads());
  std::printf("  8-bit RGB: OpenCV MergeRobertson %.1f ms real, %.1f ms CPU\n", cv_ms, cv_cpu);
  std::printf("    ours 1 thread  %.1f ms real, %.1f ms CPU: per thread %.1fx OpenCV (CPU / CPU), %.2f GB/s of input per core\n",
              ours1, ours1_cpu, cv_cpu / ours1_cpu, rgb_bytes / ours1_cpu * 1e-6);
  std::printf("    ours 2 threads %.1f ms real, %.1f ms CPU: whole run %.1fx OpenCV (real / real; goal >= 10x)\n", ours2,
              ours2_cpu, cv_ms / ours2);
  for (const char* kind : {"Response", "ResponseDarkFlat"}) {
    const std::string base = std::string("BM_OursMerge16BitMono") + kind + "/";
    const double c1 = cpu(base + "1/");
    const double r2 = get(base + "2/");
    std::printf("  16-bit mono (%s): 1 thread %.1f ms real, %.1f ms CPU = %.2f GB/s of input per core; "
                "2 threads %.1f ms real = %.2f GB/s%s\n",
                kind, get(base + "1/"), c1, mono_bytes / c1 * 1e-6, r2, mono_bytes / r2 * 1e-6,
                std::string(kind) == "ResponseDarkFlat" ? " (goal >= 2 GB/s on 2 cores)" : "");
  }
  const double cb = cpu("BM_OursMerge16BitMonoResponseDarkFlatBaselineSimd/1/");
  std::printf("  16-bit mono (ResponseDarkFlat) with the x86-64 baseline loops: 1 thread %.1f ms CPU = %.2f GB/s per core\n",
              cb, mono_bytes / cb * 1e-6);
  const double mc = get("BM_MemcpyStack16BitMono/");
  std::printf("  memcpy of the 16-bit stack (1 thread): %.1f ms, %.2f GB/s read (%.2f GB/s read+write)\n", mc,
              mono_bytes / mc * 1e-6, 2 * mono_bytes / mc * 1e-6);
  const double bayer_bytes = static_cast<double>(bayer_stack().input_bytes);
  const double b1 = cpu("BM_OursMergeBayerRG12DemosaicMatrix/1/");
  const double b2 = get("BM_OursMergeBayerRG12DemosaicMatrix/2/");
  const double bcv = get("BM_OpenCvDemosaicMergeRobertsonBayerRG12/");
  std::printf("  BayerRG12 merge + demosaicing + colour matrix: 1 thread %.1f ms CPU = %.2f GB/s of raw input per core; "
              "2 threads %.1f ms real = %.2f GB/s (goal >= 2 GB/s on 2 cores)\n",
              b1, bayer_bytes / b1 * 1e-6, b2, bayer_bytes / b2 * 1e-6);
  std::printf("    OpenCV demosaicing + MergeRobertson (8-bit) + cv::transform: %.1f ms real = %.2f GB/s; ours %.1fx "
              "faster (real / real)\n",
              bcv, bayer_bytes / bcv * 1e-6, bcv / b2);
  benchmark::Shutdown();
  return 0;
}
