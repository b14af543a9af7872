#!/usr/bin/env bash
# Memory and time of the component filter on a large foam: the noisy head phantom (512 x 512 x 256
# int16) at iso 45, about 36 million triangles in many components. isoslab writes .glb plainly,
# then with --keep-largest 1 --close-boundary (two passes), at 1 thread; then VTK 9.1 extracts the
# same volume (NIfTI reader + vtkFlyingEdges3D) and keeps its largest region with
# vtkPolyDataConnectivityFilter (when python3-vtk9 is installed).
# Usage: bench/components_memory.sh [BUILD_DIR] [SLICES]   (about 4 minutes)
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
n=${2:-256}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
input="phantom:head?n=512,512,$n"
printf '%-48s %12s %10s %10s %10s\n' run triangles components "peak MiB" seconds
# Peak RSS from /usr/bin/time (the report's own figure misses what is freed before it is written).
run() {
  local label=$1
  shift
  /usr/bin/time -f '%M %e' -o "$tmp/time" "$build/cli/isoslab" extract "$input" --iso 45 -q --threads 1 "$@" \
    -o "$tmp/f.glb"
  rm -f "$tmp/f.glb"
  python3 - "$tmp/time" "$tmp/r.json" "$label" <<'PY'
import json, os, sys
kib, seconds = open(sys.argv[1]).read().split()[-2:]
tri = comps = ''
if os.path.exists(sys.argv[2]):
    r = json.load(open(sys.argv[2])); tri = f"{r['triangles']:,}"; comps = f"{r['components']['count']:,}"
    os.remove(sys.argv[2])
print(f"{sys.argv[3]:<48} {tri:>12} {comps:>10} {int(kib) / 1024:10.1f} {float(seconds):10.1f}")
PY
}
run "isoslab .glb"
run "isoslab .glb --report" --report "$tmp/r.json"
run "isoslab .glb --close-boundary --keep-largest 1" --close-boundary --keep-largest 1
run "  the same with --report" --close-boundary --keep-largest 1 --report "$tmp/r.json"
if /usr/bin/python3 -c 'import vtk' 2>/dev/null; then
  "$build/cli/isoslab" phantom "$input" -o "$tmp/head.nii" >/dev/null
  /usr/bin/python3 - "$tmp/head.nii" <<'PY'
import resource, sys, time, vtk
t0 = time.perf_counter()
reader = vtk.vtkNIFTIImageReader(); reader.SetFileName(sys.argv[1])
fe = vtk.vtkFlyingEdges3D(); fe.SetInputConnection(reader.GetOutputPort()); fe.SetValue(0, 45.0)
fe.ComputeNormalsOff(); fe.ComputeGradientsOff(); fe.ComputeScalarsOff(); fe.Update()
t1 = time.perf_counter()
peak_fe = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
conn = vtk.vtkPolyDataConnectivityFilter(); conn.SetInputConnection(fe.GetOutputPort())
conn.SetExtractionModeToLargestRegion(); conn.Update()
t2 = time.perf_counter()
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
tris = fe.GetOutput().GetNumberOfPolys()
print(f"{'VTK reader + FlyingEdges3D':<48} {tris:12,} {'':>10} {peak_fe:10.1f} {t1 - t0:10.1f}")
print(f"{'  + vtkPolyDataConnectivityFilter':<48} {conn.GetOutput().GetNumberOfPolys():12,} {conn.GetNumberOfExtractedRegions():10,} {peak:10.1f} {t2 - t1:10.1f}")
PY
fi
