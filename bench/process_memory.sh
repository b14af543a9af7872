#!/usr/bin/env bash
# Memory and time of smoothing and decimation in the stream, against VTK on the whole mesh: the
# noisy head phantom (512 x 512 x N int16) at iso 45 (a foam of about 36 million triangles for
# N = 256), to .glb at 1 thread: plainly, with --smooth 10, and with --smooth 10 --decimate 0.1.
# Then VTK 9.1 on the same volume: NIfTI reader, vtkFlyingEdges3D, vtkWindowedSincPolyDataFilter
# (10 iterations, pass band 0.1) and vtkQuadricDecimation (target reduction 0.9), in one process
# (when python3-vtk9 is installed). Peak RSS from /usr/bin/time for isoslab, getrusage for VTK.
# Usage: bench/process_memory.sh [BUILD_DIR] [SLICES]   (N = 256: about 25 minutes; SKIP_VTK=1
# leaves out the VTK rows, which take about 5 minutes and 17 GB)
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
n=${2:-256}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
input="phantom:head?n=512,512,$n"
printf '%-44s %12s %10s %10s %12s\n' run triangles "peak MiB" seconds "max dist vx"
run() {
  local label=$1
  shift
  /usr/bin/time -f '%M %e' -o "$tmp/time" "$build/cli/isoslab" extract "$input" --iso 45 -q --threads 1 "$@" \
    -o "$tmp/f.glb" --report "$tmp/r.json"
  rm -f "$tmp/f.glb"
  python3 - "$tmp/time" "$tmp/r.json" "$label" <<'PY'
import json, sys
kib, seconds = open(sys.argv[1]).read().split()[-2:]
r = json.load(open(sys.argv[2]))
d = r.get('decimation', {})
dist = f"{d['distance_max_voxels']:.3f}" if d else ''
print(f"{sys.argv[3]:<44} {r['triangles']:12,} {int(kib) / 1024:10.1f} {float(seconds):10.1f} {dist:>12}")
PY
}
# The plain run without --report too: the report's metrics (edge tally, component list) add to
# every run's peak, and on this foam they grow with the number of components.
/usr/bin/time -f '%M %e' -o "$tmp/time" "$build/cli/isoslab" extract "$input" --iso 45 -q --threads 1 -o "$tmp/f.glb"
rm -f "$tmp/f.glb"
read -r kib seconds < "$tmp/time"
printf '%-44s %12s %10.1f %10.1f %12s\n' "isoslab .glb (no --report)" "" "$(echo "$kib / 1024" | bc -l)" "$seconds" ""
run "isoslab .glb"
run "isoslab .glb --smooth 10" --smooth 10
run "isoslab .glb --smooth 10 --decimate 0.1" --smooth 10 --decimate 0.1
if [ -z "${SKIP_VTK:-}" ] && /usr/bin/python3 -c 'import vtk' 2>/dev/null; then
  "$build/cli/isoslab" phantom "$input" -o "$tmp/head.nii" >/dev/null
  /usr/bin/python3 - "$tmp/head.nii" <<'PY'
import resource, sys, time, vtk
def peak():
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
t0 = time.perf_counter()
reader = vtk.vtkNIFTIImageReader(); reader.SetFileName(sys.argv[1])
fe = vtk.vtkFlyingEdges3D(); fe.SetInputConnection(reader.GetOutputPort()); fe.SetValue(0, 45.0)
fe.ComputeNormalsOff(); fe.ComputeGradientsOff(); fe.ComputeScalarsOff(); fe.Update()
t1 = time.perf_counter(); p1 = peak()
sinc = vtk.vtkWindowedSincPolyDataFilter(); sinc.SetInputConnection(fe.GetOutputPort())
sinc.SetNumberOfIterations(10); sinc.SetPassBand(0.1); sinc.NormalizeCoordinatesOn(); sinc.Update()
t2 = time.perf_counter(); p2 = peak()
dec = vtk.vtkQuadricDecimation(); dec.SetInputConnection(sinc.GetOutputPort()); dec.SetTargetReduction(0.9)
dec.Update()
t3 = time.perf_counter(); p3 = peak()
n = fe.GetOutput().GetNumberOfPolys()
print(f"{'VTK reader + vtkFlyingEdges3D':<44} {n:12,} {p1:10.1f} {t1 - t0:10.1f}")
print(f"{'  + vtkWindowedSincPolyDataFilter (10)':<44} {sinc.GetOutput().GetNumberOfPolys():12,} {p2:10.1f} {t2 - t1:10.1f}")
print(f"{'  + vtkQuadricDecimation (0.9)':<44} {dec.GetOutput().GetNumberOfPolys():12,} {p3:10.1f} {t3 - t2:10.1f}")
PY
fi
