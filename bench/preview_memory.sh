#!/usr/bin/env bash
# Peak memory of extract --preview against the same run without it, on the noisy head phantom of
# bench/draco_memory.sh (512 x 512 x 256 int16 at iso 45: about 36 million triangles), to .glb with
# 1 thread. The preview keeps an 800 x 800 image (3 colour + 4 depth bytes a pixel, 4.3 MiB) and
# two slabs' vertices, never the mesh. Runs are paired (without, with) and repeated, in one run.
# Usage: bench/preview_memory.sh [BUILD_DIR] [SLICES]   (about 4 minutes)
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
n=${2:-256}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
printf '%-8s %12s %10s %10s\n' run triangles "peak MiB" seconds
for round in 1 2; do
  for preview in off on; do
    extra=()
    [ "$preview" = on ] && extra=(--preview "$tmp/p.png")
    "$build/cli/isoslab" extract "phantom:head?n=512,512,$n" --iso 45 -q --threads 1 -o "$tmp/f.glb" \
      --report "$tmp/r-$preview.json" "${extra[@]}"
    rm -f "$tmp/f.glb"
    python3 - "$tmp/r-$preview.json" "$preview" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
print(f"{sys.argv[2]:<8} {r['triangles']:12,} {r['peak_rss_mib']:10.1f} {r['seconds']['total']:10.1f}")
PY
  done
  python3 - "$tmp/r-off.json" "$tmp/r-on.json" <<'PY'
import json, sys
off, on = (json.load(open(p))['peak_rss_mib'] for p in sys.argv[1:3])
image = 800 * 800 * 7 / 2**20
print(f"round: with/without {on / off:.3f}; extra {on - off:.1f} MiB (image {image:.1f} MiB; budget 10% + image = {0.1 * off + image:.1f} MiB)")
PY
done
