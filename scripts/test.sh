#!/usr/bin/env bash
# Sets up (Debian packages), builds and runs the whole test suite: unit, integration, e2e.
# Usage: bash scripts/test.sh [extra ctest arguments]
# Shares its build folder and flags with scripts/demo.sh (scripts/configure.sh).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
source scripts/configure.sh
cmake --build "$BUILD" -j "$JOBS"
echo "(build done: $(date +%T))"
ctest --test-dir "$BUILD" -j "$JOBS" --output-on-failure --no-label-summary "$@"
