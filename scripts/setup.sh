#!/usr/bin/env bash
# Installs every Debian bookworm package paintlab needs to build, test and run.
# Idempotent: when everything is present it prints one line and changes nothing.
# Usage: bash scripts/setup.sh   (as root, or with sudo available)
set -euo pipefail

packages=(
  # toolchain
  build-essential cmake ninja-build pkg-config git
  # libraries the code links
  libeigen3-dev libopencv-dev libceres-dev libtbb-dev
  libmodbus-dev libgpiod-dev libaravis-dev libusb-1.0-0-dev
  libopenexr-dev libimath-dev libhdf5-dev
  libtomlplusplus-dev nlohmann-json3-dev libcli11-dev libspdlog-dev libfmt-dev libexpected-dev
  libssl-dev
  # colour science (LittleCMS 2) and the ColorChecker reference values (CGATS)
  liblcms2-dev argyll-ref
  # tests and benchmarks
  libgtest-dev libgmock-dev googletest libbenchmark-dev
  # fuzzing (scripts/fuzz.sh): clang with the libFuzzer and sanitizer runtimes
  clang libclang-rt-14-dev
  # test peers: Aravis fake camera, pty pairs, USB descriptors, an independent Modbus stack,
  # OpenCV's sample chessboard photos
  # (arv-fake-gv-camera-0.8 is in aravis-tools, arv-tool-0.8 in aravis-tools-cli; pymodbus.server
  # imports serial_asyncio)
  aravis-tools aravis-tools-cli socat umockdev libumockdev-dev python3-pymodbus python3-serial python3-serial-asyncio
  opencv-doc
  # reports (paintlab report): gnuplot's SVG terminal draws the plots; the report test loads the
  # page in Debian's headless Chromium
  gnuplot-nox chromium
  # sparkle (fitting/flakes.h): LEMON's network simplex for the exact transport between flake
  # colour distributions (the earth mover's distance of docs/sparkle.md)
  liblemon-dev
)

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q '^install ok installed$'; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#packages[@]} packages present"
  exit 0
fi

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
echo "setup: installing ${#missing[@]} packages: ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
echo "setup: done"
