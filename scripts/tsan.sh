#!/usr/bin/env bash
# ThreadSanitizer over the tests that run threads: the pipeline's stages (tests/stream), the
# threaded paths of the components, smoothing and decimation tests, and the command line's
# same-bytes-for-every-thread-count tests. Builds build-tsan/ (RelWithDebInfo, no benchmarks).
# Exits non-zero on any race report. Not part of CI (it adds a third build); run it after changing
# stream/ or anything that the pipeline calls from its threads.
set -euo pipefail
cd "$(dirname "$0")/.."
cmake -S . -B build-tsan -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DISOSLAB_TSAN=ON -DISOSLAB_BUILD_BENCH=OFF \
  -DISOSLAB_WERROR=ON >/dev/null
cmake --build build-tsan -j "$(nproc)"
export TSAN_OPTIONS="halt_on_error=1 second_deadlock_stack=1"
(cd build-tsan && ctest --output-on-failure -j "$(nproc)" \
  -R 'Pipeline|SlabStitcher|Kernels|Components|Smoothing|Decimation|Cli\.(OutputBytes|.*Thread)|Threads')
