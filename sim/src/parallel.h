#pragma once
// Row-parallel loops on a chosen number of threads (0 = all cores), so benchmarks can
// measure one core and the simulator can use every core.
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

namespace paintlab::sim::detail {

template <class F>
void parallel_rows(int rows, int threads, F&& body) {
  auto run = [&] {
    tbb::parallel_for(tbb::blocked_range<int>(0, rows, 8), [&](const tbb::blocked_range<int>& r) {
      for (int y = r.begin(); y < r.end(); ++y) body(y);
    });
  };
  if (threads == 1) {
    for (int y = 0; y < rows; ++y) body(y);
  } else if (threads > 1) {
    tbb::task_arena arena(threads);
    arena.execute(run);
  } else {
    run();
  }
}

}  // namespace paintlab::sim::detail
