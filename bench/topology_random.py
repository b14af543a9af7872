#!/usr/bin/python3
"""Surface components on random fields: isoslab's mc and mc33 and scikit-image's Lewiner MC33
against a brute-force count of the trilinear interpolant's surfaces.

Each field is an n^3 array of a few levels around the iso value plus noise, so that about a third
of the cells are ambiguous. The reference samples the trilinear interpolant of the array at 1/step
of a voxel, labels its inside (>= iso) and outside samples with 6-connectivity (scipy.ndimage), and
counts one surface per adjacent pair of an inside and an outside region (in a box the regions and
the surfaces between them form a tree). It is given at steps 16 and 32; where they differ, a
saddle lies close to the iso value and the coarser sampling misjudges it (seed 1: 14, 15, 14, 14
at steps 20, 24, 32, 40).
Each mesh's components are counted by union-find over its triangles' vertices; its edges used by
more than two triangles are counted too.

Needs Debian's python3-numpy, python3-scipy and python3-skimage (under /usr/bin/python3).

Usage:
  /usr/bin/python3 bench/topology_random.py [--isoslab build/cli/isoslab] [--seeds 0-7] [--n 12]
Prints a Markdown table for docs/precision.md.
"""
import argparse
import os
import subprocess
import sys
import tempfile

import numpy as np
from scipy import ndimage
from skimage import measure

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
LEVELS = np.array([-3, -1, -0.25, 0.5, 1.5, 2], dtype=np.float32)
ISO = 0.1


def random_field(seed, n):
    """An (z, y, x) float32 array: x varies fastest in memory, as isoslab's raw reader expects."""
    rng = np.random.default_rng(seed)
    noise = rng.normal(0, 0.3, (n, n, n)).astype(np.float32)
    return rng.choice(LEVELS, size=(n, n, n)) + noise


def trilinear_samples(vol, step):
    """The trilinear interpolant of vol at every 1/step of a voxel, as a (z, y, x) array."""
    axes = []
    for n in vol.shape:
        t = np.arange((n - 1) * step + 1) / step
        base = np.minimum(np.floor(t).astype(int), n - 2)
        axes.append((base, t - base))
    (z0, fz), (y0, fy), (x0, fx) = axes
    out = np.zeros((len(z0), len(y0), len(x0)))
    for dz in (0, 1):
        wz = (fz if dz else 1 - fz)[:, None, None]
        for dy in (0, 1):
            wy = (fy if dy else 1 - fy)[None, :, None]
            for dx in (0, 1):
                wx = (fx if dx else 1 - fx)[None, None, :]
                out += wz * wy * wx * vol[np.ix_(z0 + dz, y0 + dy, x0 + dx)]
    return out


def reference_surfaces(vol, step):
    samples = trilinear_samples(vol.astype(np.float64), step)
    inside = samples >= ISO
    inside_labels, _ = ndimage.label(inside)
    outside_labels, _ = ndimage.label(~inside)
    pairs = set()
    for axis in range(3):
        lo = [slice(None)] * 3
        hi = [slice(None)] * 3
        lo[axis] = slice(0, -1)
        hi[axis] = slice(1, None)
        lo, hi = tuple(lo), tuple(hi)
        cut = inside[lo] != inside[hi]
        a_in = inside[lo][cut]
        ins = np.where(a_in, inside_labels[lo][cut], inside_labels[hi][cut])
        outs = np.where(a_in, outside_labels[hi][cut], outside_labels[lo][cut])
        pairs |= set(zip(ins.tolist(), outs.tolist()))
    return len(pairs)


def mesh_counts(faces, vertex_count):
    """(components, non-manifold edges) of a triangle list."""
    parent = np.arange(vertex_count)

    def find(a):
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a

    edges = np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1)
    unique, uses = np.unique(edges, axis=0, return_counts=True)
    for a, b in unique:
        ra, rb = find(a), find(b)
        if ra != rb:
            parent[ra] = rb
    components = len({find(v) for v in np.unique(faces)})
    return components, int((uses > 2).sum())


def read_ply_faces(path):
    """Faces and vertex count of isoslab's binary little-endian PLY (float positions, uchar-count
    uint32 indices)."""
    data = open(path, "rb").read()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end].decode()
    vertices = int(header.split("element vertex ")[1].split()[0])
    faces = int(header.split("element face ")[1].split()[0])
    vertex_bytes = 4 * header.split("element face")[0].count("property float")
    record = np.dtype([("n", "u1"), ("i", "<u4", 3)])
    start = end + vertices * vertex_bytes
    rows = np.frombuffer(data[start:start + faces * record.itemsize], dtype=record)
    assert (rows["n"] == 3).all()
    return rows["i"].astype(np.int64), vertices


def isoslab_counts(isoslab, vol, method, work):
    n = vol.shape[0]
    raw = os.path.join(work, "field.raw")
    ply = os.path.join(work, f"{method}.ply")
    vol.tofile(raw)
    subprocess.run([isoslab, "extract", raw, "--raw-dims", f"{n},{n},{n}", "--raw-type", "f32", "--iso", str(ISO),
                    "--method", method, "--space", "voxel", "-q", "-o", ply], check=True)
    return mesh_counts(*read_ply_faces(ply))


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--isoslab", default=os.path.join(ROOT, "build", "cli", "isoslab"))
    parser.add_argument("--seeds", default="0-7", help="a range a-b of numpy seeds")
    parser.add_argument("--n", type=int, default=12, help="points per edge of each field")
    args = parser.parse_args()
    first, last = (int(x) for x in args.seeds.split("-"))
    print(f"`/usr/bin/python3 bench/topology_random.py --seeds {args.seeds} --n {args.n}`: "
          f"{args.n}^3 fields, iso {ISO}\n")
    print("| seed | reference (step 16) | reference (step 32) | mc33 | Lewiner | Lewiner non-manifold edges | mc |")
    print("|---|---|---|---|---|---|---|")
    agree = {"mc33": 0, "lewiner": 0, "mc": 0}
    with tempfile.TemporaryDirectory() as work:
        for seed in range(first, last + 1):
            vol = random_field(seed, args.n)
            coarse, fine = reference_surfaces(vol, 16), reference_surfaces(vol, 32)
            mc33, _ = isoslab_counts(args.isoslab, vol, "mc33", work)
            mc, _ = isoslab_counts(args.isoslab, vol, "mc", work)
            verts, faces, _, _ = measure.marching_cubes(vol, ISO, method="lewiner")
            lewiner, lewiner_nonmanifold = mesh_counts(faces.astype(np.int64), len(verts))
            for name, count in (("mc33", mc33), ("lewiner", lewiner), ("mc", mc)):
                agree[name] += count == fine
            print(f"| {seed} | {coarse} | {fine} | {mc33} | {lewiner} | {lewiner_nonmanifold} | {mc} |")
    total = last - first + 1
    print(f"\nComponents equal to the reference at step 32: mc33 {agree['mc33']}/{total}, "
          f"Lewiner {agree['lewiner']}/{total}, mc {agree['mc']}/{total}.")
    return 0


if __name__ == "__main__":
    sys.exit(main())
