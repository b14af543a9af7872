#!/usr/bin/env bash
# Installs what is missing, builds with warnings as errors, and runs the whole test suite twice:
# a Release build (then its install and Debian package, scripts/package_test.sh), then an
# AddressSanitizer + UndefinedBehaviorSanitizer build; then runs every fuzz target for 25 seconds
# (scripts/fuzz.sh). --fast runs the Release suite and the package test only.
set -euo pipefail
cd "$(dirname "$0")/.."

bash scripts/setup.sh
jobs=$(nproc)

# Under CI (CI=true), nothing may be quietly left out: a failed npm install fails the run at once,
# and so does any skipped test that tests/expected_skips.txt does not list (scripts/check_skips.py).
ci=false
case "${CI:-}" in true | 1) ci=true ;; esac

# Configures a build folder and installs the real glTF clients (Khronos validator, three.js,
# draco3d) and the viewer's browser driver (playwright-core, for Debian's chromium), pinned in
# tests/encode/js, in its npm folder. Done for every folder before anything is built, so that a
# failed install fails early.
configure_suite() {
  local dir=$1
  shift
  cmake -S . -B "$dir" -G Ninja -DISOSLAB_WERROR=ON "$@" >/dev/null
  if [ ! -d "$dir/npm/node_modules/three" ] || [ ! -d "$dir/npm/node_modules/playwright-core" ]; then
    if ! (cd "$dir/npm" && npm install --no-audit --no-fund --loglevel=error >/dev/null); then
      if $ci; then
        echo "test: npm install failed in $dir/npm; under CI the glTF client and viewer tests must run (CI=true)" >&2
        exit 1
      fi
      echo "test: npm install failed in $dir/npm; the glTF client and viewer tests will skip" >&2
    fi
  fi
}

# Builds a configured folder and runs its tests; then lists the skipped tests, which fail a CI run
# unless tests/expected_skips.txt lists them.
run_suite() {
  local dir=$1
  cmake --build "$dir" -j "$jobs"
  rm -f "$dir/ctest-junit.xml" "$dir/pytest-junit.xml"
  (cd "$dir" && ctest --output-on-failure -j "$jobs" --output-junit ctest-junit.xml)
  python3 scripts/check_skips.py tests/expected_skips.txt "$dir/ctest-junit.xml" "$dir/pytest-junit.xml"
}

# Configured for /usr, the prefix of the Debian package that scripts/package_test.sh makes.
configure_suite build -DCMAKE_BUILD_TYPE=Release -DCMAKE_INSTALL_PREFIX=/usr
if [ "${1:-}" != "--fast" ]; then
  configure_suite build-asan -DCMAKE_BUILD_TYPE=RelWithDebInfo -DISOSLAB_SANITIZE=ON -DISOSLAB_BUILD_BENCH=OFF
fi

# The module graph (docs/design.md): includes and links follow the layer rules.
bash scripts/check_layers.sh
python3 scripts/check_sizes.py
# The kernels build and pass with only a compiler, CMake and GoogleTest: every other package is
# hidden from CMake.
hide=()
for p in fmt nlohmann_json CLI11 ZLIB PNG DCMTK draco PkgConfig benchmark tinyobjloader; do hide+=("-DCMAKE_DISABLE_FIND_PACKAGE_$p=ON"); done
cmake -S . -B build-kernels -G Ninja -DISOSLAB_WERROR=ON -DISOSLAB_KERNELS_ONLY=ON "${hide[@]}" >/dev/null
cmake --build build-kernels -j "$jobs"
(cd build-kernels && ctest --output-on-failure -j "$jobs" --output-junit ctest-junit.xml)
python3 scripts/check_skips.py tests/expected_skips.txt build-kernels/ctest-junit.xml

run_suite build
# The installed library as its users meet it: find_package and pkg-config consumers, the installed
# Python package, the .deb with lintian and dpkg -i.
bash scripts/package_test.sh build
if [ "${1:-}" != "--fast" ]; then
  ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1 \
    LSAN_OPTIONS=suppressions=$PWD/tests/lsan.supp:print_suppressions=0 run_suite build-asan
  # Every libFuzzer target for 25 seconds from its seed corpus (clang, ASan + UBSan, build-fuzz/).
  bash scripts/fuzz.sh 25
fi
