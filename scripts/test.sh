#!/usr/bin/env bash
# Sets up (Debian packages), builds and runs the whole test suite: unit, integration, e2e.
# Usage: bash scripts/test.sh [extra ctest arguments]
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
BUILD=${PAINTLAB_BUILD_DIR:-build}
JOBS=${PAINTLAB_JOBS:-$(nproc)}
# RelWithDebInfo with line tables only (-g1): backtraces keep file:line, and the build takes
# about a third less time than with full debug info (-g).
cmake -S . -B "$BUILD" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O2 -g1 -DNDEBUG" \
      "-DCMAKE_C_FLAGS_RELWITHDEBINFO=-O2 -g1 -DNDEBUG" -DPAINTLAB_WERROR=ON >/dev/null
cmake --build "$BUILD" -j "$JOBS"
echo "(build done: $(date +%T))"
ctest --test-dir "$BUILD" -j "$JOBS" --output-on-failure --no-label-summary "$@"
