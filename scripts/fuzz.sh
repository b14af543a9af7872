#!/usr/bin/env bash
# Builds the libFuzzer targets of tests/fuzz/ (clang, ASan + UBSan, in build-fuzz/) when needed
# and runs each for SECONDS from a copy of its seed corpus in tests/fuzz/corpus/<target>/ (new
# inputs go to build-fuzz/fuzz-work/<target>/, never into the repository). Prints one summary line
# with every target's executions, and exits non-zero if any target crashed, leaked, hit a
# sanitizer report, ran out of memory or timed out; its log and reproducer are then in the work
# folder.
#   scripts/fuzz.sh SECONDS [TARGET...]      (default: every target)
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:?usage: scripts/fuzz.sh SECONDS [TARGET...]}
shift
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=(raw volume dicom image_stack mesh extract process printable label_finish)
build=build-fuzz

if [ ! -f "$build/build.ninja" ]; then
  CC=clang CXX=clang++ cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O2 -g" -DISOSLAB_FUZZ=ON -DISOSLAB_BUILD_TESTS=OFF \
    -DISOSLAB_BUILD_BENCH=OFF >/dev/null
fi
if ! cmake --build "$build" -j "$(nproc)" --target "${targets[@]/#/fuzz_}" >"$build/fuzz-build.log" 2>&1; then
  tail -n 40 "$build/fuzz-build.log" >&2
  echo "fuzz: the build failed (log: $build/fuzz-build.log)" >&2
  exit 1
fi

export ASAN_OPTIONS=detect_leaks=1:symbolize=1:handle_abort=1
export UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1
# Leaks inside third-party libraries (each explained in the file).
export LSAN_OPTIONS=suppressions=$PWD/tests/fuzz/lsan.supp:print_suppressions=0
summary=()
failed=()
for t in "${targets[@]}"; do
  work=$build/fuzz-work/$t
  rm -rf "$work"
  mkdir -p "$work/corpus" "$work/artifacts"
  cp tests/fuzz/corpus/"$t"/* "$work/corpus/"
  rc=0
  "$build/tests/fuzz/fuzz_$t" -max_total_time="$seconds" -rss_limit_mb=2048 -timeout=10 -print_final_stats=1 \
    -artifact_prefix="$work/artifacts/" "$work/corpus" >"$work/log" 2>&1 || rc=$?
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$work/log" | tail -n 1)
  corpus=$(find "$work/corpus" -type f | wc -l)
  if [ "$rc" -ne 0 ]; then
    failed+=("$t")
    summary+=("$t ${execs:-?} execs FAILED (rc $rc)")
    echo "fuzz: $t failed (exit $rc); log $work/log, reproducer in $work/artifacts/:" >&2
    grep -E "ERROR: |SUMMARY: |runtime error|fuzz check failed|uncaught exception" "$work/log" | head -n 5 >&2 || true
    ls "$work/artifacts" >&2 || true
  else
    summary+=("$t ${execs:-?} execs ($corpus inputs)")
  fi
done
line=$(IFS=','; echo "${summary[*]}")
echo "fuzz: ${seconds}s per target: ${line//,/, }"
if [ ${#failed[@]} -gt 0 ]; then
  echo "fuzz: FAILED: ${failed[*]}" >&2
  exit 1
fi
