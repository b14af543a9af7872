#!/usr/bin/python3
"""Rank scaling of `isoslab extract` under mpirun (issue 20; docs/scaling.md).

For each volume and format: one process (no mpirun), then 1, 2 and 4 ranks (oversubscribed on
this machine), in paired rounds (the machine's speed drifts), each rank on one thread unless
--threads is given. Prints the median wall time, the ratio to one process, each rank's peak RSS
(/usr/bin/time around every rank), and the per-slab costs that docs/scaling.md's model uses:
extraction seconds per slab (the report's seconds.extract over the slabs) and the bytes each slab
adds to the output (which a rank ships to rank 0).

Usage: bench/ranks.py [BUILD_DIR] [--runs N] [--threads T] [--big]
  --big: also the 1024^3 i16 phantom (a 2 GiB .nii in $TMPDIR) on 1 process and 2 ranks at the default
         threads, peak RSS per rank (about 10 minutes).
"""
import json
import os
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

args = sys.argv[1:]
BUILD = next((a for i, a in enumerate(args) if not a.startswith("--") and (i == 0 or args[i - 1] not in ("--runs", "--threads"))), "build")
RUNS = int(args[args.index("--runs") + 1]) if "--runs" in args else 3
THREADS = int(args[args.index("--threads") + 1]) if "--threads" in args else 1
ISOSLAB = os.path.abspath(os.path.join(BUILD, "cli", "isoslab"))
MPIRUN = shutil.which("mpirun")
TMP = tempfile.mkdtemp(prefix="isoslab-ranks-")
ENV = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")


def run(ranks, spec, iso, out, threads):
    """Wall seconds, the report, and each rank's peak RSS in MiB (ranks = 0: no mpirun)."""
    report = os.path.join(TMP, "r.json")
    rss = os.path.join(TMP, "rss")
    cmd = ["/usr/bin/time", "-f", "%M", "-o", rss + ".0"] if ranks == 0 else [
        MPIRUN, "-q", "--oversubscribe", "-np", str(ranks), "sh", "-c",
        '/usr/bin/time -f %M -o "$0.$OMPI_COMM_WORLD_RANK" "$@"', rss]
    cmd += [ISOSLAB, "extract", spec, "--iso", str(iso), "-q", "-o", out, "--report", report]
    if threads is not None:
        cmd += ["--threads", str(threads)]
    t = time.perf_counter()
    subprocess.run(cmd, check=True, env=ENV)
    wall = time.perf_counter() - t
    peaks = []
    for k in range(max(1, ranks)):
        text = open(f"{rss}.{k}").read()
        peaks.append(int(re.findall(r"(\d+)\s*$", text)[0]) / 1024)
    return wall, json.load(open(report)), peaks


def table(name, spec, iso, slabs, ext, rank_counts, runs, threads):
    out = os.path.join(TMP, "out." + ext)
    rows = {r: [] for r in rank_counts}
    last = {}
    for _ in range(runs):
        for r in rank_counts:
            wall, report, peaks = run(r, spec, iso, out, threads)
            rows[r].append(wall)
            last[r] = (report, peaks, os.path.getsize(out))
    base = statistics.median(rows[0])
    threads_text = f"{threads} thread(s) per rank" if threads is not None else "default threads (the cores, shared among the ranks)"
    print(f"\n{name}, .{ext}, {threads_text}, median of {runs}\n")
    print("| processes | wall s | / 1 process | peak RSS per rank MiB | extract s (summed) | output bytes per slab |")
    print("|---|---|---|---|---|---|")
    for r in rank_counts:
        report, peaks, size = last[r]
        label = "1 process" if r == 0 else f"{r} ranks"
        print(f"| {label} | {statistics.median(rows[r]):.2f} | {statistics.median(rows[r]) / base:.2f} | "
              f"{' / '.join(f'{p:.0f}' for p in peaks)} | {report['seconds']['extract']:.2f} | {size / slabs:.0f} |")
    report = last[0][0]
    print(f"\nper slab, 1 process: extract {report['seconds']['extract'] / slabs * 1e3:.2f} ms, "
          f"write {report['seconds']['write'] / slabs * 1e3:.2f} ms, read {report['seconds']['read'] / slabs * 1e3:.2f} ms; "
          f"{report['triangles']} triangles")


def main():
    if MPIRUN is None:
        sys.exit("bench/ranks.py: mpirun is missing (Debian: openmpi-bin)")
    try:
        # The phantom as a file: computing it would be most of the time (about 20 ms a slice).
        head = os.path.join(TMP, "head512.nii")
        subprocess.run([ISOSLAB, "phantom", "phantom:head?n=512,512,512", "-o", head], check=True,
                       stdout=subprocess.DEVNULL)
        for ext in ("ply", "glb"):
            table("head phantom 512 x 512 x 512 i16 (.nii), iso 300", head, 300, 511, ext, [0, 1, 2, 4], RUNS, THREADS)
        philips = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "..", "shared", "data",
                               "ct-philips-head")
        if os.path.isdir(philips):
            for ext in ("ply", "glb"):
                table("Philips CT series 512 x 512 x 140 (DICOM), iso 300", philips, 300, 139, ext, [0, 1, 2, 4], RUNS,
                      THREADS)
        if "--big" in args:
            big = os.path.join(TMP, "head1024.nii")
            subprocess.run([ISOSLAB, "phantom", "phantom:head?n=1024,1024,1024", "-o", big], check=True,
                           stdout=subprocess.DEVNULL)
            for ext in ("ply", "glb"):
                table("head phantom 1024 x 1024 x 1024 i16 (.nii), iso 300", big, 300, 1023, ext, [0, 2], 1, None)
    finally:
        shutil.rmtree(TMP, ignore_errors=True)


main()
