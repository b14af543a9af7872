#!/usr/bin/python3
"""Paired extraction-only ratios, isoslab mc / vtkFlyingEdges3D, at 1 and 2 threads.

This shared machine's speed drifts by tens of percent within minutes. So each round times
vtkFlyingEdges3D and isoslab (bench/isoslab_extract_only) back to back on the same volume, and the
ratio is taken per round. It prints each round and the median ratio.
Usage: bench/fe_ratio.py [BUILD_DIR] [--rounds N] [--runs N]   (run with /usr/bin/python3)
"""
import json
import os
import statistics
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import peers  # noqa: E402  (volumes, NIfTI loading)

ROUNDS = int(sys.argv[sys.argv.index("--rounds") + 1]) if "--rounds" in sys.argv else 5


def fe_seconds(image, iso, threads, runs):
    import vtk
    vtk.vtkSMPTools.Initialize(threads)
    fe = vtk.vtkFlyingEdges3D()
    fe.SetInputData(image)
    fe.SetValue(0, iso)
    fe.ComputeNormalsOff()
    fe.ComputeGradientsOff()
    fe.ComputeScalarsOff()
    times = []
    for _ in range(runs):
        fe.Modified()
        t = time.perf_counter()
        fe.Update()
        times.append(time.perf_counter() - t)
    return statistics.median(times)


def main():
    import vtk
    from vtk.util import numpy_support
    print("| volume | threads | round | FE s | isoslab s | ratio |")
    print("|---|---|---|---|---|---|")
    summary = []
    for name, path, iso in peers.volumes():
        vol = peers.nifti(path)
        image = vtk.vtkImageData()
        image.SetDimensions(vol.shape[2], vol.shape[1], vol.shape[0])
        image.GetPointData().SetScalars(numpy_support.numpy_to_vtk(vol.ravel(), deep=True))
        for threads in (1, 2):
            ratios = []
            for r in range(ROUNDS):
                fe = fe_seconds(image, iso, threads, peers.RUNS)
                iso_s, _, _ = peers.extract_only(path, iso, threads)
                ratios.append(iso_s / fe)
                print(f"| {name} | {threads} | {r + 1} | {fe:.3f} | {iso_s:.3f} | {iso_s / fe:.2f} |")
            summary.append((name, threads, statistics.median(ratios), min(ratios), max(ratios)))
    print()
    for name, threads, med, lo, hi in summary:
        print(f"- {name}, {threads} thread(s): isoslab / FE median {med:.2f} (rounds {lo:.2f} .. {hi:.2f})")


if __name__ == "__main__":
    main()
