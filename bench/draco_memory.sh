#!/usr/bin/env bash
# Peak memory of streaming a large mesh to .glb, against VTK holding it whole. The noisy head
# phantom (512 x 512 x N, int16) at iso 45 is a foam of about 36 million triangles for N = 256.
# For N = 64 and 256 (and 1024 with --big), with 1 and 2 threads and the default chunks, then
# VTK 9.1's NIfTI reader + vtkFlyingEdges3D on the N = 256 volume (when python3-vtk9 is installed).
# Usage: bench/draco_memory.sh [BUILD_DIR] [--big]   (about 3 minutes; 6 more with --big)
set -euo pipefail
cd "$(dirname "$0")/.."
build=build
sizes=(64 256)
for a in "$@"; do
  case "$a" in
    --big) sizes+=(1024) ;;
    *) build=$a ;;
  esac
done
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
printf '%-6s %8s %12s %10s %12s %8s %10s\n' slices threads triangles "peak MiB" bytes chunks seconds
for n in "${sizes[@]}"; do
  for threads in 1 2; do
    "$build/cli/isoslab" extract "phantom:head?n=512,512,$n" --iso 45 -q --threads "$threads" -o "$tmp/f.glb" \
      --report "$tmp/r.json"
    rm -f "$tmp/f.glb"
    python3 - "$tmp/r.json" "$n" "$threads" <<'PY'
import json, sys
r = json.load(open(sys.argv[1])); o = r['output']
print(f"{sys.argv[2]:<6} {sys.argv[3]:>8} {r['triangles']:12,} {r['peak_rss_mib']:10.1f} {o['bytes']:12,} {o['chunks']:8.0f} {r['seconds']['total']:10.1f}")
PY
  done
done
if /usr/bin/python3 -c 'import vtk' 2>/dev/null; then
  "$build/cli/isoslab" phantom 'phantom:head?n=512,512,256' -o "$tmp/head.nii" >/dev/null
  /usr/bin/python3 - "$tmp/head.nii" <<'PY'
import resource, sys, time, vtk
t = time.perf_counter()
reader = vtk.vtkNIFTIImageReader(); reader.SetFileName(sys.argv[1])
fe = vtk.vtkFlyingEdges3D(); fe.SetInputConnection(reader.GetOutputPort()); fe.SetValue(0, 45.0)
fe.ComputeNormalsOff(); fe.ComputeGradientsOff(); fe.ComputeScalarsOff(); fe.Update()
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
print(f"VTK 9.1 reader + vtkFlyingEdges3D, 256 slices: {fe.GetOutput().GetNumberOfPolys():,} triangles, "
      f"peak {peak:.1f} MiB, {time.perf_counter() - t:.1f} s")
PY
fi
