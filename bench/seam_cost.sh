#!/usr/bin/env bash
# The size cost of the .glb seam marks (_ISOSLAB_SEAM): each input written with and without them,
# everything else equal, by build/bench/isoslab_seam_cost.
set -euo pipefail
cd "$(dirname "$0")/.."
bin=build/bench/isoslab_seam_cost
[ -x "$bin" ] || { echo "build first: cmake --build build" >&2; exit 1; }
philips=../shared/data/ct-philips-head
if [ -d "$philips" ]; then
  "$bin" "$philips" --iso 350
  "$bin" "$philips" --iso 350 --normals
  "$bin" "$philips" --iso 350 --chunk-triangles 65536
fi
"$bin" 'phantom:head?n=128,128,112' --iso -400 --chunk-triangles 20000
"$bin" 'phantom:sphere?n=96&r=40&field=distance' --iso 600 --method mt6 --chunk-triangles 20000
