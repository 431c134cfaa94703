// Benchmarks of fitting/ (docs/fitting.md "Performance"):
//  - binning throughput in samples per second per core, the streaming accumulator against
//    the naive one-sample-at-a-time Welford accumulation, on the same sample stream;
//  - hole filling of a table with 10 % of its valid bins measured;
//  - a 3-lobe Cook-Torrance fit of a full table (residual blocks and iterations as counters).
// Run: build-*/bench/fitting/bench_fitting [--benchmark_filter=Bin]
#include <benchmark/benchmark.h>

#include <cmath>
#include <numbers>
#include <random>

#include "paintlab/brdf/cook_torrance.h"
#include "paintlab/brdf/merl.h"
#include "paintlab/brdf/rusinkiewicz.h"
#include "paintlab/core/geometry.h"
#include "paintlab/fitting/binning.h"
#include "paintlab/fitting/ct_fit.h"
#include "paintlab/fitting/hole_fill.h"

namespace {

using namespace paintlab;

brdf::CookTorrance silver() {
  return brdf::CookTorrance(brdf::Rgb(0.030, 0.032, 0.035), {{brdf::Rgb(0.060, 0.062, 0.066), 0.38, 0.85},
                                                            {brdf::Rgb(0.045, 0.046, 0.048), 0.16, 0.55},
                                                            {brdf::Rgb(0.15, 0.15, 0.15), 0.015, 0.04}});
}

// Samples in image order, as extraction delivers them: the upper half of a 40 mm sphere
// seen from 1 m by a 50 mm lens on 6.45 um pixels, the LED 0.5 m away in the horizontal
// plane at `angles` table angles spread over 0..180 deg.
const fit::SampleBatch& image_ordered_samples() {
  static const fit::SampleBatch batch = [] {
    fit::SampleBatch b;
    const brdf::CookTorrance paint = silver();
    const double f = 50e-3 / 6.45e-6, radius = 0.04;
    const Vec3 cam(1, 0, 0);
    for (int a = 5; a <= 175; a += 10) {
      const double ang = deg_to_rad(a);
      const Vec3 led(0.5 * std::cos(ang), 0.5 * std::sin(ang), 0);
      for (int y = 200; y < 824; ++y)
        for (int x = 370; x < 990; ++x) {
          const Vec3 d = Vec3(-1, (x - 680 + 0.5) / f, -(y - 512 + 0.5) / f).normalized();
          const double bq = cam.dot(d), c = cam.squaredNorm() - radius * radius, disc = bq * bq - c;
          if (disc < 0) continue;
          const Vec3 p = cam + (-bq - std::sqrt(disc)) * d, n = p / radius;
          if (n.z() < 0.05) continue;
          const Mat3 frame = frame_from_normal(n);
          const Vec3 wi = frame.transpose() * (led - p).normalized(), wo = frame.transpose() * (cam - p).normalized();
          if (wi.z() <= 0 || wo.z() <= 0) continue;
          const brdf::HalfDiff hd = brdf::half_diff_from_directions(wi, wo);
          const brdf::Rgb v = paint.eval(wi, wo);
          const float rgb[3] = {static_cast<float>(v[0]), static_cast<float>(v[1]), static_cast<float>(v[2])};
          const float var[3] = {1e-6f, 1e-6f, 1e-6f};
          b.push_back(hd.theta_h, hd.theta_d, hd.phi_d, rgb, var);
        }
    }
    return b;
  }();
  return batch;
}

void BM_BinNaive(benchmark::State& state) {
  const fit::SampleBatch& b = image_ordered_samples();
  fit::NaiveBinAccumulator acc;
  for (auto _ : state) {
    for (std::size_t s = 0; s < b.size(); ++s) acc.add(b.theta_h[s], b.theta_d[s], b.phi_d[s], &b.value[3 * s]);
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * b.size()));
  state.counters["threads"] = 1;
}
BENCHMARK(BM_BinNaive)->Unit(benchmark::kMillisecond);

void BM_BinStreaming(benchmark::State& state) {
  const fit::SampleBatch& b = image_ordered_samples();
  fit::BinAccumulator acc;
  for (auto _ : state) {
    acc.add(b);
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * b.size()));
  state.counters["threads"] = 1;
}
BENCHMARK(BM_BinStreaming)->Unit(benchmark::kMillisecond);

void BM_BinStreamingParallel(benchmark::State& state) {
  const fit::SampleBatch& b = image_ordered_samples();
  fit::BinningOptions opt;
  opt.threads = static_cast<int>(state.range(0));
  fit::BinAccumulator acc(opt);
  for (auto _ : state) {
    acc.add_parallel(b);
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * b.size()));
  state.counters["threads"] = static_cast<double>(state.range(0));
  state.counters["samples_per_s_per_core"] = benchmark::Counter(
      static_cast<double>(state.iterations() * b.size()) / static_cast<double>(state.range(0)), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_BinStreamingParallel)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_HoleFill10Percent(benchmark::State& state) {
  const brdf::MerlTable truth = brdf::tabulate(silver());
  brdf::MerlTable sparse;
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> u(0, 1);
  for (std::size_t b = 0; b < brdf::kMerlBins; ++b)
    if (truth.state(b) == brdf::BinState::Measured && u(rng) < 0.1) sparse.set_value(b, truth.value(b), brdf::BinState::Measured);
  fit::HoleFillReport rep;
  for (auto _ : state) {
    state.PauseTiming();
    brdf::MerlTable t = sparse;
    state.ResumeTiming();
    rep = fit::fill_holes(t);
    benchmark::DoNotOptimize(t);
  }
  state.counters["measured_bins"] = static_cast<double>(rep.measured_bins);
  state.counters["filled_bins"] = static_cast<double>(rep.filled_mirror + rep.filled_pyramid);
}
BENCHMARK(BM_HoleFill10Percent)->Unit(benchmark::kMillisecond)->UseRealTime();

// The 3-lobe fit of every valid bin of a tabulated silver paint (about 1.1 M bins, 3.3 M
// residuals) with the default options (4 grid + 2 seeded starts on a 15 000-bin
// subsample, polish on all bins, covariance) on 2 threads. Goal: < 10 s (issue 7).
void BM_FitCookTorranceFullTable(benchmark::State& state) {
  const fit::FitData data = fit::prepare_fit_data(brdf::tabulate(silver()));
  fit::CtFitOptions o;
  o.threads = static_cast<int>(state.range(0));
  fit::CookTorranceFit f;
  for (auto _ : state) {
    f = fit::fit_cook_torrance(data, o);
    benchmark::DoNotOptimize(f);
  }
  state.counters["bins"] = static_cast<double>(data.bins.size());
  state.counters["residual_blocks"] = static_cast<double>(f.summary.residual_blocks);
  state.counters["iterations"] = f.summary.iterations;
  int start_iterations = 0;
  for (const fit::StartReport& s : f.summary.starts) start_iterations += s.iterations;
  state.counters["start_iterations"] = start_iterations;
  state.counters["converged"] = f.summary.converged ? 1 : 0;
  state.counters["log_rms"] = f.residual.total.log_rms;
}
BENCHMARK(BM_FitCookTorranceFullTable)->Arg(2)->Iterations(1)->Unit(benchmark::kSecond)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
