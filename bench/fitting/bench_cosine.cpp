// The cosine-lobe basis (issue 17 items 2 and 3, docs/design.md). Goals: `design` at most 10 ms
// per solve; the basis render under an environment at least 10x faster than the full model's
// environment render (render_preview, Monte Carlo with 32 samples per strategy: `paintlab
// render`'s default), both at 512 x 512 and measured in the same run, with the RMS log ratio
// between the two images per paint. The paints: the three metallics of paints/ with their
// cosine-lobe weights for the basis chosen over them (5 lobes); the sky: sun_and_sky_map(256).
//   build/bench/fitting/bench_fitting_cosine --benchmark_out=cosine.json --benchmark_out_format=json
#include <benchmark/benchmark.h>

#include <chrono>
#include <filesystem>
#include <memory>

#include "paintlab/brdf/paint.h"
#include "paintlab/fitting/cosine_lobes.h"
#include "paintlab/fitting/export.h"
#include "paintlab/fitting/prefiltered_env.h"

using namespace paintlab;

namespace {

const std::filesystem::path kSource = PAINTLAB_SOURCE_DIR;
const char* const kPaints[] = {"red-metallic", "silver-metallic", "dark-metallic"};

struct Setup {
  std::vector<std::pair<std::string, std::shared_ptr<const brdf::Brdf>>> paints;
  fit::CosineBasis basis;
  std::unique_ptr<fit::EnvironmentMap> env;
  std::unique_ptr<fit::PrefilteredEnvironment> maps;
  double maps_s = 0;
};

const Setup& setup() {
  static const Setup s = [] {
    Setup s;
    for (const char* p : kPaints) {
      brdf::PaintSpec spec = brdf::load_paint_file(kSource / "paints" / (std::string(p) + ".toml"));
      spec.flakes.reset();
      s.paints.emplace_back(p, brdf::make_brdf(spec));
    }
    fit::CosineBasisOptions o;
    o.max_lobes = 5;
    o.lobes = 5;
    s.basis = fit::fit_cosine_basis(s.paints, o);
    s.env = std::make_unique<fit::EnvironmentMap>(fit::sun_and_sky_map(256), 1.0);
    const auto t0 = std::chrono::steady_clock::now();
    s.maps = std::make_unique<fit::PrefilteredEnvironment>(fit::PrefilteredEnvironment::build(*s.env, s.basis.exponents));
    s.maps_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return s;
  }();
  return s;
}

const fit::PreviewOptions kScene{.size_px = 512, .point_light = false, .environment_samples = 32};

void BM_DesignSolve(benchmark::State& state) {
  const Setup& s = setup();
  std::vector<fit::DesignTarget> targets;
  for (const auto& c : fit::colour_at(*s.paints[0].second, fit::geometry_set("five-angle")))
    targets.push_back({c.geometry, c.lab});
  for (auto _ : state) benchmark::DoNotOptimize(fit::design_paint(s.basis.exponents, targets));
  state.counters["lobes"] = static_cast<double>(s.basis.exponents.size());
  state.counters["targets"] = static_cast<double>(targets.size());
}
BENCHMARK(BM_DesignSolve)->Unit(benchmark::kMillisecond);

void BM_PrefilterMaps(benchmark::State& state) {
  const Setup& s = setup();
  for (auto _ : state) benchmark::DoNotOptimize(fit::PrefilteredEnvironment::build(*s.env, s.basis.exponents));
  state.counters["maps"] = static_cast<double>(s.basis.exponents.size() + 1);
}
BENCHMARK(BM_PrefilterMaps)->Unit(benchmark::kMillisecond)->Iterations(2);

// The basis render of one paint, the maps ready.
void BM_BasisRender(benchmark::State& state) {
  const Setup& s = setup();
  const auto fit = fit::fit_cosine_lobes(*s.paints[static_cast<std::size_t>(state.range(0))].second, s.basis.exponents);
  for (auto _ : state) benchmark::DoNotOptimize(fit::render_preview_cosine(fit.params, kScene, s.maps.get()));
  state.SetLabel(kPaints[state.range(0)]);
  state.counters["fps"] = benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_BasisRender)->DenseRange(0, 2)->Unit(benchmark::kMillisecond)->UseRealTime();

// The full model's environment render beside the basis render of the same paint, in the same
// run: speed-up and the RMS log ratio of the two images.
void BM_FullAgainstBasis(benchmark::State& state) {
  const Setup& s = setup();
  const auto& [name, model] = s.paints[static_cast<std::size_t>(state.range(0))];
  const auto fit = fit::fit_cosine_lobes(*model, s.basis.exponents);
  double full_s = 0, basis_s = 0, log_rms = 0;
  for (auto _ : state) {
    auto t0 = std::chrono::steady_clock::now();
    const fit::Preview full = fit::render_preview(*model, kScene, s.env.get());
    full_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    t0 = std::chrono::steady_clock::now();
    const fit::Preview basis = fit::render_preview_cosine(fit.params, kScene, s.maps.get());
    basis_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    log_rms = fit::preview_log_rms(basis.linear, full.linear, basis.mask);
  }
  state.SetLabel(name);
  state.counters["full_ms"] = 1000 * full_s;
  state.counters["basis_ms"] = 1000 * basis_s;
  state.counters["speedup"] = full_s / basis_s;
  state.counters["log_rms"] = log_rms;
  state.counters["fit_mean_rel_error"] = fit.mean_error;
  state.counters["maps_build_s"] = s.maps_s;
}
BENCHMARK(BM_FullAgainstBasis)->DenseRange(0, 2)->Unit(benchmark::kMillisecond)->Iterations(1)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
