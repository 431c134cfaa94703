#!/usr/bin/env bash
# Builds the libFuzzer harnesses of tests/fuzz with clang (ASan+UBSan) and runs each for
# SECONDS (default 30) on a corpus seeded from the project's own files; fails on the first
# crash, sanitizer report, leak or hang (libFuzzer writes the input as crash-*/leak-*/timeout-*
# into build-fuzz/findings/HARNESS/).
# Usage: bash scripts/fuzz.sh [SECONDS] [HARNESS...]   (harnesses: rig_toml paint_toml
#        records_json exr merl axf colour_toml; default all). Set up with scripts/setup.sh first.
#        PAINTLAB_FUZZ_BUILD_DIR picks the build folder (default build-fuzz);
#        PAINTLAB_FUZZ_ARGS adds libFuzzer flags (long runs: "-runs=1000000 -detect_leaks=0").
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-30}
shift || true
harnesses=("$@")
[ ${#harnesses[@]} -gt 0 ] || harnesses=(rig_toml paint_toml records_json exr merl axf colour_toml)
BUILD=${PAINTLAB_FUZZ_BUILD_DIR:-build-fuzz}
# A folder already configured with PAINTLAB_FUZZ=ON (.ci/run's sanitizer build, which also
# holds the test programs) is used as it is; otherwise a fuzz-only build is configured.
if ! grep -qs '^PAINTLAB_FUZZ:BOOL=ON$' "$BUILD/CMakeCache.txt"; then
  CC=clang CXX=clang++ cmake -S . -B "$BUILD" -G Ninja -DCMAKE_BUILD_TYPE=Debug \
    "-DCMAKE_CXX_FLAGS_DEBUG=-O1 -g1" "-DCMAKE_C_FLAGS_DEBUG=-O1 -g1" -DPAINTLAB_FUZZ=ON \
    -DPAINTLAB_BUILD_TESTS=OFF -DPAINTLAB_BUILD_BENCH=OFF >/dev/null
fi
targets=()
for h in "${harnesses[@]}"; do targets+=("fuzz_$h"); done
cmake --build "$BUILD" -j "${PAINTLAB_JOBS:-$(nproc)}" --target "${targets[@]}"

seed_files() {  # the project's own files of each kind
  case "$1" in
    rig_toml) ls examples/*.toml ;;
    paint_toml) ls paints/*.toml ;;
    *) ;;
  esac
}
# One harness: its corpus seeded, then libFuzzer for $seconds s; what it found (or its stats)
# goes to $BUILD/fuzz_$h.summary, its exit status is the harness's.
run_one() {
  local h=$1 corpus="$BUILD/corpus/$1" findings="$BUILD/findings/$1"
  mkdir -p "$corpus" "$findings"
  [ -d "tests/fuzz/seeds/$h" ] && cp -n tests/fuzz/seeds/"$h"/* "$corpus"/ 2>/dev/null || true
  for f in $(seed_files "$h"); do cp -n "$f" "$corpus"/; done
  {
    echo "== fuzz_$h: ${seconds} s on $(ls "$corpus" | wc -l) inputs =="
    # detect_leaks: a leak is a finding (tests/fuzz/lsan.supp: the third-party ones, with why). -malloc_limit_mb bounds one allocation, -rss_limit_mb the process (ASan keeps freed memory);
    # -timeout: an input that takes over 10 s is a hang.
    if ! ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 LSAN_OPTIONS=suppressions=$PWD/tests/fuzz/lsan.supp UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
         "$BUILD/tests/fuzz/fuzz_$h" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=4096 -malloc_limit_mb=2048 \
         -print_final_stats=1 -artifact_prefix="$findings/" ${PAINTLAB_FUZZ_ARGS:-} "$corpus" 2>"$BUILD/fuzz_$h.log"; then
      echo "fuzz_$h: FOUND A PROBLEM (input in $findings/); the end of its log:"
      tail -40 "$BUILD/fuzz_$h.log"
      return 1
    fi
    grep -E 'stat::number_of_executed_units|stat::peak_rss_mb' "$BUILD/fuzz_$h.log" | tr '\n' ' '
    echo
  } >"$BUILD/fuzz_$h.summary" 2>&1
}

# The harnesses run side by side, PAINTLAB_FUZZ_JOBS at a time (default: one a core; libFuzzer
# uses one core), so each still gets its full $seconds; their summaries print in order.
jobs_max=${PAINTLAB_FUZZ_JOBS:-$(nproc)}
pids=()
for h in "${harnesses[@]}"; do
  while [ "$(jobs -rp | wc -l)" -ge "$jobs_max" ]; do sleep 1; done
  rm -f "$BUILD/fuzz_$h.status"
  ( if run_one "$h"; then echo 0; else echo 1; fi >"$BUILD/fuzz_$h.status" ) &
  pids+=($!)
done
wait "${pids[@]}" || true
status=0
for h in "${harnesses[@]}"; do
  cat "$BUILD/fuzz_$h.summary" 2>/dev/null || echo "fuzz_$h: no summary (the run did not finish)"
  [ "$(cat "$BUILD/fuzz_$h.status" 2>/dev/null)" = 0 ] || status=1
done
exit $status
