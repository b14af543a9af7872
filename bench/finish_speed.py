#!/usr/bin/python3
"""Finishing at extraction speed (issue 36), in one run: isoslab's streamed decimation against the
whole-mesh simplifiers on the same surfaces.

Inputs: the Philips head at -400 HU (../shared/data), the MRI brain of Debian's mricron-data at 50,
and a 512x512x256 noisy head phantom at -400 (written as NIfTI first, so that the phantom's own
cost is not timed). For each, and for 1 and 2 threads:
- isoslab: plain extraction, `--decimate 0.1`, `--smooth 10 --decimate 0.1` (wall time, peak RSS,
  triangles; the decimation's added time is the decimated run less the plain one). All three write
  PLY, so that the added time is the finishing's alone: a `.glb` run also pays Draco's encoding of
  its output, which meshoptimizer's and VTK's timed calls do not (and a plain `.glb` run would pay
  it on ten times the triangles). One more `--decimate 0.1` run to `.glb` shows what that encoding
  adds (and gives the peak with the `.glb` encoder, as a user's run has it);
- on the plain mesh read from PLY: meshoptimizer's whole-mesh `meshopt_simplify` (Debian's 0.18,
  locked border) to the count isoslab kept (bench/isoslab_simplify_whole, the call alone),
  isoslab's own simplifier (process/simplifier.h) in the same harness, to the same count with no
  error bound and no distance checks (the core of the streamed decimation, on the whole mesh),
  `vtkDecimatePro` and `vtkQuadricDecimation` (Debian's VTK 9.1, the filter alone, target reduction
  0.9).
With --old, an older build runs beside each isoslab run, in turn (paired, as the machine's speed
drifts).

    /usr/bin/python3 bench/finish_speed.py [--program build/cli/isoslab] [--old OLD_ISOSLAB]
        [--simplify build/bench/isoslab_simplify_whole] [--only philips,brain,phantom] [--no-vtk]
"""

import argparse
import json
import os
import subprocess
import tempfile

from timing import timed  # bench/timing.py

HERE = os.path.dirname(os.path.abspath(__file__))
SHARED = os.path.join(HERE, "..", "..", "shared", "data")

VTK_SCRIPT = r"""
import sys, time, json, vtk
path, which = sys.argv[1], sys.argv[2]
reader = vtk.vtkPLYReader()
reader.SetFileName(path)
reader.Update()
mesh = reader.GetOutput()
f = vtk.vtkDecimatePro() if which == "pro" else vtk.vtkQuadricDecimation()
f.SetInputData(mesh)
f.SetTargetReduction(0.9)
if which == "pro":
    f.PreserveTopologyOn()
t0 = time.perf_counter()
f.Update()
t1 = time.perf_counter()
print(json.dumps({"seconds": t1 - t0, "triangles": f.GetOutput().GetNumberOfCells(),
                  "triangles_in": mesh.GetNumberOfCells()}))
"""


def isoslab(program, source, iso, out, threads, extra):
    """The timed run has no --report, as a user's run (a report also measures the decimated
    surface's distance to the original, which meshoptimizer's and VTK's runs do not); a second run
    with --report gives the counts."""
    report = out + ".json"
    command = [program, "extract", *source, "--iso", str(iso), "--threads", str(threads), *extra, "-o", out, "-q"]
    wall, rss, _ = timed(command)
    wall_report, _, _ = timed([*command, "--report", report])
    r = json.load(open(report))
    return {"wall": wall, "wall_report": wall_report, "rss_mib": rss, "triangles": r["triangles"],
            "decimation": r.get("decimation")}


def finish_inputs(program, only, out):
    """The issue's inputs as (label, source arguments, iso), those of `only` that are here: the
    Philips head, the MRI brain, and the noisy phantom, written to `out` as NIfTI first (so that its
    own making is not timed). bench/finish_ratio.py uses the same."""
    inputs = []
    philips = os.path.join(SHARED, "ct-philips-head")
    if "philips" in only and os.path.isdir(philips):
        inputs.append(("Philips head, -400 HU", [philips], -400))
    brain = "/usr/share/mricron/templates/ch2better.nii.gz"
    if "brain" in only and os.path.exists(brain):
        inputs.append(("MRI brain (ch2better), 50", [brain], 50))
    if "phantom" in only:
        phantom = os.path.join(out, "head512.nii")
        subprocess.run([program, "phantom", "phantom:head?n=512,512,256", "-o", phantom], check=True,
                       capture_output=True)
        inputs.append(("noisy head 512x512x256, -400", [phantom], -400))
    return inputs


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--program", default="build/cli/isoslab")
    parser.add_argument("--old", help="an older isoslab, run beside each isoslab run")
    parser.add_argument("--simplify", default="build/bench/isoslab_simplify_whole")
    parser.add_argument("--only", default="philips,brain,phantom")
    parser.add_argument("--no-vtk", action="store_true")
    parser.add_argument("--out", default=tempfile.mkdtemp(prefix="finish-speed-"))
    a = parser.parse_args()
    os.makedirs(a.out, exist_ok=True)
    inputs = finish_inputs(a.program, a.only, a.out)
    programs = [("isoslab", a.program)] + ([("old", a.old)] if a.old else [])
    results = []

    def show(name, r):
        results.append((name, r))
        extra = ""
        if r.get("added") is not None:
            extra = f"  decimation adds {r['added']:7.2f} s"
        print(f"{name:70s} {r['wall']:8.2f} s  {r.get('rss_mib', 0):7.1f} MiB  {r['triangles']:>10,} triangles{extra}",
              flush=True)

    for label, source, iso in inputs:
        plain_mesh = os.path.join(a.out, "plain.ply")
        kept = None
        for threads in (1, 2):
            plain = {}
            for who, program in programs:
                plain[who] = isoslab(program, source, iso, plain_mesh if who == "isoslab" else plain_mesh + ".old.ply",
                                     threads, [])
                show(f"{label}: {who} extract, {threads} thread(s)", plain[who])
            for finish, ext in ((["--decimate", "0.1"], "ply"), (["--smooth", "10", "--decimate", "0.1"], "ply"),
                                (["--decimate", "0.1"], "glb")):
                for who, program in programs:
                    r = isoslab(program, source, iso, os.path.join(a.out, f"{who}.{ext}"), threads, finish)
                    r["added"] = r["wall"] - plain[who]["wall"]
                    show(f"{label}: {who} {' '.join(finish)} to .{ext}, {threads} thread(s)", r)
                    if who == "isoslab" and finish[0] == "--decimate":
                        kept = r["triangles"]
        if kept and os.path.exists(a.simplify):
            wall, rss, out = timed([a.simplify, plain_mesh, str(kept)])
            r = json.loads(out)
            show(f"{label}: meshoptimizer whole mesh to {kept:,} (the call)", {"wall": r["seconds"], "rss_mib": rss,
                                                                               "triangles": r["triangles"]})
            # isoslab's own simplifier on the same whole mesh, to the same count, with no error bound
            # and no distance checks: the core that the streamed decimation runs, against meshoptimizer's.
            wall, rss, out = timed([a.simplify, plain_mesh, str(kept), "isoslab"])
            r = json.loads(out)
            show(f"{label}: isoslab's simplifier, whole mesh to {kept:,}, no bound (the call)",
                 {"wall": r["seconds"], "rss_mib": rss, "triangles": r["triangles"]})
        if not a.no_vtk:
            for which, name in (("pro", "vtkDecimatePro"), ("quadric", "vtkQuadricDecimation")):
                wall, rss, out = timed(["/usr/bin/python3", "-c", VTK_SCRIPT, plain_mesh, which])
                r = json.loads(out)
                show(f"{label}: {name}, 0.9 reduction (the filter)", {"wall": r["seconds"], "rss_mib": rss,
                                                                     "triangles": r["triangles"]})
    json.dump(results, open(os.path.join(a.out, "finish-speed.json"), "w"), indent=1)


if __name__ == "__main__":
    main()
