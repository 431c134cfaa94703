# Small helpers so every module is declared the same way (COLMAP's CMakeHelper style).

add_library(paintlab_warnings INTERFACE)
target_compile_options(paintlab_warnings INTERFACE -Wall -Wextra -Wpedantic)
if(PAINTLAB_WERROR)
  target_compile_options(paintlab_warnings INTERFACE -Werror)
endif()
if(PAINTLAB_UNITY_BUILD AND CMAKE_CXX_COMPILER_ID STREQUAL "GNU")
  # In a unity batch every .cpp but the batch file counts as a header for GCC, so a class
  # with a member or base from its own file's anonymous namespace (a test fixture, an Impl)
  # is reported as if a header leaked an internal type; it does not in a unity build.
  target_compile_options(paintlab_warnings INTERFACE -Wno-subobject-linkage)
endif()
if(PAINTLAB_FUZZ)
  # Every library instrumented for libFuzzer's coverage (the harnesses add its main) and
  # checked by ASan+UBSan: this is also the sanitizer build of .ci/run, whose test programs
  # link the same libraries (ASan's runtime serves the coverage hooks without libFuzzer).
  add_compile_options(-fsanitize=fuzzer-no-link
                      -fsanitize-coverage-ignorelist=${PROJECT_SOURCE_DIR}/tests/fuzz/coverage-ignore.txt)
  set(PAINTLAB_SANITIZE ON)
endif()
if(PAINTLAB_SANITIZE)
  add_compile_options(-fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined)
  # GCC 12 reports false maybe-uninitialized warnings inside libstdc++'s std::regex /
  # std::function under sanitizer instrumentation: keep them visible, not fatal.
  if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU")
    target_compile_options(paintlab_warnings INTERFACE -Wno-error=maybe-uninitialized)
  endif()
  add_link_options(-fsanitize=address,undefined)
  # Eigen picks its allocator at compile time: under ASan (__SANITIZE_ADDRESS__) it falls back
  # to a hand-made aligned malloc that offsets the pointer, while Debian's uninstrumented
  # libceres.a uses plain malloc. An Eigen object allocated on one side and freed on the other
  # (Ceres' covariance through BDCSVD) is then an invalid free. glibc's and ASan's allocators
  # both return 16-byte aligned blocks on x86-64, so tell Eigen so and both sides agree.
  add_compile_definitions(EIGEN_MALLOC_ALREADY_ALIGNED=1)
endif()

# paintlab_add_library(<module> SOURCES ... [DEPS ...] [PRIVATE_DEPS ...])
# Creates target paintlab_<module> with public headers in <module>/include.
# DEPS are the module's allowed public dependencies (DESIGN.md's graph).
function(paintlab_add_library module)
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS;PRIVATE_DEPS" ${ARGN})
  set(target paintlab_${module})
  add_library(${target} STATIC ${ARG_SOURCES})
  target_include_directories(${target}
    PUBLIC ${CMAKE_CURRENT_SOURCE_DIR}/include
    PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/src)
  target_link_libraries(${target} PUBLIC ${ARG_DEPS} PRIVATE ${ARG_PRIVATE_DEPS} paintlab_warnings)
  set_target_properties(${target} PROPERTIES POSITION_INDEPENDENT_CODE ON)
endfunction()

# paintlab_add_test(<name> SOURCES ... [DEPS ...] [LABELS ...] [TIMEOUT s]
#                   [RESOURCE_LOCK lock...] [RUN_SERIAL])
# One GoogleTest executable; every TEST becomes one ctest test carrying LABELS.
function(paintlab_add_test name)
  cmake_parse_arguments(ARG "RUN_SERIAL" "TIMEOUT" "SOURCES;DEPS;LABELS;RESOURCE_LOCK" ${ARGN})
  if(NOT ARG_TIMEOUT)
    set(ARG_TIMEOUT 120)
  endif()
  if(NOT ARG_LABELS)
    set(ARG_LABELS unit)
  endif()
  set(target test_${name})
  add_executable(${target} ${ARG_SOURCES})
  target_link_libraries(${target} PRIVATE ${ARG_DEPS} paintlab_test_support paintlab_warnings)
  # A test program's own sources (assertions, gtest and gmock templates) compile at -O1 in the
  # optimised builds: a quarter less compile time than -O2 (test_acquisition's largest batch
  # 23.6 -> 17.9 s, 2026-12-06), and the work they test is in the libraries, built at -O2.
  target_compile_options(${target} PRIVATE $<$<CONFIG:RelWithDebInfo,Release>:-O1>)
  # PAINTLAB_BUILD_SLOW_TESTS=OFF (the sanitizer build of .ci/run, which runs only the unit and
  # integration tests not labelled slow) leaves the slow and e2e programs out of the default
  # build and out of ctest; they run in the normal build.
  if(NOT PAINTLAB_BUILD_SLOW_TESTS AND ("slow" IN_LIST ARG_LABELS OR "e2e" IN_LIST ARG_LABELS))
    set_target_properties(${target} PROPERTIES EXCLUDE_FROM_ALL ON)
    return()
  endif()
  # Several labels (e.g. "unit slow") must reach set_tests_properties as ONE list value;
  # gtest_discover_tests (CMake 3.25) unescapes the properties three times on the way, so
  # each ';' needs 8 backslashes here. Checked with ctest -N -L slow / -LE slow.
  string(REPLACE ";" "\\\\\\\\\\\\\\\\;" _labels "${ARG_LABELS}")
  set(props LABELS "${_labels}" TIMEOUT ${ARG_TIMEOUT} SKIP_RETURN_CODE 77)
  if(ARG_RESOURCE_LOCK)
    list(APPEND props RESOURCE_LOCK "${ARG_RESOURCE_LOCK}")
  endif()
  if(ARG_RUN_SERIAL)
    list(APPEND props RUN_SERIAL TRUE)
  endif()
  # The long programs (slow, e2e: 20-100 s a test) start first: ctest schedules by COST, and in
  # a fresh build folder (no cost data yet) it would start them last, by number, leaving one core
  # idle while the last of them runs (70-100 s of a CI run's tail, measured 2026-12-06).
  if("slow" IN_LIST ARG_LABELS OR "e2e" IN_LIST ARG_LABELS)
    list(APPEND props COST 1000)
  endif()
  gtest_discover_tests(${target}
    TEST_PREFIX "${name}."
    DISCOVERY_MODE PRE_TEST
    DISCOVERY_TIMEOUT 30
    PROPERTIES ${props})
endfunction()

# paintlab_add_bench(<name> SOURCES ... [DEPS ...]): a Google Benchmark program (not in ctest).
function(paintlab_add_bench name)
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS" ${ARGN})
  add_executable(bench_${name} ${ARG_SOURCES})
  target_link_libraries(bench_${name} PRIVATE ${ARG_DEPS} benchmark::benchmark paintlab_warnings)
endfunction()

# add_subdirectory() for every folder below the current source folder that has a
# CMakeLists.txt (tests/integration/<area>, tests/e2e/<area>, bench/<module>); a new folder
# is picked up at the next configure.
function(paintlab_add_subfolders)
  file(GLOB _folders LIST_DIRECTORIES true CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/*)
  foreach(folder ${_folders})
    if(IS_DIRECTORY ${folder} AND EXISTS ${folder}/CMakeLists.txt)
      add_subdirectory(${folder})
    endif()
  endforeach()
endfunction()
