#!/usr/bin/python3
"""Label maps (issue 35), in one run: isoslab against VTK's vtkDiscreteFlyingEdges3D (Debian's VTK
9.1, every label value set) on mricron's AAL atlas and on checker phantoms of 1000 labels.

For each: wall time, the extraction alone (isoslab's report; VTK's filter), peak RSS and triangles.
VTK holds the volume and runs a pass per label, so it gets the 256^3 phantom only; isoslab also
runs the 1024^3 one (a billion voxels) for its memory goal.

    /usr/bin/python3 bench/labels.py [--program build/cli/isoslab] [--out /tmp/labels-bench]
"""

import argparse
import json
import os
import tempfile

from timing import timed  # bench/timing.py

VTK_SCRIPT = r"""
import sys, time, json, vtk
path, out = sys.argv[1], sys.argv[2]
if len(sys.argv) > 3:  # VTK's threads (its SMP backend, TBB in Debian, uses every core by default)
    vtk.vtkSMPTools.Initialize(int(sys.argv[3]))
t0 = time.perf_counter()
if path.startswith("phantom:"):
    # The checker phantom, made in VTK from the same rule as isoslab's: blocks of b voxels labelled
    # 1 .. labels in turn along x, then y, then z.
    n, b, labels = (int(v) for v in path.split(":")[1].split(","))
    import numpy as np
    from vtk.util import numpy_support
    i = np.arange(n) // b
    nb = (n + b - 1) // b
    block = i[None, None, :] + nb * (i[None, :, None] + nb * i[:, None, None])
    values = (1 + block % labels).astype(np.uint16)
    image = vtk.vtkImageData()
    image.SetDimensions(n, n, n)
    image.GetPointData().SetScalars(numpy_support.numpy_to_vtk(values.ravel(), deep=1))
    hi = labels
else:
    reader = vtk.vtkNIFTIImageReader()
    reader.SetFileName(path)
    reader.Update()
    image = reader.GetOutput()
    hi = int(image.GetScalarRange()[1])
t1 = time.perf_counter()
f = vtk.vtkDiscreteFlyingEdges3D()
f.SetInputData(image)
f.GenerateValues(hi, 1, hi)
f.ComputeNormalsOff()
f.ComputeGradientsOff()
f.ComputeScalarsOn()
f.Update()
t2 = time.perf_counter()
w = vtk.vtkPLYWriter()
w.SetFileName(out)
w.SetFileTypeToBinary()
w.SetInputData(f.GetOutput())
w.Write()
t3 = time.perf_counter()
print(json.dumps({"read": t1 - t0, "filter": t2 - t1, "write": t3 - t2, "total": t3 - t0,
                  "triangles": f.GetOutput().GetNumberOfCells()}))
"""


def isoslab(program, args, out, threads, repeat=3):
    """`repeat` runs with --report (the extraction's time, and every label's topology measured), each
    followed by one without (file to mesh, as VTK's run, which measures nothing per label): the best
    extraction and wall times (the machine's speed drifts, and a first run pays for cold caches)
    and the largest peak RSS."""
    report = out + ".json"
    command = [program, "extract", *args, "-o", out, "--threads", str(threads), "-q"]
    runs = []
    for _ in range(repeat):
        wall_report, rss_report, _ = timed([*command, "--report", report])
        r = json.load(open(report))
        wall, rss, _ = timed(command)
        runs.append((wall_report, rss_report, r["seconds"]["extract"], wall, rss))
    return {"wall": min(x[3] for x in runs), "wall_report": min(x[0] for x in runs),
            "extract": min(x[2] for x in runs), "rss_mib": max(x[4] for x in runs),
            "rss_report_mib": max(x[1] for x in runs), "triangles": r["triangles"]}


def vtk_run(source, out, repeat=3, threads=None):
    """VTK's run `repeat` times: the best of each part, the largest peak. `threads`: vtkSMPTools'
    thread count (None: its default, every core)."""
    runs = []
    for _ in range(repeat):
        extra = [str(threads)] if threads else []
        wall, rss, stdout = timed(["/usr/bin/python3", "-c", VTK_SCRIPT, source, out, *extra])
        runs.append((wall, rss, json.loads(stdout)))
    return {"wall": min(x[0] for x in runs), "extract": min(x[2]["filter"] for x in runs),
            "file_to_mesh": min(x[2]["read"] + x[2]["filter"] + x[2]["write"] for x in runs),
            "rss_mib": max(x[1] for x in runs), "triangles": runs[0][2]["triangles"]}


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--program", default="build/cli/isoslab")
    parser.add_argument("--out", default=tempfile.mkdtemp(prefix="labels-bench-"))
    parser.add_argument("--big", type=int, default=1024, help="edge of the large phantom (0: skip)")
    a = parser.parse_args()
    os.makedirs(a.out, exist_ok=True)
    aal = "/usr/share/mricron/templates/aal.nii.gz"
    rows = []

    def row(name, result):
        rows.append((name, result))
        print(f"{name:44s} wall {result['wall']:7.3f} s  (report {result.get('wall_report', result['wall']):7.3f} s)  "
              f"extract {result['extract']:7.3f} s  "
              f"RSS {result['rss_mib']:7.1f} MiB (report {result.get('rss_report_mib', result['rss_mib']):7.1f})  triangles {result['triangles']:>11,}", flush=True)

    if os.path.exists(aal):
        for threads in (1, 2):
            row(f"isoslab labels, aal, {threads} thread(s), .ply",
                isoslab(a.program, [aal], f"{a.out}/aal.ply", threads, repeat=7))
        row("isoslab mc --iso 1, aal, 1 thread, .ply", isoslab(a.program, [aal, "--iso", "1"], f"{a.out}/mc.ply", 1, repeat=7))
        row("VTK reader + discrete FE + PLY, aal", vtk_run(aal, f"{a.out}/vtk.ply", repeat=5))
        row("VTK reader + discrete FE + PLY, aal, 1 thread", vtk_run(aal, f"{a.out}/vtk1.ply", repeat=5, threads=1))
    small = "phantom:checker?n=256&b=25&labels=1000"
    for threads in (1, 2):
        row(f"isoslab labels, checker 256^3, {threads} thread(s)", isoslab(a.program, [small], f"{a.out}/c256.ply", threads))
    row("isoslab mc --iso 1, checker 256^3, 1 thread",
        isoslab(a.program, [small, "--iso", "1"], f"{a.out}/c256mc.ply", 1))
    row("VTK discrete FE + PLY, checker 256^3", vtk_run("phantom:256,25,1000", f"{a.out}/c256vtk.ply", repeat=1))
    if a.big:
        big = f"phantom:checker?n={a.big}&b={a.big // 10}&labels=1000"
        for threads in (1, 2):
            row(f"isoslab labels, checker {a.big}^3, {threads} thread(s)",
                isoslab(a.program, [big], f"{a.out}/cbig.ply", threads, repeat=1))
            os.remove(f"{a.out}/cbig.ply")
    results = {name: r for name, r in rows}
    aal1 = results.get("isoslab labels, aal, 1 thread(s), .ply")
    vtk = results.get("VTK reader + discrete FE + PLY, aal")
    mc = results.get("isoslab mc --iso 1, aal, 1 thread, .ply")
    vtk1 = results.get("VTK reader + discrete FE + PLY, aal, 1 thread")
    if aal1 and vtk1:
        print(f"aal against VTK at one thread: extraction {vtk1['extract'] / aal1['extract']:.1f}x its filter; "
              f"file to mesh {vtk1['file_to_mesh'] / aal1['wall']:.1f}x its reader, filter and writer")
    if aal1 and vtk and mc:
        print(f"aal: extraction {vtk['extract'] / aal1['extract']:.1f}x VTK's filter (goal 20x); file to mesh "
              f"{vtk['file_to_mesh'] / aal1['wall']:.1f}x VTK's reader, filter and writer (goal 8x; "
              f"{vtk['wall'] / aal1['wall']:.1f}x its wall with Python's start); memory {aal1['rss_mib'] / vtk['rss_mib']:.2f} "
              f"of VTK's (goal 0.1); voxel throughput {mc['extract'] / aal1['extract']:.2f} of plain mc's (goal 0.5)")
    json.dump(results, open(f"{a.out}/labels-bench.json", "w"), indent=1)


if __name__ == "__main__":
    main()
