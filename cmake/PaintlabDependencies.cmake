# Every external dependency of paintlab, found once. scripts/setup.sh installs them
# (Debian bookworm packages).
find_package(PkgConfig REQUIRED)
find_package(Threads REQUIRED)
find_package(Eigen3 3.4 REQUIRED NO_MODULE)
find_package(fmt REQUIRED)
find_package(spdlog REQUIRED)
find_package(nlohmann_json 3.10 REQUIRED)
find_package(tomlplusplus REQUIRED)
find_package(CLI11 CONFIG QUIET)
if(NOT CLI11_FOUND)
  # Debian's libcli11-dev ships pkg-config data; the headers are all that is needed.
  find_path(CLI11_INCLUDE_DIR CLI/CLI.hpp REQUIRED)
  add_library(CLI11::CLI11 INTERFACE IMPORTED)
  target_include_directories(CLI11::CLI11 INTERFACE ${CLI11_INCLUDE_DIR})
endif()
find_path(TL_EXPECTED_INCLUDE_DIR tl/expected.hpp REQUIRED)
add_library(paintlab_tl_expected INTERFACE)
target_include_directories(paintlab_tl_expected INTERFACE ${TL_EXPECTED_INCLUDE_DIR})
find_package(OpenSSL REQUIRED)  # SHA-256 of data files
find_package(OpenEXR 3 REQUIRED)
find_package(Imath REQUIRED)
find_package(OpenCV 4 REQUIRED COMPONENTS core imgproc imgcodecs calib3d features2d photo mcc)
find_package(TBB REQUIRED)
find_package(Ceres 2 REQUIRED)
find_package(HDF5 REQUIRED COMPONENTS C)
# LEMON (liblemon-dev): the network simplex of the flake colour transport (header-only parts)
# and its LP interface, which Debian builds over GLPK (lemon/config.h: LEMON_DEFAULT_LP GLPK):
# the cosine-lobe fits and the paint design. The shared library, because it carries its GLPK
# dependency (libglpk.so.40); the static one named by lemonConfig.cmake would need GLPK's
# development package for -lglpk.
find_package(lemon REQUIRED CONFIG)
find_library(PAINTLAB_LEMON_SHARED NAMES liblemon.so lemon REQUIRED)
add_library(paintlab_lemon_lp INTERFACE)
target_link_libraries(paintlab_lemon_lp INTERFACE ${PAINTLAB_LEMON_SHARED})
pkg_check_modules(MODBUS REQUIRED IMPORTED_TARGET libmodbus>=3.1)
pkg_check_modules(GPIOD REQUIRED IMPORTED_TARGET libgpiod>=1.6)
if(GPIOD_VERSION VERSION_GREATER_EQUAL 2.0)
  message(FATAL_ERROR "libgpiod ${GPIOD_VERSION} found; the GpiodLight adapter is written for the v1 API (1.6)")
endif()
pkg_check_modules(ARAVIS REQUIRED IMPORTED_TARGET aravis-0.8)
pkg_check_modules(LIBUSB REQUIRED IMPORTED_TARGET libusb-1.0)
pkg_check_modules(LCMS2 REQUIRED IMPORTED_TARGET lcms2>=2.9)  # colour science: CIELAB, CIEDE2000, Bradford, CGATS
if(PAINTLAB_BUILD_TESTS)
  find_package(GTest REQUIRED)
endif()
if(PAINTLAB_BUILD_BENCH)
  find_package(benchmark REQUIRED)
endif()
