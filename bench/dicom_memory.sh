#!/usr/bin/env bash
# Peak memory of the DICOM path against slice count: writes 512 x 512 head phantoms of 64 and 512
# slices as DICOM series (samples/make_dicom_series), extracts each at -400 HU, and prints peak RSS.
# Also extracts ../shared/data/ct-philips-head when present. Usage: bench/dicom_memory.sh [BUILD_DIR]
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
printf '%-28s %8s %12s %12s %10s\n' input slices "pixel MiB" "peak MiB" seconds
for n in 64 512; do
  "$build/samples/make_dicom_series" "phantom:head?n=512,512,$n" "$tmp/s$n"
  "$build/cli/isoslab" extract "$tmp/s$n" --iso -400 -q -o "$tmp/m.ply" --report "$tmp/r.json"
  python3 - "$tmp/r.json" "synthetic 512x512" "$n" <<'PY'
import json, sys
r = json.load(open(sys.argv[1])); n = int(sys.argv[3])
print(f"{sys.argv[2]:<28} {n:8d} {n*512*512*2/2**20:12.0f} {r['peak_rss_mib']:12.1f} {r['seconds']['total']:10.2f}")
PY
  rm -rf "$tmp/s$n"
done
if [ -d ../shared/data/ct-philips-head ]; then
  "$build/cli/isoslab" extract ../shared/data/ct-philips-head --iso -400 -q -o "$tmp/m.ply" --report "$tmp/r.json"
  python3 - "$tmp/r.json" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
print(f"{'ct-philips-head (-400 HU)':<28} {140:8d} {140*512*512*2/2**20:12.0f} {r['peak_rss_mib']:12.1f} {r['seconds']['total']:10.2f}  triangles {r['triangles']}")
PY
fi
