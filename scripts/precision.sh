#!/usr/bin/env bash
# Reruns the paper's precision and speed study into docs/precision/ (CSV, Markdown, charts):
# installs what is missing, builds Release, then runs the suites of `isoslab compare`, and the
# figures suite into docs/figures/
# Uses ../shared/data's engine and CThead for the paper suite when present, phantoms otherwise.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build --target isoslab
out=${1:-docs/precision}
bin=./build/cli/isoslab
# Each method also smoothed with extract's --smooth 20 (windowed sinc), as rows "method+sinc20".
"$bin" compare --suite spheres51 --smooth 20 --out "$out"
paper=()
[ -f ../shared/data/engine/engine_256x256x128_uint8.raw.gz ] && paper+=(--engine ../shared/data/engine/engine_256x256x128_uint8.raw.gz)
[ -d ../shared/data/cthead ] && paper+=(--cthead ../shared/data/cthead)
"$bin" compare --suite paper "${paper[@]}" --out "$out"
"$bin" compare --suite cubes --out "$out"
# The image comparison into docs/figures/ (beside the tables: its own folder of PNGs).
figures=()
[ -d ../shared/data/cthead ] && figures+=(--cthead ../shared/data/cthead)
"$bin" compare --suite figures "${figures[@]}" --out "${2:-docs/figures}"
