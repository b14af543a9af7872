#!/usr/bin/python3
"""VTK 9.1's vtkGLTFReader (no Draco support) opens isoslab's uncompressed .glb.

Usage: vtk_gltf_test.py ISOSLAB_CLI
Exits 77 (ctest's skip code) when VTK is absent.
"""
import json
import os
import subprocess
import sys
import tempfile

try:
    import vtk
except ImportError:
    print("skipped: python3-vtk9 is not installed")
    sys.exit(77)

cli = sys.argv[1]
failures = 0


def check(condition, what):
    global failures
    if not condition:
        failures += 1
        print("FAILED:", what)


with tempfile.TemporaryDirectory() as d:
    for frame in ("gltf", "raw"):
        glb = os.path.join(d, f"h_{frame}.glb")
        report = os.path.join(d, f"r_{frame}.json")
        subprocess.run([cli, "extract", "phantom:head?n=48,48,40", "--iso", "-400", "--normals", "--draco", "off",
                        "--gltf-frame", frame, "-q", "-o", glb, "--report", report], check=True)
        r = json.load(open(report))
        reader = vtk.vtkGLTFReader()
        reader.SetFileName(glb)
        reader.Update()
        blocks = reader.GetOutput()
        it = blocks.NewIterator()
        it.InitTraversal()
        triangles = points = 0
        bounds = None
        while not it.IsDoneWithTraversal():
            mesh = it.GetCurrentDataObject()
            triangles += mesh.GetNumberOfCells()
            points += mesh.GetNumberOfPoints()
            bounds = mesh.GetBounds()
            check(mesh.GetPointData().GetNormals() is not None, f"{frame}: VTK finds the normals")
            it.GoToNextItem()
        check(triangles == r["triangles"], f"{frame}: VTK reads {triangles} triangles, the report says {r['triangles']}")
        check(points == r["vertices"], f"{frame}: VTK reads {points} points, the report says {r['vertices']}")
        b = r["bounds"]
        if frame == "raw":
            expect = (b[0], b[3], b[1], b[4], b[2], b[5])
        else:  # VTK applies the node: glTF's frame in metres, (x, y, z) -> 0.001 (x, z, -y)
            expect = tuple(0.001 * v for v in (b[0], b[3], b[2], b[5], -b[4], -b[1]))
        scale = 1.0 if frame == "raw" else 0.001
        check(bounds is not None and all(abs(x - y) <= 1e-4 * scale for x, y in zip(bounds, expect)),
              f"{frame}: VTK's bounds {bounds} are the report's {expect}")

print(f"vtk_gltf_test: {failures} failures")
sys.exit(1 if failures else 0)
