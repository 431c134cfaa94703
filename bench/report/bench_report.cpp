// `paintlab report` of a full demo folder (issue 18: at most 10 s on 2 cores and at most
// 10 MB): every JSON read, the dark and flat maps and the sphere image drawn, the plots made
// by gnuplot, the pictures encoded, the page assembled. Give the folder of a full demo
// (`paintlab demo --out DIR`: 181 positions at 1360x1024):
//   PAINTLAB_BENCH_DEMO=DIR build/bench/report/bench_report --benchmark_out=report.json --benchmark_out_format=json
#include <benchmark/benchmark.h>

#include <cstdlib>
#include <filesystem>

#include "paintlab/report/report.h"

namespace fs = std::filesystem;
using namespace paintlab;

namespace {

void BM_DemoReport(benchmark::State& state) {
  const char* dir = std::getenv("PAINTLAB_BENCH_DEMO");
  if (!dir || !fs::exists(fs::path(dir) / "summary.json")) {
    state.SkipWithError("set PAINTLAB_BENCH_DEMO to the folder of a full `paintlab demo`");
    return;
  }
  const report::ReportInput in = report::classify_input(dir);
  std::size_t bytes = 0;
  for (auto _ : state) {
    const report::Report r = report::make_report(in);
    bytes = r.html.size();
    benchmark::DoNotOptimize(r.html.data());
  }
  state.counters["page_MB"] = static_cast<double>(bytes) / (1 << 20);
}
BENCHMARK(BM_DemoReport)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(3);

}  // namespace

BENCHMARK_MAIN();
