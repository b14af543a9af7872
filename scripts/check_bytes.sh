#!/usr/bin/env bash
# Compares the output bytes of two isoslab builds: every method, 1 and 3 threads, every mesh
# format, on a noisy phantom and (when ../shared/data is present) on the Philips head CT.
#
#   scripts/check_bytes.sh REFERENCE_ISOSLAB NEW_ISOSLAB
#
# A refactor must leave the output unchanged: this prints one line per run and exits 1 if any
# pair of files differs. Build the reference from the commit before the change, e.g.
#   git worktree add /tmp/ref <commit> && cmake -S /tmp/ref -B /tmp/ref/build -G Ninja \
#     -DISOSLAB_BUILD_TESTS=OFF -DISOSLAB_BUILD_BENCH=OFF && cmake --build /tmp/ref/build --target isoslab
set -euo pipefail
if [ $# -ne 2 ]; then
  echo "usage: $0 REFERENCE_ISOSLAB NEW_ISOSLAB" >&2
  exit 2
fi
ref=$1
new=$2
here="$(cd "$(dirname "$0")/.." && pwd)"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

inputs=("phantom:head?n=40,36,32&seed=3&noise=0.05")
isos=("")
philips="$here/../shared/data/ct-philips-head"
if [ -d "$philips" ]; then
  inputs+=("$philips")
  isos+=("--iso 350")
fi

runs=0
differ=0
for k in "${!inputs[@]}"; do
  input=${inputs[$k]}
  for method in mc mt5 mt6 bcc12 mt24 mc33; do
    for threads in 1 3; do
      for format in ply stl obj drc glb; do
        extra=(--method "$method" --threads "$threads" -q)
        [ "$format" = ply ] || [ "$format" = obj ] && extra+=(--normals)
        # shellcheck disable=SC2206
        iso=(${isos[$k]})
        "$ref" extract "$input" "${iso[@]}" "${extra[@]}" -o "$work/ref.$format"
        "$new" extract "$input" "${iso[@]}" "${extra[@]}" -o "$work/new.$format"
        runs=$((runs + 1))
        if cmp -s "$work/ref.$format" "$work/new.$format"; then
          echo "same     $(basename "$input") $method threads=$threads .$format ($(stat -c %s "$work/new.$format") bytes)"
        else
          echo "DIFFERS  $(basename "$input") $method threads=$threads .$format"
          differ=$((differ + 1))
        fi
      done
    done
  done
done
echo "check_bytes: $runs runs, $differ differ"
[ "$differ" -eq 0 ]
