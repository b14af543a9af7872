#!/usr/bin/python3
"""Topology of the extracted surface: isoslab's mc and mc33 against scikit-image's Lewiner.

Measures, for each tool on the same volume and iso value, the triangles, the Euler characteristic
V - E + F, the non-manifold edges (shared by more than two triangles), the boundary edges (used by
one triangle), the edges whose two triangles disagree in orientation, the connected components and
how many of them are closed. All of these come from one counter in this script, applied to
isoslab's binary PLY (read as written: indexed and welded, nothing is merged here) and to
scikit-image's (verts, faces) alike; isoslab's own --report figures are printed beside it as a
cross-check.

Volumes (from ../shared/data, skipped with a note when absent):
- the engine CT (raw uint8 256x256x128, x fastest) at iso 90.5;
- the Philips head CT (DICOM series, HU) at iso -399.5.
The iso values lie between integer voxel values, so isoslab's "value >= iso is inside" and
scikit-image's "value > level is inside" classify every voxel alike.

Needs Debian's python3-numpy, python3-scipy, python3-skimage and (for the DICOM series)
python3-pydicom, which load under /usr/bin/python3 only.

Usage:
  /usr/bin/python3 bench/topology.py [--isoslab build/cli/isoslab] [--methods mc,mc33]
      [--threads 1] [--engine PATH] [--dicom DIR] [--keep DIR]
Prints a Markdown table for docs/precision.md. Each tool is timed once (wall seconds):
isoslab's `extract` end to end (file in, PLY out, with its report), scikit-image's
marching_cubes alone on the volume already in memory (its load time is given apart).
"""
import argparse
import gzip
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DATA = os.path.join(ROOT, "..", "shared", "data")


# ---------------------------------------------------------------------------------------------
# Reading meshes and volumes


def read_ply(path):
    """(vertices float64 (V, 3), faces int64 (F, 3)) from a binary little-endian triangle PLY."""
    with open(path, "rb") as f:
        if f.readline().strip() != b"ply":
            raise ValueError(f"{path}: not a PLY file")
        elements = []  # [name, count, [(property name, dtype or (count dtype, item dtype))]]
        fmt = None
        while True:
            line = f.readline()
            if not line:
                raise ValueError(f"{path}: header without end_header")
            words = line.decode("ascii").split()
            if not words or words[0] in ("comment", "obj_info"):
                continue
            if words[0] == "end_header":
                break
            if words[0] == "format":
                fmt = words[1]
            elif words[0] == "element":
                elements.append([words[1], int(words[2]), []])
            elif words[0] == "property":
                if words[1] == "list":
                    elements[-1][2].append((words[4], (PLY_TYPES[words[2]], PLY_TYPES[words[3]])))
                else:
                    elements[-1][2].append((words[2], PLY_TYPES[words[1]]))
        if fmt != "binary_little_endian":
            raise ValueError(f"{path}: format {fmt}; only binary_little_endian is read here")
        body = f.read()
    offset = 0
    vertices = faces = None
    for name, count, props in elements:
        if any(isinstance(t, tuple) for _, t in props):
            # A triangle list: every row is (count, i0, i1, i2), checked below.
            if len(props) != 1:
                raise ValueError(f"{path}: element {name} mixes a list with other properties")
            count_type, index_type = props[0][1]
            row = np.dtype([("n", "<" + count_type), ("i", "<" + index_type, 3)])
            table = np.frombuffer(body, row, count, offset)
            if count and not np.all(table["n"] == 3):
                raise ValueError(f"{path}: element {name} holds polygons other than triangles")
        else:
            row = np.dtype([(p, "<" + t) for p, t in props])
            table = np.frombuffer(body, row, count, offset)
        offset += row.itemsize * count
        if name == "vertex":
            vertices = np.stack([table["x"], table["y"], table["z"]], axis=1).astype(np.float64)
        elif name == "face":
            faces = table["i"].astype(np.int64)
    if vertices is None or faces is None:
        raise ValueError(f"{path}: no vertex or face element")
    return vertices, faces


PLY_TYPES = {"char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1", "short": "i2", "int16": "i2",
             "ushort": "u2", "uint16": "u2", "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
             "float": "f4", "float32": "f4", "double": "f8", "float64": "f8"}


def load_engine(path):
    """The engine CT as float32 indexed [z, y, x] (the raw file is x fastest, 256x256x128)."""
    raw = gzip.open(path).read() if path.endswith(".gz") else open(path, "rb").read()
    return np.frombuffer(raw, np.uint8).reshape(128, 256, 256).astype(np.float32)


def load_dicom_series(folder):
    """The largest DICOM image series in folder as float32 HU indexed [slice, row, column].

    Files without pixel data (the Philips DIRFILE, the licence) are skipped. Slices are sorted by
    ImagePositionPatient projected on the slice normal (row direction x column direction), the
    order in which isoslab stacks them, and RescaleSlope/RescaleIntercept are applied.
    """
    import pydicom
    series = {}
    for name in sorted(os.listdir(folder)):
        try:
            ds = pydicom.dcmread(os.path.join(folder, name))
        except Exception:
            continue
        if "PixelData" not in ds:
            continue
        series.setdefault(ds.SeriesInstanceUID, []).append(ds)
    if not series:
        raise ValueError(f"{folder}: no DICOM image")
    slices = max(series.values(), key=len)
    orientation = np.array(slices[0].ImageOrientationPatient, float)
    normal = np.cross(orientation[:3], orientation[3:])
    slices.sort(key=lambda ds: float(np.dot(normal, np.array(ds.ImagePositionPatient, float))))
    steps = np.diff([np.dot(normal, np.array(ds.ImagePositionPatient, float)) for ds in slices])
    if len(steps) and (steps.min() <= 0 or steps.max() - steps.min() > 1e-3 * steps.max()):
        print(f"note: {folder}: uneven or repeated slice positions (steps {steps.min():g}..{steps.max():g} mm)",
              file=sys.stderr)
    volume = np.empty((len(slices), int(slices[0].Rows), int(slices[0].Columns)), np.float32)
    for k, ds in enumerate(slices):
        slope = float(getattr(ds, "RescaleSlope", 1.0))
        intercept = float(getattr(ds, "RescaleIntercept", 0.0))
        volume[k] = ds.pixel_array.astype(np.float32) * slope + intercept
    return volume


# ---------------------------------------------------------------------------------------------
# The one counter


def topology(vertices, faces):
    """Counts on an indexed triangle mesh, welding nothing.

    V counts the vertices that some triangle uses (unused ones are reported apart); E the unique
    undirected edges; a component is a set of triangles connected through shared vertices, closed
    when none of its edges is a boundary edge (used by one triangle only).
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    faces = np.asarray(faces, np.int64)
    n_vertices = len(vertices)
    used = np.unique(faces)
    degenerate = int(np.count_nonzero((faces[:, 0] == faces[:, 1]) | (faces[:, 1] == faces[:, 2]) |
                                      (faces[:, 2] == faces[:, 0])))
    # Directed half-edges (a -> b) of every triangle, keyed as a * n + b.
    tail = faces.ravel()
    head = faces[:, [1, 2, 0]].ravel()
    lo, hi = np.minimum(tail, head), np.maximum(tail, head)
    undirected, edge_of, uses = np.unique(lo * n_vertices + hi, return_inverse=True, return_counts=True)
    # An edge used twice is consistently oriented when its two triangles run it in opposite
    # directions, i.e. one half-edge goes lo -> hi and the other hi -> lo.
    forward = np.bincount(edge_of, weights=(tail < head), minlength=len(undirected))
    inconsistent = int(np.count_nonzero((uses == 2) & (forward != 1)))
    boundary = uses == 1

    graph = coo_matrix((np.ones(len(tail), np.int8), (tail, head)), shape=(n_vertices, n_vertices))
    _, label = connected_components(graph, directed=False)
    face_label = label[faces[:, 0]]
    components = np.unique(face_label)
    # The component of each boundary edge: the label of either endpoint.
    open_labels = np.unique(label[(undirected[boundary] // n_vertices)])
    return {
        "vertices": int(len(used)),
        "unused_vertices": int(n_vertices - len(used)),
        "triangles": int(len(faces)),
        "degenerate": degenerate,
        "edges": int(len(undirected)),
        "euler": int(len(used) - len(undirected) + len(faces)),
        "non_manifold_edges": int(np.count_nonzero(uses > 2)),
        "boundary_edges": int(np.count_nonzero(boundary)),
        "inconsistent_edges": inconsistent,
        "components": int(len(components)),
        "closed_components": int(len(components) - len(np.intersect1d(components, open_labels))),
    }


# ---------------------------------------------------------------------------------------------
# The tools


def run_isoslab(isoslab, source, iso, method, threads, workdir):
    """(counts from the PLY, isoslab's report, wall seconds, bounds in voxel units as x, y, z)."""
    ply = os.path.join(workdir, f"{source['key']}-{method}.ply")
    report = os.path.join(workdir, f"{source['key']}-{method}.json")
    cmd = [isoslab, "extract", *source["isoslab_args"], "--iso", repr(iso), "--method", method,
           "--space", "voxel", "--threads", str(threads), "-o", ply, "--report", report, "-q"]
    start = time.perf_counter()
    subprocess.run(cmd, check=True)
    seconds = time.perf_counter() - start
    vertices, faces = read_ply(ply)
    counts = topology(vertices, faces)
    return counts, json.load(open(report)), seconds, (vertices.min(0), vertices.max(0))


def run_skimage(volume, iso):
    """(counts, seconds of marching_cubes, bounds in voxel units as x, y, z)."""
    from skimage.measure import marching_cubes
    start = time.perf_counter()
    verts, faces, _, _ = marching_cubes(volume, iso, method="lewiner")
    seconds = time.perf_counter() - start
    xyz = verts[:, ::-1]  # scikit-image gives (z, y, x) for a volume indexed [z, y, x]
    return topology(verts, faces), seconds, (xyz.min(0), xyz.max(0))


# ---------------------------------------------------------------------------------------------


COLUMNS = ["triangles", "vertices", "euler", "non_manifold_edges", "boundary_edges", "inconsistent_edges",
           "components", "closed_components"]
REPORT_KEYS = {"triangles": "triangles", "vertices": "vertices", "euler": "euler",
               "non_manifold_edges": "nonmanifold_edges", "boundary_edges": "boundary_edges",
               "inconsistent_edges": "inconsistent_edges"}


def sources(args):
    out = []
    if os.path.exists(args.engine):
        out.append({"key": "engine", "name": "engine CT 256x256x128 u8", "iso": args.engine_iso,
                    "isoslab_args": [args.engine, "--raw-dims", "256,256,128", "--raw-type", "u8"],
                    "load": lambda: load_engine(args.engine)})
    else:
        print(f"note: {args.engine} absent; the engine is skipped", file=sys.stderr)
    if os.path.isdir(args.dicom):
        out.append({"key": "philips", "name": "Philips head CT 512x512x140 HU", "iso": args.dicom_iso,
                    "isoslab_args": [args.dicom], "load": lambda: load_dicom_series(args.dicom)})
    else:
        print(f"note: {args.dicom} absent; the Philips head is skipped", file=sys.stderr)
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--isoslab", default=os.path.join(ROOT, "build", "cli", "isoslab"))
    parser.add_argument("--methods", default="mc,mc33", help="isoslab methods, comma-separated")
    parser.add_argument("--threads", type=int, default=1, help="isoslab --threads (default 1)")
    parser.add_argument("--engine", default=os.path.join(DATA, "engine", "engine_256x256x128_uint8.raw.gz"))
    parser.add_argument("--engine-iso", type=float, default=90.5)
    parser.add_argument("--dicom", default=os.path.join(DATA, "ct-philips-head"))
    parser.add_argument("--dicom-iso", type=float, default=-399.5)
    parser.add_argument("--keep", help="keep the PLY files and reports in this folder")
    parser.add_argument("--no-skimage", action="store_true", help="isoslab only")
    args = parser.parse_args()

    workdir = args.keep or tempfile.mkdtemp(prefix="isoslab-topology-")
    os.makedirs(workdir, exist_ok=True)
    version = subprocess.run([args.isoslab, "--version"], capture_output=True, text=True).stdout.strip()
    rows, notes = [], []
    try:
        for source in sources(args):
            iso = source["iso"]
            bounds = {}
            for method in args.methods.split(","):
                counts, report, seconds, bounds[method] = run_isoslab(args.isoslab, source, iso, method,
                                                                      args.threads, workdir)
                rows.append((source["name"], iso, f"isoslab {method}", counts, f"{seconds:.2f}"))
                differ = [f"{key} {report.get(rkey)} vs {counts[key]}" for key, rkey in REPORT_KEYS.items()
                          if report.get(rkey) != counts[key]]
                if differ:
                    notes.append(f"{source['key']} {method}: isoslab's report differs from this count: "
                                 + "; ".join(differ))
                if counts["degenerate"] or counts["unused_vertices"]:
                    notes.append(f"{source['key']} {method}: {counts['degenerate']} degenerate triangles, "
                                 f"{counts['unused_vertices']} unused vertices")
            if args.no_skimage:
                continue
            start = time.perf_counter()
            volume = source["load"]()
            load = time.perf_counter() - start
            counts, seconds, bounds["skimage"] = run_skimage(volume, iso)
            del volume
            rows.append((source["name"], iso, "skimage lewiner", counts, f"{seconds:.2f} (+{load:.2f} load)"))
            if counts["degenerate"] or counts["unused_vertices"]:
                notes.append(f"{source['key']} skimage: {counts['degenerate']} degenerate triangles, "
                             f"{counts['unused_vertices']} unused vertices")
            # Same voxel order: the surfaces' bounding boxes in voxel units must agree.
            lo, hi = bounds["skimage"]
            for method in args.methods.split(","):
                gap = max(np.abs(bounds[method][0] - lo).max(), np.abs(bounds[method][1] - hi).max())
                if gap > 0.01:
                    notes.append(f"{source['key']}: the bounding boxes of isoslab {method} and skimage differ "
                                 f"by {gap:.3f} voxel (different voxel order?)")
    finally:
        if not args.keep:
            shutil.rmtree(workdir, ignore_errors=True)

    print(f"`{' '.join(['/usr/bin/python3', 'bench/topology.py', *sys.argv[1:]])}`: isoslab {version}, "
          f"isoslab --threads {args.threads}")
    print()
    print("| volume | iso | tool | triangles | vertices | Euler V−E+F | non-manifold edges | boundary edges "
          "| misoriented edges | components | closed | seconds |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for name, iso, tool, counts, seconds in rows:
        cells = [f"{counts[c]:,}" if c in ("triangles", "vertices") else str(counts[c]) for c in COLUMNS]
        print(f"| {name} | {iso:g} | {tool} | {' | '.join(cells)} | {seconds} |")
    print()
    print("Counted by bench/topology.py on each mesh as written (nothing welded). Edges: unique undirected "
          "vertex pairs; non-manifold: used by more than two triangles; boundary: used by one; misoriented: "
          "used by two triangles that run it in the same direction. Components: triangles connected through "
          "shared vertices; closed: without a boundary edge. isoslab: `extract` end to end (file in, PLY out, "
          "with --report); skimage: `marching_cubes(vol, level, method='lewiner')` on the volume in memory.")
    for note in notes:
        print(f"- {note}")
    if not notes:
        print("- isoslab's --report agrees with this count on every isoslab row; the bounding boxes of all "
              "tools agree within 0.01 voxel (the same voxel order).")


if __name__ == "__main__":
    main()
