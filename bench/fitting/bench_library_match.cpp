// `paintlab library match` on a library of 10,000 paints (issue 15: under 1 s): the index read
// and parsed, every entry's stored five-angle CIELAB compared with the target by CIEDE2000, the
// ranking sorted. The library is an index.json written as `library add` leaves it (format 2),
// its entries' colours drawn around a silver metallic and a red; no paint file is opened, as
// for a library of version-2 entries.
//   build/bench/fitting/bench_library_match --benchmark_out=match.json --benchmark_out_format=json
#include <benchmark/benchmark.h>

#include <filesystem>
#include <random>

#include <fmt/format.h>

#include "paintlab/brdf/brdf.h"
#include "paintlab/core/json.h"
#include "paintlab/fitting/multiangle.h"
#include "paintlab/fitting/paint_library.h"

namespace fs = std::filesystem;
using namespace paintlab;

namespace {

fs::path make_library(std::size_t paints) {
  const fs::path dir = fs::temp_directory_path() / fmt::format("paintlab-bench-library-{}", paints);
  fs::create_directories(dir);
  std::mt19937_64 rng(7);
  std::normal_distribution<double> g(0.0, 1.0);
  const auto geometries = fit::geometry_set(fit::kDefaultGeometrySet);
  Json entries = Json::array();
  for (std::size_t i = 0; i < paints; ++i) {
    fit::LibraryEntry e;
    e.name = fmt::format("paint-{:05d}", i);
    e.file = e.name + ".1.axf.h5";
    e.sha256 = std::string(64, '0');
    e.model = "cook-torrance";
    e.date = e.added_utc = "2026-12-03T00:00:00Z";
    const double L0 = 30.0 + 60.0 * std::abs(g(rng)) / 3.0, a0 = 20.0 * g(rng), b0 = 20.0 * g(rng);
    for (std::size_t k = 0; k < geometries.size(); ++k) {
      const double flop = 1.0 - 0.15 * static_cast<double>(k);
      e.colour.push_back({geometries[k].name, colour::Lab{L0 * flop, a0 * flop, b0 * flop}});
    }
    entries.push_back(e.to_json());
  }
  write_json_file(dir / fit::kLibraryIndexFile, Json{{"format", fit::kLibraryFormat},
                                                     {"format_version", fit::kLibraryFormatVersion},
                                                     {"next_id", paints + 1},
                                                     {"paints", entries}});
  return dir;
}

void BM_LibraryMatch(benchmark::State& state) {
  const std::size_t n = static_cast<std::size_t>(state.range(0));
  const fs::path dir = make_library(n);
  const auto geometries = fit::geometry_set(fit::kDefaultGeometrySet);
  fit::MultiAngleColour target;
  target.paint = "target";
  target.model = fit::colour_at(brdf::Lambertian(brdf::Rgb(0.4, 0.3, 0.2)), geometries);
  std::size_t compared = 0;
  for (auto _ : state) {
    const fit::PaintLibrary lib = fit::PaintLibrary::open(dir, false);
    const fit::LibraryMatchResult r = fit::library_match(lib, target, geometries);
    compared = r.matches.size();
    benchmark::DoNotOptimize(r.matches.front().worst_de00);
  }
  state.counters["paints"] = static_cast<double>(compared);
  fs::remove_all(dir);
}
BENCHMARK(BM_LibraryMatch)->Arg(10000)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
