#!/usr/bin/env bash
# Draco size and speed by compression level, and the cost of chunking, on one real mesh: the
# Philips head CT at -400 HU (../shared/data/ct-philips-head), or the head phantom when the data is
# absent. Prints a Markdown table (docs/compression.md keeps the latest).
# Usage: bench/compression.sh [BUILD_DIR]
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
bin=$build/cli/isoslab
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
if [ -d ../shared/data/ct-philips-head ]; then
  input=../shared/data/ct-philips-head; iso=-400; label="ct-philips-head at -400 HU"
else
  input='phantom:head?n=256,256,224'; iso=-400; label="phantom:head?n=256,256,224 at -400"
fi
row() {  # label report.json
  python3 - "$1" "$2" <<'PY'
import json, sys
r = json.load(open(sys.argv[2])); o = r['output']
print(f"| {sys.argv[1]} | {o['bytes']:,} | {o['bits_per_triangle']:.2f} | {100*o['ratio_to_binary_ply']:.1f}% | {o.get('encode_seconds', 0):.2f} | {r['seconds']['total']:.2f} | {r['peak_rss_mib']:.0f} |")
PY
}
echo "Mesh: $label, mc, $("$bin" extract $input --iso $iso -q -o "$tmp/m.ply" --report "$tmp/p.json" && python3 -c "import json; r=json.load(open('$tmp/p.json')); print(f\"{r['triangles']:,} triangles, {r['vertices']:,} vertices\")")"
echo
echo "| output | bytes | bits/triangle | of binary PLY | encode s | total s | peak MiB |"
echo "|---|---|---|---|---|---|---|"
row "binary PLY" "$tmp/p.json"
for level in 0 1 2 3 4 5 6 7 8 9 10; do
  "$bin" extract $input --iso $iso -q --draco-level $level -o "$tmp/m.glb" --report "$tmp/r.json"
  row ".glb level $level" "$tmp/r.json"
done
for bits in 12 14 16; do
  "$bin" extract $input --iso $iso -q --quant-bits $bits -o "$tmp/m.glb" --report "$tmp/r.json"
  row ".glb level 7, $bits bits" "$tmp/r.json"
done
for chunk in 65536 262144; do
  "$bin" extract $input --iso $iso -q --chunk-triangles $chunk -o "$tmp/m.glb" --report "$tmp/r.json"
  row ".glb level 7, chunks of $chunk" "$tmp/r.json"
done
"$bin" extract $input --iso $iso -q -o "$tmp/m.drc" --report "$tmp/r.json"
row ".drc level 7 (one mesh)" "$tmp/r.json"
echo
echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //')"
