#!/usr/bin/env bash
# Installs what is missing, builds with warnings as errors, and runs the whole test suite twice:
# a Release build (then its install and Debian package, scripts/package_test.sh), then an
# AddressSanitizer + UndefinedBehaviorSanitizer build; then runs every fuzz target for 25 seconds
# (scripts/fuzz.sh). --fast runs the Release suite and the package test only.
set -euo pipefail
cd "$(dirname "$0")/.."

bash scripts/setup.sh
jobs=$(nproc)

run_suite() {
  local dir=$1
  shift
  cmake -S . -B "$dir" -G Ninja -DISOSLAB_WERROR=ON "$@" >/dev/null
  # The real glTF clients (Khronos validator, three.js, draco3d) and the viewer's browser driver
  # (playwright-core, for Debian's chromium), pinned in tests/encode/js.
  if [ ! -d "$dir/npm/node_modules/three" ] || [ ! -d "$dir/npm/node_modules/playwright-core" ]; then
    (cd "$dir/npm" && npm install --no-audit --no-fund --loglevel=error >/dev/null) ||
      echo "test: npm install failed; the glTF client test will skip" >&2
  fi
  cmake --build "$dir" -j "$jobs"
  (cd "$dir" && ctest --output-on-failure -j "$jobs")
}

# The module graph (docs/design.md): includes and links follow the layer rules.
bash scripts/check_layers.sh
# The kernels build and pass with only a compiler, CMake and GoogleTest: every other package is
# hidden from CMake.
hide=()
for p in fmt nlohmann_json CLI11 ZLIB PNG DCMTK draco PkgConfig benchmark tinyobjloader; do hide+=("-DCMAKE_DISABLE_FIND_PACKAGE_$p=ON"); done
cmake -S . -B build-kernels -G Ninja -DISOSLAB_WERROR=ON -DISOSLAB_KERNELS_ONLY=ON "${hide[@]}" >/dev/null
cmake --build build-kernels -j "$jobs"
(cd build-kernels && ctest --output-on-failure -j "$jobs")

# Configured for /usr, the prefix of the Debian package that scripts/package_test.sh makes.
run_suite build -DCMAKE_BUILD_TYPE=Release -DCMAKE_INSTALL_PREFIX=/usr
# The installed library as its users meet it: find_package and pkg-config consumers, the installed
# Python package, the .deb with lintian and dpkg -i.
bash scripts/package_test.sh build
if [ "${1:-}" != "--fast" ]; then
  ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1 \
    run_suite build-asan -DCMAKE_BUILD_TYPE=RelWithDebInfo -DISOSLAB_SANITIZE=ON -DISOSLAB_BUILD_BENCH=OFF
  # Every libFuzzer target for 25 seconds from its seed corpus (clang, ASan + UBSan, build-fuzz/).
  bash scripts/fuzz.sh 25
fi
