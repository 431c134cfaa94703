#!/usr/bin/env bash
# Sets up (Debian packages), builds paintlab and runs the simulated rig end to end.
# Usage: bash scripts/demo.sh                      -> paintlab demo --quick --out demo-out
#        bash scripts/demo.sh OUT_DIR [OPTIONS]    -> paintlab demo --out OUT_DIR [OPTIONS] (full unless --quick)
# Shares its build folder and flags with scripts/test.sh (scripts/configure.sh).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
source scripts/configure.sh
cmake --build "$BUILD" -j "$JOBS" --target paintlab
echo "(build done: $(date +%T))"
if [ $# -eq 0 ]; then
  set -- demo-out --quick
fi
OUT=$1
shift
"$BUILD/app/paintlab" demo --out "$OUT" "$@"
