// Simulator throughput on the reference rig (examples/rig-sim.toml: 1360 x 1024, 50 mm):
//   radiance pass of a sphere frame (frames/s, per core), sensor pass of one exposure (GB/s),
//   and the one-off costs (scene geometry, a sparkling paint's flake field).
// Run: build/bench/sim/bench_sim_render [--benchmark_filter=...]
// "threads" is the number of worker threads the pass uses; frames/s per core = fps / threads.
#include <benchmark/benchmark.h>

#include <map>
#include <memory>

#include "paintlab/core/rig.h"
#include "paintlab/sim/paint.h"
#include "paintlab/sim/world.h"

using namespace paintlab;

namespace {

const std::filesystem::path kSource = PAINTLAB_SOURCE_DIR;

sim::SimConfig reference_config() { return sim::SimConfig::from_rig(RigConfig::load(kSource / "examples/rig-sim.toml")); }

sim::SimWorld& world_with(const std::string& paint_file) {
  static std::map<std::string, std::unique_ptr<sim::SimWorld>> worlds;
  auto& w = worlds[paint_file];
  if (!w) {
    w = std::make_unique<sim::SimWorld>(reference_config());
    w->set_paint(sim::load_sim_paint(kSource / "paints" / paint_file));
  }
  return *w;
}

void radiance_pass(benchmark::State& state, const std::string& paint_file, bool sparkle) {
  sim::SimWorld& world = world_with(paint_file);
  sim::RenderOptions opt;
  opt.threads = static_cast<int>(state.range(0));
  opt.sparkle = sparkle;
  double angle = 0;
  for (auto _ : state) {
    ImageF img = world.render_at(angle, true, opt);
    benchmark::DoNotOptimize(img.data());
    angle = angle >= 180 ? 0 : angle + 1;
  }
  state.SetItemsProcessed(state.iterations());  // frames
  state.counters["frames_per_s_per_core"] =
      benchmark::Counter(static_cast<double>(state.iterations()) / static_cast<double>(opt.threads),
                         benchmark::Counter::kIsRate);
}

void BM_RadianceCookTorranceSparkle(benchmark::State& s) { radiance_pass(s, "silver-metallic.toml", true); }
void BM_RadianceCookTorranceSmooth(benchmark::State& s) { radiance_pass(s, "silver-metallic.toml", false); }
void BM_RadianceSolid(benchmark::State& s) { radiance_pass(s, "solid-blue.toml", true); }
void BM_RadiancePearlescent(benchmark::State& s) { radiance_pass(s, "pearlescent.toml", true); }

// The sensor pass on a radiance image. Pixels below 20 mean electrons take the exact
// Poisson sampler (a CDF inversion), brighter ones one Gaussian deviate.
void sensor_pass(benchmark::State& state, const ImageF& radiance, sim::SimWorld& world) {
  sim::ExposureSettings e;
  e.exposure_s = 0.02;
  e.output_bits = 16;
  const int threads = static_cast<int>(state.range(0));
  for (auto _ : state) {
    auto raw = world.sensor().expose(radiance, e, threads);
    benchmark::DoNotOptimize(raw.data());
  }
  // Per pixel: radiance (4 B) and gain map (4 B) read, raw value (2 B) written.
  state.SetBytesProcessed(state.iterations() * static_cast<std::int64_t>(radiance.pixel_count()) * 10);
  state.SetItemsProcessed(state.iterations());
  state.counters["GB_per_s_per_core"] = benchmark::Counter(
      static_cast<double>(state.iterations()) * static_cast<double>(radiance.pixel_count()) * 10 / 1e9 / threads,
      benchmark::Counter::kIsRate);
  state.counters["ns_per_pixel"] = benchmark::Counter(
      static_cast<double>(state.iterations()) * static_cast<double>(radiance.pixel_count()) * 1e-9 / threads,
      benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

// A sphere frame: mostly dark felt (a few electrons: the Poisson path).
void BM_SensorPass(benchmark::State& state) {
  sim::SimWorld& world = world_with("silver-metallic.toml");
  sensor_pass(state, world.render_at(30.0, true), world);
}

// A bright uniform field (about 9000 electrons everywhere: the Gaussian path).
void BM_SensorPassBright(benchmark::State& state) {
  sim::SimWorld& world = world_with("silver-metallic.toml");
  double g = world.sensor().electrons_per_s_per_radiance(680, 512);
  sensor_pass(state, ImageF(1360, 1024, 1, static_cast<float>(9000.0 / (g * 0.02))), world);
}

void BM_SceneSetup(benchmark::State& state) {
  sim::SimConfig cfg = reference_config();
  for (auto _ : state) {
    sim::SimWorld world(cfg);
    benchmark::DoNotOptimize(&world);
  }
}

void BM_SparklingPaintSetup(benchmark::State& state) {
  sim::SimWorld world(reference_config());
  sim::SimPaint paint = sim::load_sim_paint(kSource / "paints/silver-metallic.toml");
  for (auto _ : state) world.set_paint(paint);
}

}  // namespace

BENCHMARK(BM_RadianceCookTorranceSparkle)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_RadianceCookTorranceSmooth)->Arg(1)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_RadianceSolid)->Arg(1)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_RadiancePearlescent)->Arg(1)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_SensorPass)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_SensorPassBright)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_SceneSetup)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_SparklingPaintSetup)->Unit(benchmark::kMillisecond)->UseRealTime();

BENCHMARK_MAIN();
