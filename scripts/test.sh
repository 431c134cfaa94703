#!/usr/bin/env bash
# Sets up (Debian packages), builds and runs the whole test suite: unit, integration, e2e.
# Usage: bash scripts/test.sh [extra ctest arguments]
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
BUILD=${PAINTLAB_BUILD_DIR:-build}
JOBS=${PAINTLAB_JOBS:-$(nproc)}
cmake -S . -B "$BUILD" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DPAINTLAB_WERROR=ON >/dev/null
cmake --build "$BUILD" -j "$JOBS"
ctest --test-dir "$BUILD" -j "$JOBS" --output-on-failure --no-label-summary "$@"
