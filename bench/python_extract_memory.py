#!/usr/bin/env python3
"""Peak memory of isoslab.extract() from Python on an array against the program on the same raw
file (issue 34): the goal is Python's peak <= the program's peak + the array + 10%.

    /usr/bin/python3 bench/python_extract_memory.py BUILD [--shape 1024,512,512] [--iso 100]

Writes a noisy head phantom of SHAPE (slices, rows, columns) as int16 raw, runs
`isoslab extract` on it, then a fresh Python that loads the raw file into an array
(np.fromfile: the array's pages are resident) and calls isoslab.extract() on it. Peak RSS is
each process's VmHWM (ru_maxrss of the child). Prints one table; exits 1 when over the goal.
"""
import argparse
import os
import resource
import subprocess
import sys
import tempfile

CHILD = r'''
import resource, sys, time, numpy as np
sys.path.insert(0, sys.argv[1])
import isoslab
shape = tuple(int(v) for v in sys.argv[3].split(","))
a = np.fromfile(sys.argv[2], "<i2").reshape(shape)
loaded = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
t = time.monotonic()
r = isoslab.extract(a, sys.argv[4], iso=float(sys.argv[5]), threads=int(sys.argv[6]), progress=False)
print(loaded, resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, time.monotonic() - t, r["triangles"])
'''


def main():
    p = argparse.ArgumentParser()
    p.add_argument("build")
    p.add_argument("--shape", default="1024,512,512")
    p.add_argument("--iso", default="100")
    p.add_argument("--threads", default="2")
    args = p.parse_args()
    program = os.path.join(args.build, "cli", "isoslab")
    nz, ny, nx = (int(v) for v in args.shape.split(","))
    with tempfile.TemporaryDirectory(prefix="isoslab-mem-") as work:
        raw = os.path.join(work, "v.raw")
        subprocess.run([program, "phantom", f"phantom:head?n={nx},{ny},{nz}&noise=40&type=i16", "-o", raw],
                       check=True, capture_output=True)
        array_mib = os.path.getsize(raw) / 2**20
        before = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
        run = subprocess.run(["/usr/bin/time", "-f", "%M %e", program, "extract", raw, "--raw-dims", f"{nx},{ny},{nz}",
                              "--raw-type", "i16", "--iso", args.iso, "--threads", args.threads, "-q", "-o",
                              os.path.join(work, "p.glb")], check=True, capture_output=True, text=True)
        kib, seconds = run.stderr.split()[-2:]
        program_mib = int(kib) / 1024
        child = subprocess.run(["/usr/bin/python3", "-c", CHILD, os.path.join(args.build, "python"), raw, args.shape,
                                os.path.join(work, "a.glb"), args.iso, args.threads],
                               check=True, capture_output=True, text=True)
        loaded, peak, py_seconds, triangles = child.stdout.split()
        same = open(os.path.join(work, "p.glb"), "rb").read() == open(os.path.join(work, "a.glb"), "rb").read()
    goal = (program_mib + array_mib) * 1.10
    print(f"volume {args.shape} int16 ({array_mib:.0f} MiB), iso {args.iso}, {args.threads} threads, "
          f"{triangles} triangles, same bytes: {same}")
    print(f"{'run':<34}{'peak RSS MiB':>14}{'seconds':>10}")
    print(f"{'isoslab extract on the raw file':<34}{program_mib:>14.0f}{float(seconds):>10.2f}")
    print(f"{'Python: array loaded':<34}{float(loaded):>14.0f}")
    print(f"{'Python: extract() on the array':<34}{float(peak):>14.0f}{float(py_seconds):>10.2f}")
    print(f"goal: at most (program + array) x 1.10 = {goal:.0f} MiB: {'met' if float(peak) <= goal else 'NOT met'}")
    return 0 if float(peak) <= goal and same else 1


if __name__ == "__main__":
    sys.exit(main())
