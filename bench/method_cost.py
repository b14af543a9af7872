#!/usr/bin/python3
"""Extraction cost of mc33 against mc and of mt24 against mt6, in paired, interleaved rounds.

The goals measured: mc33's extraction time at most 1.3x mc's, and mt24's at most 2x mt6's, on
the MRI brain (iso 50) and the head phantom (iso 300); the engine CT (iso 90) is a third volume.

This machine's speed drifts by up to 2x within minutes, so times taken minutes apart are not
compared. Each round runs bench/isoslab_extract_only for mc, mc33, mt6 and mt24 back to back on
one volume (single thread, --runs R each, its median_seconds), and the ratios mc33/mc and
mt24/mt6 are taken within that round. The table gives, over the rounds, the median of each ratio
with its min and max, and the median of each method's seconds. Odd rounds swap the order within
each pair (mc33 before mc, mt24 before mt6) so that neither method always runs second. With
--threads2 (the default) each round also times mc33 and mt24 on 2 threads, after the pairs.

Inputs, prepared once in a temporary folder as bench/peers.py prepares them:
- MRI brain: /usr/share/mricron/templates/ch2better.nii.gz, decompressed (skipped if absent);
- head phantom: `isoslab phantom phantom:head?n=512,512,256` as int16 NIfTI;
- engine: ../shared/data/engine/engine_256x256x128_uint8.raw.gz wrapped in a NIfTI-1 header
  (isoslab_extract_only takes no raw options); skipped if absent.

Usage:
  /usr/bin/python3 bench/method_cost.py [--isoslab build/cli/isoslab]
      [--extract-only build/bench/isoslab_extract_only] [--rounds 5] [--runs 3] [--no-threads2]
Prints Markdown tables for docs/performance.md and the command line that made them.
"""
import argparse
import gzip
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
METHODS = ("mc", "mc33", "mt6", "mt24")
PAIRS = (("mc33", "mc", 1.3), ("mt24", "mt6", 2.0))  # (method, its base, the goal's largest ratio)
GOAL_VOLUMES = ("MRI brain", "head phantom")  # the engine is measured for context only


def write_nifti_u8(raw, dims, path):
    """A NIfTI-1 file (uint8, spacing 1) holding raw, a volume of dims (x fastest)."""
    header = bytearray(352)
    header[0:4] = np.int32(348).tobytes()
    header[40:56] = np.array([3, *dims, 1, 1, 1, 1], "<i2").tobytes()
    header[70:72] = np.int16(2).tobytes()  # datatype: unsigned char
    header[72:74] = np.int16(8).tobytes()  # bits per voxel
    header[76:108] = np.ones(8, "<f4").tobytes()  # pixdim
    header[108:112] = np.float32(352).tobytes()  # vox_offset
    header[344:348] = b"n+1\0"
    with open(path, "wb") as f:
        f.write(bytes(header))
        f.write(raw)


def prepare_volumes(isoslab, workdir):
    """[(name, description, path, iso)] of the volumes present, written into workdir."""
    out = []
    brain = "/usr/share/mricron/templates/ch2better.nii.gz"
    if os.path.exists(brain):
        path = os.path.join(workdir, "brain.nii")
        with gzip.open(brain) as src, open(path, "wb") as dst:
            shutil.copyfileobj(src, dst)
        out.append(("MRI brain", "mricron ch2better 301x370x316 u8", path, 50.0))
    else:
        print(f"note: {brain} absent (Debian's mricron-data); the brain is skipped", file=sys.stderr)
    path = os.path.join(workdir, "phantom.nii")
    subprocess.run([isoslab, "phantom", "phantom:head?n=512,512,256", "-o", path], check=True,
                   stdout=subprocess.DEVNULL)
    out.append(("head phantom", "isoslab phantom:head 512x512x256 i16", path, 300.0))
    engine = os.path.join(ROOT, "..", "shared", "data", "engine", "engine_256x256x128_uint8.raw.gz")
    if os.path.exists(engine):
        path = os.path.join(workdir, "engine.nii")
        write_nifti_u8(gzip.open(engine).read(), (256, 256, 128), path)
        out.append(("engine", "engine CT 256x256x128 u8", path, 90.0))
    else:
        print(f"note: {engine} absent; the engine is skipped", file=sys.stderr)
    return out


def extract_only(binary, path, iso, method, threads, runs):
    """(median seconds of `runs` extractions, triangles) from bench/isoslab_extract_only."""
    out = subprocess.run([binary, path, "--iso", repr(iso), "--method", method, "--threads", str(threads),
                          "--runs", str(runs)], check=True, capture_output=True, text=True).stdout
    result = json.loads(out)
    return result["median_seconds"], result["triangles"]


def round_order(index):
    """The order of the runs in round `index`: the pairs back to back, swapped in odd rounds."""
    if index % 2 == 0:
        return ["mc", "mc33", "mt6", "mt24"]
    return ["mc33", "mc", "mt24", "mt6"]


def spread(values, digits=2):
    """'median (min–max)'."""
    return f"{statistics.median(values):.{digits}f} ({min(values):.{digits}f}–{max(values):.{digits}f})"


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--isoslab", default=os.path.join(ROOT, "build", "cli", "isoslab"))
    parser.add_argument("--extract-only", help="default: bench/isoslab_extract_only in --isoslab's build folder")
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--runs", type=int, default=3, help="extractions per isoslab_extract_only call")
    parser.add_argument("--no-threads2", dest="threads2", action="store_false",
                        help="skip the 2-thread times of mc33 and mt24")
    args = parser.parse_args()
    binary = args.extract_only or os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(args.isoslab))),
                                               "bench", "isoslab_extract_only")
    for tool in (args.isoslab, binary):
        if not os.access(tool, os.X_OK):
            sys.exit(f"{tool}: not found or not executable")

    workdir = tempfile.mkdtemp(prefix="isoslab-method-cost-")
    started = time.perf_counter()
    try:
        volumes = prepare_volumes(args.isoslab, workdir)
        # seconds[name][method] and seconds2[name][method]: one value per round;
        # ratios[name][method]: method / its base, one per round.
        seconds = {name: {m: [] for m in METHODS} for name, _, _, _ in volumes}
        seconds2 = {name: {m: [] for m, _, _ in PAIRS} for name, _, _, _ in volumes}
        ratios = {name: {m: [] for m, _, _ in PAIRS} for name, _, _, _ in volumes}
        triangles = {name: {} for name, _, _, _ in volumes}
        for r in range(args.rounds):
            for name, _, path, iso in volumes:
                this_round = {}
                for method in round_order(r):
                    t, tris = extract_only(binary, path, iso, method, 1, args.runs)
                    this_round[method] = t
                    seconds[name][method].append(t)
                    if triangles[name].setdefault(method, tris) != tris:
                        sys.exit(f"{name} {method}: {tris} triangles in round {r + 1}, "
                                 f"{triangles[name][method]} before")
                for method, base, _ in PAIRS:
                    ratios[name][method].append(this_round[method] / this_round[base])
                if args.threads2:
                    for method, _, _ in PAIRS:
                        seconds2[name][method].append(extract_only(binary, path, iso, method, 2, args.runs)[0])
            print(f"round {r + 1}/{args.rounds} done, {time.perf_counter() - started:.0f} s", file=sys.stderr)
    finally:
        shutil.rmtree(workdir, ignore_errors=True)

    version = subprocess.run([args.isoslab, "--version"], capture_output=True, text=True).stdout.strip()
    command = " ".join(["/usr/bin/python3", "bench/method_cost.py", *sys.argv[1:]])
    print(f"`{command}`: isoslab {version}, {args.rounds} rounds, each method's time the median of "
          f"{args.runs} extractions (isoslab_extract_only, 1 thread); {time.perf_counter() - started:.0f} s "
          f"in all, load average {os.getloadavg()[0]:.2f} at the end.")
    print()
    header = "| volume | iso | method | triangles | 1 thread s | ratio to base (median, min–max) |"
    rule = "|---|---|---|---|---|---|"
    if args.threads2:
        header += " 2 threads s |"
        rule += "---|"
    print(header)
    print(rule)
    base_of = {m: b for m, b, _ in PAIRS}
    for name, _, _, iso in volumes:
        for method in METHODS:
            ratio = f"{method}/{base_of[method]} {spread(ratios[name][method])}" if method in base_of else ""
            row = (f"| {name} | {iso:g} | {method} | {triangles[name][method]:,} | "
                   f"{statistics.median(seconds[name][method]):.3f} | {ratio} |")
            if args.threads2:
                row += f" {statistics.median(seconds2[name][method]):.3f} |" if method in base_of else " |"
            print(row)
    print()
    print("| volume | mc33/mc (goal ≤ 1.3) | mt24/mt6 (goal ≤ 2) |")
    print("|---|---|---|")
    for name, _, _, _ in volumes:
        cells = []
        for method, _, goal in PAIRS:
            median = statistics.median(ratios[name][method])
            if name not in GOAL_VOLUMES:
                verdict = "(no goal)"
            elif max(ratios[name][method]) <= goal:
                verdict = "met"
            else:
                verdict = "met (median)" if median <= goal else "**missed**"
            cells.append(f"{spread(ratios[name][method])} {verdict}")
        print(f"| {name} | {' | '.join(cells)} |")
    print()
    print("Ratios are taken within a round (the two methods run back to back on the same volume), then the "
          "median over the rounds is given with the min–max in parentheses. Seconds are medians over the "
          "rounds. \"met\": every round within the goal; \"met (median)\": the median only. The goals are set on "
          "the brain and the phantom; the engine is given for context.")
    print(f"Volumes: {'; '.join(f'{name}: {what}, iso {iso:g}' for name, what, _, iso in volumes)}.")


if __name__ == "__main__":
    main()
