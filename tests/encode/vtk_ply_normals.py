#!/usr/bin/python3
"""Reads an isoslab PLY with VTK 9.1's vtkPLYReader (Debian's python3-vtk9) and checks its vertex
normals against the surface they belong to: an ellipsoid, the phantom sphere of a distance field
(inside larger) scaled by the voxel spacing, centred at CX CY CZ (physical units). Its outward
normal at p is ((p - c) / s^2) normalised per axis; every normal VTK reads must be unit length and
within a degree of it.

Usage: vtk_ply_normals.py PLY VERTICES CX CY CZ SX SY SZ      Exits 77 without python3-vtk9.
Run by PlyWriter.VtkReadsTheNormalsAsTheSurfaces (tests/encode/writers_test.cpp).
"""
import sys

try:
    import numpy as np
    from vtkmodules.util.numpy_support import vtk_to_numpy
    from vtkmodules.vtkIOPLY import vtkPLYReader
except ImportError:
    print("skipped: python3-vtk9 or numpy is not installed")
    sys.exit(77)

path, vertices = sys.argv[1], int(sys.argv[2])
centre = np.array([float(x) for x in sys.argv[3:6]])
spacing = np.array([float(x) for x in sys.argv[6:9]])
reader = vtkPLYReader()
reader.SetFileName(path)
reader.Update()
mesh = reader.GetOutput()
normals = mesh.GetPointData().GetNormals()
if mesh.GetNumberOfPoints() != vertices or normals is None:
    print(f"FAILED: {mesh.GetNumberOfPoints()} points (want {vertices}), normals {'absent' if normals is None else 'read'}")
    sys.exit(1)
points = vtk_to_numpy(mesh.GetPoints().GetData()).astype(np.float64)
n = vtk_to_numpy(normals).astype(np.float64)
want = (points - centre) / spacing**2
want /= np.linalg.norm(want, axis=1)[:, None]
length = np.abs(np.linalg.norm(n, axis=1) - 1).max()
cosine = (n * want).sum(axis=1) / np.linalg.norm(n, axis=1)
worst = np.degrees(np.arccos(np.clip(cosine.min(), -1, 1)))
print(f"{len(n)} normals: largest |n| - 1 {length:.2g}, largest angle to the ellipsoid's normal {worst:.3f} degrees")
if length > 1e-5 or worst > 1.0:
    print("FAILED")
    sys.exit(1)
