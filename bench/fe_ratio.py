#!/usr/bin/python3
"""Paired extraction-only ratios, isoslab mc / vtkFlyingEdges3D, at 1 and 2 threads.

This shared machine's speed drifts by tens of percent within minutes. So each round times
vtkFlyingEdges3D and isoslab (bench/isoslab_extract_only) back to back on the same volume, and the
ratio is taken per round. It prints each round and the median ratio.
Usage: bench/fe_ratio.py [BUILD_DIR] [--rounds N] [--runs N]   (run with /usr/bin/python3)
"""
import os
import statistics
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import peers  # noqa: E402  (volumes, NIfTI loading)

ROUNDS = int(sys.argv[sys.argv.index("--rounds") + 1]) if "--rounds" in sys.argv else 5


def fe_seconds(image, iso, threads, runs):
    fe = peers.flying_edges(image, iso, threads)
    return peers.median_time(lambda: (fe.Modified(), fe.Update()), runs=runs)[0]


def main():
    print("| volume | threads | round | FE s | isoslab s | ratio |")
    print("|---|---|---|---|---|---|")
    summary = []
    for name, path, iso in peers.volumes():
        vol = peers.nifti(path)
        image = peers.vtk_image(vol)
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
