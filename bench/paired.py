#!/usr/bin/python3
"""Two isoslab builds on the same extraction, in turn (the machine's speed drifts, so each pair runs
back to back): the extraction's own time (from --report) and the wall time of a run without a
report, best and median of each.

    /usr/bin/python3 bench/paired.py OLD_ISOSLAB NEW_ISOSLAB [--runs 15] [-- EXTRACT ARGS...]

The default extraction is every label of mricron's AAL atlas at 1 thread, to a PLY in a temporary
folder.
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time


def main():
    argv = sys.argv[1:]
    extra = []
    if "--" in argv:
        extra = argv[argv.index("--") + 1:]
        argv = argv[:argv.index("--")]
    parser = argparse.ArgumentParser()
    parser.add_argument("old")
    parser.add_argument("new")
    parser.add_argument("--runs", type=int, default=15)
    a = parser.parse_args(argv)
    if not extra:
        extra = ["/usr/share/mricron/templates/aal.nii.gz", "--labels", "all", "--threads", "1"]
    folder = tempfile.mkdtemp(prefix="isoslab-paired-")
    out, report = os.path.join(folder, "out.ply"), os.path.join(folder, "report.json")
    times = {p: ([], []) for p in (a.old, a.new)}
    for _ in range(a.runs):
        for program in (a.old, a.new):
            command = [program, "extract", *extra, "-o", out, "-q"]
            subprocess.run([*command, "--report", report], check=True)
            times[program][0].append(json.load(open(report))["seconds"]["extract"])
            start = time.perf_counter()
            subprocess.run(command, check=True)
            times[program][1].append(time.perf_counter() - start)
    for program, (extract, wall) in times.items():
        extract.sort()
        wall.sort()
        print(f"{program:40s} extraction best {extract[0] * 1000:7.1f} ms, median {extract[len(extract) // 2] * 1000:7.1f}; "
              f"wall best {wall[0] * 1000:7.1f} ms, median {wall[len(wall) // 2] * 1000:7.1f}")
    old, new = times[a.old], times[a.new]
    print(f"new / old: extraction {new[0][0] / old[0][0]:.3f}, wall {new[1][0] / old[1][0]:.3f} (best against best)")


if __name__ == "__main__":
    main()
