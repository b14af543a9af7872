"""Peak memory of isoslab.label_surfaces() on a 100-label 512^3 array (issue 37).

The array: 100 random seeds in a ball of radius 230, each voxel of the ball labelled by its nearest
seed (a Voronoi partition; 0 outside), written slab by slab to a .npy so that making it costs
little memory. Each measurement runs in a fresh process: it loads the array (a plain in-memory
array), resets the peak (VmHWM, through /proc/self/clear_refs), calls label_surfaces and reports
the peak above the RSS before the call, the returned meshes' bytes, and the rest: the library's
own working memory.

  PYTHONPATH=build/python /usr/bin/python3 bench/label_surfaces_memory.py [--folder /tmp/lsmem]
"""
import argparse
import json
import os
import subprocess
import sys
import time

import numpy as np

SIZE = 512
RADIUS = 230
SEEDS = 100


def status(key):
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith(key + ":"):
                return int(line.split()[1]) / 1024.0  # MiB
    raise KeyError(key)


def make(path, dtype):
    from scipy.spatial import cKDTree
    centre = (SIZE - 1) / 2
    rng = np.random.default_rng(12345)
    seeds = []
    while len(seeds) < SEEDS:
        p = rng.uniform(centre - RADIUS, centre + RADIUS, 3)
        if np.sum((p - centre) ** 2) < RADIUS * RADIUS:
            seeds.append(p)
    tree = cKDTree(np.array(seeds))
    out = np.lib.format.open_memmap(path, mode="w+", dtype=dtype, shape=(SIZE, SIZE, SIZE))
    yy, xx = np.mgrid[0:SIZE, 0:SIZE].astype(np.float32)
    for z in range(SIZE):
        inside = (z - centre) ** 2 + (yy - centre) ** 2 + (xx - centre) ** 2 < RADIUS * RADIUS
        plane = np.zeros((SIZE, SIZE), dtype)
        if inside.any():
            points = np.stack([np.full(inside.sum(), z, np.float32), yy[inside], xx[inside]], 1)
            plane[inside] = tree.query(points)[1] + 1
        out[z] = plane
    out.flush()


def measure(path, threads):
    import isoslab
    labels = np.load(path)
    with open("/proc/self/clear_refs", "w") as f:
        f.write("5")  # VmHWM back to VmRSS
    before = status("VmRSS")
    start = time.perf_counter()
    surfaces, adjacency = isoslab.label_surfaces(labels, threads=threads)
    seconds = time.perf_counter() - start
    peak = status("VmHWM")
    meshes = sum(v.nbytes + f.nbytes for v, f in surfaces.values()) / 2**20
    print(json.dumps({"dtype": str(labels.dtype), "threads": threads, "array_mib": labels.nbytes / 2**20,
                      "call_peak_mib": peak - before, "meshes_mib": meshes, "working_mib": peak - before - meshes,
                      "labels": len(surfaces), "pairs": len(adjacency),
                      "triangles": sum(len(f) for _, f in surfaces.values()), "seconds": seconds}))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--folder", default="/tmp/lsmem")
    parser.add_argument("--measure", nargs=2, metavar=("NPY", "THREADS"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.measure:
        measure(args.measure[0], int(args.measure[1]))
        return
    os.makedirs(args.folder, exist_ok=True)
    print("| dtype | threads | array MiB | call peak MiB | returned meshes MiB | working MiB | triangles | s |")
    print("|---|---|---|---|---|---|---|---|")
    for dtype in (np.uint8, np.uint16):
        path = os.path.join(args.folder, f"labels_{np.dtype(dtype).name}.npy")
        if not os.path.exists(path):
            make(path, dtype)
        for threads in (1, 2):
            run = subprocess.run([sys.executable, __file__, "--measure", path, str(threads)], capture_output=True,
                                 text=True, check=True)
            r = json.loads(run.stdout.strip().splitlines()[-1])
            print(f"| {r['dtype']} | {threads} | {r['array_mib']:.0f} | {r['call_peak_mib']:.1f} | "
                  f"{r['meshes_mib']:.1f} | {r['working_mib']:.1f} | {r['triangles']:,} | {r['seconds']:.1f} |")


if __name__ == "__main__":
    main()
