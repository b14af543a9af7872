#!/usr/bin/env bash
# Peak memory reading a large compressed NIfTI: a 512 x 512 x 400 int16 head phantom (200 MiB of
# voxels) written as .nii.gz, then extracted at -400; the gzip stream is inflated slice by slice.
# Usage: bench/nifti_memory.sh [BUILD_DIR]
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
"$build/cli/isoslab" phantom 'phantom:head?n=512,512,400' -o "$tmp/head.nii.gz"
"$build/cli/isoslab" extract "$tmp/head.nii.gz" --iso -400 -q -o "$tmp/head.ply" --report "$tmp/r.json"
python3 - "$tmp/r.json" "$tmp/head.nii.gz" <<'PY'
import json, os, sys
r = json.load(open(sys.argv[1]))
print(f"head.nii.gz: {os.path.getsize(sys.argv[2])/2**20:.1f} MiB compressed, {512*512*400*2/2**20:.0f} MiB of voxels; "
      f"{r['triangles']:,} triangles; peak RSS {r['peak_rss_mib']:.1f} MiB; {r['seconds']['total']:.1f} s")
PY
