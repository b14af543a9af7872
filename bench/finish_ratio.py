#!/usr/bin/python3
"""Issue 36's two speed ratios in paired rounds, as the machine's speed drifts by up to 2x within
minutes (bench/finish_speed.py runs each kind once, minutes apart).

Each round runs back to back, on each input: the plain extraction and `--decimate 0.1` at 1 thread,
meshoptimizer's whole-mesh call to the count that isoslab kept (bench/isoslab_simplify_whole on the
plain PLY), then the plain extraction and `--decimate 0.1` at 2 threads. Every isoslab run writes
PLY, so that the added time is the decimation's alone. Per round it prints the added time at 1
thread over meshoptimizer's call (goal: at most 1) and the added time at 1 thread over that at 2
(goal: at least 1.6), then the medians.

    /usr/bin/python3 bench/finish_ratio.py [--program build/cli/isoslab]
        [--simplify build/bench/isoslab_simplify_whole] [--rounds 4] [--only philips,brain,phantom]
"""

import argparse
import json
import os
import statistics
import subprocess
import tempfile
import time

from finish_speed import finish_inputs  # bench/finish_speed.py


def wall(command):
    start = time.perf_counter()
    subprocess.run(command, check=True, capture_output=True)
    return time.perf_counter() - start


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--program", default="build/cli/isoslab")
    parser.add_argument("--simplify", default="build/bench/isoslab_simplify_whole")
    parser.add_argument("--rounds", type=int, default=4)
    parser.add_argument("--only", default="philips,brain,phantom")
    a = parser.parse_args()
    out = tempfile.mkdtemp(prefix="finish-ratio-")
    inputs = finish_inputs(a.program, a.only, out)
    plain_mesh, decimated = os.path.join(out, "plain.ply"), os.path.join(out, "decimated.ply")
    for label, source, iso in inputs:
        def run(threads, extra, path):
            return wall([a.program, "extract", *source, "--iso", str(iso), "--threads", str(threads), *extra,
                         "-o", path, "-q"])

        report = os.path.join(out, "report.json")
        subprocess.run([a.program, "extract", *source, "--iso", str(iso), "--threads", "1", "--decimate", "0.1",
                        "-o", decimated, "-q", "--report", report], check=True, capture_output=True)
        kept = json.load(open(report))["triangles"]
        ratios, speedups = [], []
        for r in range(a.rounds):
            plain1 = run(1, [], plain_mesh)
            added1 = run(1, ["--decimate", "0.1"], decimated) - plain1
            meshopt = json.loads(subprocess.run([a.simplify, plain_mesh, str(kept), "meshopt"], check=True,
                                                capture_output=True, text=True).stdout)["seconds"]
            plain2 = run(2, [], plain_mesh)
            added2 = run(2, ["--decimate", "0.1"], decimated) - plain2
            ratios.append(added1 / meshopt)
            speedups.append(added1 / added2)
            print(f"{label}, round {r + 1}: added {added1:.2f} s at 1 thread, {added2:.2f} s at 2; meshopt "
                  f"{meshopt:.2f} s; added / meshopt {ratios[-1]:.2f}; 2-thread speedup {speedups[-1]:.2f}",
                  flush=True)
        print(f"{label}: median added / meshopt {statistics.median(ratios):.2f}, median 2-thread speedup "
              f"{statistics.median(speedups):.2f}", flush=True)


if __name__ == "__main__":
    main()
