#!/usr/bin/env bash
# Peak memory of streaming a large mesh to .glb: a noisy head phantom whose brain at iso 35 is a
# foam of about 44 million triangles, with the default chunk size and with 1,048,576.
# Usage: bench/draco_memory.sh [BUILD_DIR]   (about 2 minutes)
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
printf '%-16s %12s %10s %12s %8s %10s\n' chunk triangles "peak MiB" bytes chunks seconds
for chunk in default 1048576; do
  extra=()
  [ "$chunk" = default ] || extra=(--chunk-triangles "$chunk")
  "$build/cli/isoslab" extract 'phantom:head?n=512,512,256' --iso 35 -q "${extra[@]}" -o "$tmp/f.glb" --report "$tmp/r.json"
  python3 - "$tmp/r.json" "$chunk" <<'PY'
import json, sys
r = json.load(open(sys.argv[1])); o = r['output']
print(f"{sys.argv[2]:<16} {r['triangles']:12,} {r['peak_rss_mib']:10.1f} {o['bytes']:12,} {o['chunks']:8.0f} {r['seconds']['total']:10.1f}")
PY
done
