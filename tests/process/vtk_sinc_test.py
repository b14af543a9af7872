#!/usr/bin/python3
"""`isoslab extract --smooth N` (windowed sinc) against VTK 9.1's vtkWindowedSincPolyDataFilter on
the same mesh: Debian's python3-vtk9 reads isoslab's unsmoothed PLY, smooths it with the same
iterations and pass band, and the result must equal isoslab's smoothed PLY, vertex by vertex.

isoslab divides VTK's filter by its gain at frequency 0, S = sum of the Chebyshev coefficients
(0.9984 for 20 iterations), so that the mesh neither shrinks nor drifts towards the coordinates'
origin. VTK's filter is linear and maps a constant shift T to S*T, so S is measured here from VTK
itself, by smoothing the mesh shifted by T, and isoslab's result must be VTK's divided by S.
Tolerance: 2e-5 voxels (isoslab works in double and writes float32; VTK runs in double here).

Usage: vtk_sinc_test.py ISOSLAB_CLI        Exits 77 (ctest's skip code) without python3-vtk9.
"""
import os
import subprocess
import sys
import tempfile

try:
    import numpy as np
    import vtk
    from vtk.util.numpy_support import numpy_to_vtk, vtk_to_numpy
except ImportError:
    print("skipped: python3-vtk9 or numpy is not installed")
    sys.exit(77)

cli = sys.argv[1]
failures = 0


def read_ply(path):
    reader = vtk.vtkPLYReader()
    reader.SetFileName(path)
    reader.Update()
    mesh = reader.GetOutput()
    points = vtk_to_numpy(mesh.GetPoints().GetData()).astype(np.float64)
    cells = vtk_to_numpy(mesh.GetPolys().GetConnectivityArray()).reshape(-1, 3)
    return points, cells


def vtk_smooth(points, cells, iterations, pass_band):
    poly = vtk.vtkPolyData()
    pts = vtk.vtkPoints()
    pts.SetDataTypeToDouble()
    pts.SetData(numpy_to_vtk(np.ascontiguousarray(points), deep=True))
    poly.SetPoints(pts)
    polys = vtk.vtkCellArray()
    offsets = np.arange(0, 3 * len(cells) + 1, 3, dtype=np.int64)
    polys.SetData(numpy_to_vtk(offsets, deep=True, array_type=vtk.VTK_ID_TYPE),
                  numpy_to_vtk(cells.astype(np.int64).ravel(), deep=True, array_type=vtk.VTK_ID_TYPE))
    poly.SetPolys(polys)
    f = vtk.vtkWindowedSincPolyDataFilter()
    f.SetInputData(poly)
    f.SetNumberOfIterations(iterations)
    f.SetPassBand(pass_band)
    f.NormalizeCoordinatesOff()
    f.Update()
    return vtk_to_numpy(f.GetOutput().GetPoints().GetData()).astype(np.float64)


cases = [
    ("phantom:sphere?n=40&r=12.3&c=19.6,20.2,19.9&field=binary", 50, "mc"),
    ("phantom:torus?n=48,48,40&R=13&r=5&field=distance", None, "mt6"),
]
with tempfile.TemporaryDirectory() as tmp:
    print(f"{'input':<58} {'method':<6} {'N':>3} {'pass band':>9} {'S (VTK gain)':>13} {'max |isoslab - VTK/S|':>22} {'max move':>9}")
    for spec, iso, method in cases:
        base = os.path.join(tmp, "base.ply")
        iso_args = ["--iso", str(iso)] if iso is not None else []
        subprocess.run([cli, "extract", spec, *iso_args, "--method", method, "--space", "voxel", "-q", "-o", base],
                       check=True)
        points, cells = read_ply(base)
        for iterations in (5, 20):
            for pass_band in (0.1, 0.05):
                out = os.path.join(tmp, "smooth.ply")
                subprocess.run([cli, "extract", spec, *iso_args, "--method", method, "--space", "voxel", "-q",
                                "--smooth", str(iterations), "--pass-band", str(pass_band), "-o", out], check=True)
                ours, our_cells = read_ply(out)
                if not np.array_equal(cells, our_cells):
                    failures += 1
                    print("FAILED: smoothing changed the triangles")
                reference = vtk_smooth(points, cells, iterations, pass_band)
                shift = np.array([1000.0, -700.0, 300.0])
                shifted = vtk_smooth(points + shift, cells, iterations, pass_band)
                gain = float(np.median((shifted - reference) / shift))
                difference = float(np.abs(ours - reference / gain).max())
                moved = float(np.abs(ours - points).max())
                print(f"{spec:<58} {method:<6} {iterations:>3} {pass_band:>9} {gain:>13.7f} {difference:>22.2e} {moved:>9.3f}")
                if not difference <= 2e-5:
                    failures += 1
                    print("FAILED: isoslab's smoothing differs from VTK's")
                if not moved > 0.05:
                    failures += 1
                    print("FAILED: the mesh did not move")
print("failures:", failures)
sys.exit(1 if failures else 0)
