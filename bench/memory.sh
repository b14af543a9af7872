#!/usr/bin/env bash
# Peak memory against slice count: extracts the same sphere from 256 x 256 x N phantoms with
# N = 64 and N = 1024 for every method, and prints the peak RSS (VmHWM) each run reported.
# Streaming means the two columns should match. Usage: bench/memory.sh [BUILD_DIR]
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
bin=$build/cli/isoslab
[ -x "$bin" ] || { echo "memory.sh: build isoslab first ($bin is missing)" >&2; exit 1; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

printf '%-6s %14s %14s %10s %12s\n' method "N=64 MiB" "N=1024 MiB" ratio triangles
for method in mc mt5 mt6 bcc12; do
  row=()
  for n in 64 1024; do
    "$bin" extract "phantom:sphere?n=256,256,$n&r=30" --method "$method" -q -o "$tmp/s.ply" --report "$tmp/r$n.json"
  done
  python3 - "$method" "$tmp/r64.json" "$tmp/r1024.json" <<'PY'
import json, sys
a = json.load(open(sys.argv[2])); b = json.load(open(sys.argv[3]))
print(f"{sys.argv[1]:<6} {a['peak_rss_mib']:14.1f} {b['peak_rss_mib']:14.1f} {b['peak_rss_mib']/a['peak_rss_mib']:10.3f} {b['triangles']:12d}")
PY
done
echo "machine: $(nproc) cores, $(grep MemTotal /proc/meminfo | awk '{printf "%.0f GiB", $2/1048576}'), $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //')"
