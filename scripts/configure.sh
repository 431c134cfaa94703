#!/usr/bin/env bash
# Configures the one build folder that scripts/demo.sh and scripts/test.sh share, with one
# set of flags, so whichever runs second builds only what the first did not (the demo builds
# `paintlab`, the tests add the test programs). Sourced by both; sets BUILD and JOBS.
# RelWithDebInfo with line tables only (-g1): backtraces keep file:line, and the build takes
# about a third less time than with full debug info (-g). Warnings are errors in every build.
BUILD=${PAINTLAB_BUILD_DIR:-build}
JOBS=${PAINTLAB_JOBS:-$(nproc)}
cmake -S . -B "$BUILD" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
      "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O2 -g1 -DNDEBUG" "-DCMAKE_C_FLAGS_RELWITHDEBINFO=-O2 -g1 -DNDEBUG" \
      -DPAINTLAB_WERROR=ON >/dev/null
