#!/usr/bin/env bash
# Sets up (Debian packages), builds paintlab and runs the simulated rig end to end.
# Usage: bash scripts/demo.sh                      -> paintlab demo --quick --out demo-out
#        bash scripts/demo.sh OUT_DIR [OPTIONS]    -> paintlab demo --out OUT_DIR [OPTIONS] (full unless --quick)
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
BUILD=${PAINTLAB_BUILD_DIR:-build}
cmake -S . -B "$BUILD" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo >/dev/null
cmake --build "$BUILD" -j "$(nproc)" --target paintlab
if [ $# -eq 0 ]; then
  set -- demo-out --quick
fi
OUT=$1
shift
"$BUILD/app/paintlab" demo --out "$OUT" "$@"
