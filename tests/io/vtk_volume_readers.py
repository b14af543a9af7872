#!/usr/bin/python3
"""Reads isoslab's volume files with VTK 9.1's own readers (Debian's python3-vtk9):
vtkNIFTIImageReader, vtkNrrdReader and vtkMetaImageReader. Every file of FOLDER/manifest.txt
(lines: FILE TYPE REFERENCE NX NY NZ SX SY SZ) must give the voxels of REFERENCE (raw, little-endian,
of numpy TYPE) exactly, in the same type, with the dimensions and spacing given.

Usage: vtk_volume_readers.py FOLDER          Exits 77 (ctest's skip code) without python3-vtk9.
Run by VolumeFormats.VtkReadersReadTheWrittenFiles (tests/io/volume_formats_test.cpp).
"""
import gzip
import os
import sys

try:
    import numpy as np
    # The readers' own modules: `import vtk` would load vtkIOMPIImage, whose factory swaps in a
    # parallel NRRD reader that needs MPI.
    from vtkmodules.util.numpy_support import vtk_to_numpy
    from vtkmodules.vtkIOImage import vtkMetaImageReader, vtkNIFTIImageReader, vtkNrrdReader
except ImportError:
    print("skipped: python3-vtk9 or numpy is not installed")
    sys.exit(77)

folder = sys.argv[1]
failures = 0
checked = 0
vtk_swap_bug = 0
for line in open(os.path.join(folder, "manifest.txt")):
    name, dtype, reference, *numbers = line.split()
    dims = tuple(int(n) for n in numbers[:3])
    spacing = tuple(float(s) for s in numbers[3:])
    path = os.path.join(folder, name)
    reader = (vtkNIFTIImageReader() if ".nii" in name else vtkNrrdReader() if name.endswith(".nrrd")
              else vtkMetaImageReader())
    reader.SetFileName(path)
    reader.Update()
    image = reader.GetOutput()
    scalars = image.GetPointData().GetScalars()
    problems = []
    if scalars is None:
        problems.append("no voxels read")
    else:
        got = vtk_to_numpy(scalars)
        want = np.fromfile(os.path.join(folder, reference), dtype="<" + dtype)
        if got.dtype != want.dtype:
            problems.append(f"type {got.dtype}, not {want.dtype}")
        if got.shape != want.shape or not np.array_equal(got, want):
            diff = np.flatnonzero(got != want) if got.shape == want.shape else []
            problems.append(f"voxels differ ({len(diff)} of {want.size})" if len(diff) else f"{got.size} voxels")
        if image.GetDimensions() != dims:
            problems.append(f"dimensions {image.GetDimensions()}, not {dims}")
        if not np.allclose(image.GetSpacing(), spacing, rtol=1e-6):
            problems.append(f"spacing {image.GetSpacing()}, not {spacing}")
    if problems and name.endswith("_z_be.nrrd"):
        # VTK 9.1's vtkNrrdReader ignores `endian: big` for gzip data (it swaps only raw data). Then
        # the file is read by Python's gzip and numpy instead, to the same standard.
        header, data = open(path, "rb").read().split(b"\n\n", 1)
        own = np.frombuffer(gzip.decompress(data), dtype=">" + dtype)
        want = np.fromfile(os.path.join(folder, reference), dtype="<" + dtype)
        swapped = got.byteswap() if scalars is not None else None
        if (b"endian: big" in header and np.array_equal(own, want) and swapped is not None
                and np.array_equal(swapped, want)):
            problems = []
            vtk_swap_bug += 1
        else:
            problems.append("nor as gzip-compressed big-endian voxels")
    checked += 1
    if problems:
        failures += 1
        print(f"FAILED: {name} ({type(reader).__name__}): " + "; ".join(problems))
if failures:
    print(f"{failures} of {checked} files failed")
    sys.exit(1)
print(f"VTK's readers read all {checked} files as written ({vtk_swap_bug} gzip big-endian NRRD files, whose bytes VTK 9.1 "
      "does not swap, read byte-swapped and checked with Python's gzip too)")
