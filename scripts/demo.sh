#!/usr/bin/env bash
# Sets up (Debian packages), builds paintlab and runs the simulated rig end to end.
# Usage: bash scripts/demo.sh [OUT_DIR] [extra demo options, e.g. --quick]
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
BUILD=${PAINTLAB_BUILD_DIR:-build}
cmake -S . -B "$BUILD" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo >/dev/null
cmake --build "$BUILD" -j "$(nproc)" --target paintlab
OUT=${1:-demo-out}
shift || true
"$BUILD/app/paintlab" demo --out "$OUT" "$@"
