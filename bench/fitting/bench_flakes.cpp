// Sparkle (issue 16): flake extraction of a full session, at most 30 s on 2 cores (reported
// as pixels per second: every image pixel read, and the sphere pixels compared with the
// model), and a 512 x 512 preview rendered with the measured flakes (frames per second;
// "interactive" means several a second), against the same preview without them in the same
// run. Give the folder of a full demo (`paintlab demo --out DIR`: 181 positions at
// 1360x1024) and its flakes:
//   PAINTLAB_BENCH_DEMO=DIR build/bench/fitting/bench_flakes --benchmark_out=flakes.json --benchmark_out_format=json
#include <benchmark/benchmark.h>

#include <cstdlib>
#include <filesystem>

#include "paintlab/acquisition/session.h"
#include "paintlab/acquisition/session_reader.h"
#include "paintlab/core/json.h"
#include "paintlab/fitting/export.h"
#include "paintlab/fitting/flakes.h"
#include "paintlab/fitting/preview.h"

namespace fs = std::filesystem;
using namespace paintlab;

namespace {

const char* demo_dir(benchmark::State& state) {
  const char* dir = std::getenv("PAINTLAB_BENCH_DEMO");
  if (!dir || !fs::exists(fs::path(dir) / "session") || !fs::exists(fs::path(dir) / "fit.json")) {
    state.SkipWithError("set PAINTLAB_BENCH_DEMO to the folder of a full `paintlab demo`");
    return nullptr;
  }
  return dir;
}

void BM_SessionFlakes(benchmark::State& state) {
  const char* dir = demo_dir(state);
  if (!dir) return;
  fit::SessionFlakeOptions o;
  o.fit_file = fs::path(dir) / "fit.json";
  const acq::SessionDir session = acq::SessionDir::open(fs::path(dir) / "session");
  const auto model = brdf::make_brdf(fit::load_any_paint(o.fit_file).paint_spec());
  fit::FlakeStats s;
  for (auto _ : state) {
    s = fit::session_flakes(session, *model, o.flakes, o.extraction);
    benchmark::DoNotOptimize(s.glints);
  }
  const calib::RigCalibration cal = acq::session_calibration(session, std::nullopt);
  const double image_px = static_cast<double>(s.images) * cal.camera().width_px * cal.camera().height_px;
  state.counters["images"] = static_cast<double>(s.images);
  state.counters["image_px_per_s"] = benchmark::Counter(image_px, benchmark::Counter::kIsIterationInvariantRate);
  state.counters["sphere_px_per_s"] =
      benchmark::Counter(static_cast<double>(s.pixels), benchmark::Counter::kIsIterationInvariantRate);
  state.counters["glints"] = static_cast<double>(s.glints);
}
BENCHMARK(BM_SessionFlakes)->Unit(benchmark::kSecond)->UseRealTime()->Iterations(1);

// The preview with and without the flakes measured from the demo's session (one run of
// BM_SessionFlakes' extraction, made once here).
const fit::FlakeStats& demo_flakes(const char* dir) {
  static fit::FlakeStats stats = [&] {
    fit::SessionFlakeOptions o;
    o.fit_file = fs::path(dir) / "fit.json";
    return fit::session_flakes(fs::path(dir) / "session", o);
  }();
  return stats;
}

void BM_PreviewWithSparkle(benchmark::State& state) {
  const char* dir = demo_dir(state);
  if (!dir) return;
  const bool sparkle = state.range(0) != 0;
  const auto model = brdf::make_brdf(fit::load_any_paint(fs::path(dir) / "fit.json").paint_spec());
  std::optional<fit::FlakeSparkle> flakes;
  if (sparkle) flakes.emplace(demo_flakes(dir));
  fit::PreviewOptions o;
  o.size_px = 512;
  for (auto _ : state) {
    const fit::Preview p = fit::render_preview(*model, o, nullptr, flakes ? &*flakes : nullptr);
    benchmark::DoNotOptimize(p.linear.data());
  }
  state.counters["frames_per_s"] = benchmark::Counter(1.0, benchmark::Counter::kIsIterationInvariantRate);
}
BENCHMARK(BM_PreviewWithSparkle)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(2.0);

}  // namespace

BENCHMARK_MAIN();
