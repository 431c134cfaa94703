// Designing paints (issue 17): Golla and Klein's interpolation of metallic car paints. Goals:
// two paints' interpolatable material (the optimal transports of every flake slice) at most
// 0.5 s, three paints at most 1 s (their Python: 50 s and 103 s), a realisation at most 1 ms.
// The paints: the full 12 x 12 slice layout, every slice with 50 colour clusters (the most
// `paintlab flakes` keeps), so each slice's transport is the largest one measured paints give.
//   build/bench/fitting/bench_fitting_interpolate --benchmark_out=interpolate.json --benchmark_out_format=json
#include <benchmark/benchmark.h>

#include <algorithm>
#include <random>

#include "paintlab/fitting/interpolate.h"

using namespace paintlab;

namespace {

fit::AxfPaint synthetic_paint(const std::string& name, double hue, std::uint64_t seed) {
  fit::AxfPaint p;
  p.name = name;
  p.model = "cook-torrance";
  p.colour_space = colour::kLinearSrgb;
  fit::AxfCookTorrance ct;
  ct.params.kd = brdf::Rgb(0.03, 0.032, 0.035);
  ct.params.lobes = {{brdf::Rgb(0.06, 0.062, 0.066), 0.38, 0.85}, {brdf::Rgb(0.045, 0.046, 0.048), 0.16, 0.55},
                     {brdf::Rgb(0.15, 0.15, 0.15), 0.015, 0.04}};
  p.cook_torrance = ct;
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> d(0.0, 8.0);
  std::uniform_real_distribution<double> u(0.1, 1.0);
  fit::FlakeStats fs;
  fs.colour_space = colour::kLinearSrgb;
  fs.lifetime_deg = 5.0;
  for (int i = 0; i < fs.options.num_theta_i; ++i)
    for (int f = 0; f < fs.options.num_theta_f; ++f) {
      fit::FlakeSlice s;
      s.theta_f = f;
      s.theta_i = i;
      s.pixels = 100000;
      s.glints = 5000;
      s.intensity_mean = 3.0;
      s.glint_model_y = 0.2;
      s.lifetime_deg = 5.0;
      double total = 0.0;
      for (int k = 0; k < fs.options.clusters; ++k) {
        fit::FlakeCluster c;
        c.mean = {120 + d(rng), hue + d(rng), -hue + d(rng)};
        c.lo = {c.mean.L - 3, c.mean.a - 2, c.mean.b - 2};
        c.hi = {c.mean.L + 3, c.mean.a + 2, c.mean.b + 2};
        c.probability = u(rng);
        total += c.probability;
        s.clusters.push_back(c);
      }
      for (fit::FlakeCluster& c : s.clusters) c.probability /= total;
      std::sort(s.clusters.begin(), s.clusters.end(),
                [](const fit::FlakeCluster& x, const fit::FlakeCluster& y) { return x.probability > y.probability; });
      s.inverse_cdf = fit::flake_inverse_cdf(s.clusters, fs.options.cdf_steps);
      fs.pixels += s.pixels;
      fs.glints += s.glints;
      fs.slices.push_back(std::move(s));
    }
  fs.instrument = {{15, 400, 40, 10.0, 2.5}, {45, 300, 3, 1.0, 1.2}, {75, 300, 0, 0.0, 0.0}};
  p.flake_stats = fs;
  return p;
}

void BM_InterpolatableTwoPaints(benchmark::State& state) {
  const fit::AxfPaint a = synthetic_paint("a", 3.0, 1), b = synthetic_paint("b", 15.0, 2);
  for (auto _ : state) benchmark::DoNotOptimize(fit::interpolatable_paint(a, b));
  state.counters["slices"] = static_cast<double>(a.flake_stats->slices.size());
}
BENCHMARK(BM_InterpolatableTwoPaints)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_InterpolateThreePaints(benchmark::State& state) {
  const fit::AxfPaint a = synthetic_paint("a", 3.0, 1), b = synthetic_paint("b", 15.0, 2),
                      c = synthetic_paint("c", -10.0, 3);
  for (auto _ : state) benchmark::DoNotOptimize(fit::interpolate_paints({a, b, c}, {0.4, 0.3, 0.3}));
}
BENCHMARK(BM_InterpolateThreePaints)->Unit(benchmark::kMillisecond)->UseRealTime();

// A realisation of the statistics (what a slider drags), and with the flake BTF drawn
// (32 x 32 texels a slice: what a file written needs).
void BM_Realise(benchmark::State& state) {
  const fit::AxfPaint a = synthetic_paint("a", 3.0, 1), b = synthetic_paint("b", 15.0, 2);
  const fit::InterpolatablePaint m = fit::interpolatable_paint(a, b);
  const bool btf = state.range(0) != 0;
  double t = 0.0;
  for (auto _ : state) {
    t = t > 1.0 ? 0.0 : t + 0.01;
    benchmark::DoNotOptimize(fit::realise(m, 1.0 - t, t, btf));
  }
}
BENCHMARK(BM_Realise)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
