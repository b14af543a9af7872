#!/usr/bin/python3
"""`isoslab info --histogram` and `extract --iso auto` against numpy.histogram and scikit-image's
threshold_otsu on the same volumes, with the same bins over the same range.

For every volume and bin count: the counts and edges must equal numpy's exactly, and Otsu's split
must be scikit-image's. scikit-image returns the centre of the last lower bin, to be read as
"value > threshold"; isoslab returns that bin's upper edge (or the middle of the empty bins after
it), to be read as "value >= iso". Both split the histogram at the same bin; the printed table
gives the two values and how many voxels the two readings put on different sides.

Usage: otsu_skimage_test.py ISOSLAB_CLI SHARED_DATA_DIR
Exits 77 (ctest's skip code) when numpy or scikit-image is absent, and, after checking everything
else, when a real volume of SHARED_DATA_DIR (engine, cthead, ct-philips-head) or pydicom (for the
Philips series) is absent: a run that left a part out says so.
"""
import glob
import gzip
import json
import os
import re
import subprocess
import sys
import tempfile

try:
    import numpy as np
    from skimage.filters import threshold_otsu
except ImportError:
    print("skipped: numpy or scikit-image (python3-skimage) is not installed")
    sys.exit(77)

cli = sys.argv[1]
data = sys.argv[2] if len(sys.argv) > 2 else ""
failures = 0
left_out = []


def check(condition, what):
    global failures
    if not condition:
        failures += 1
        print("FAILED:", what)


def info_histogram(args, bins):
    out = subprocess.run([cli, "info", *args, "--histogram", "--bins", str(bins)], check=True,
                         capture_output=True, text=True).stdout
    rows, otsu, inside = [], None, False
    for line in out.splitlines():
        if "bin    from" in line:
            inside = True
        elif "(a bin holds" in line:
            inside = False
        elif inside:
            b, lo, hi, count = line.split()
            rows.append((int(b), float(lo), float(hi), int(count)))
        elif line.startswith("otsu "):
            m = re.match(r"otsu\s+(\S+) \(over these bins: bins (\d+) \.\.", line)
            otsu = (float(m.group(1)), int(m.group(2)))
    return rows, otsu, out


def compare(name, args, volume, bins_list=(256, 64)):
    values = volume.astype(np.float64).ravel()
    for bins in bins_list:
        rows, otsu, out = info_histogram(args, bins)
        counts, edges = np.histogram(values, bins=bins, range=(values.min(), values.max()))
        check(len(rows) == bins, f"{name}: {len(rows)} rows for {bins} bins\n{out}")
        if len(rows) != bins:
            continue
        check([r[3] for r in rows] == counts.tolist(), f"{name} {bins} bins: counts differ from numpy's")
        check([r[1] for r in rows] == edges[:-1].tolist() and [r[2] for r in rows] == edges[1:].tolist(),
              f"{name} {bins} bins: edges differ from numpy's")
        threshold = threshold_otsu(values, nbins=bins)
        centres = (edges[:-1] + edges[1:]) / 2
        matches = np.flatnonzero(centres == threshold)
        check(len(matches) == 1, f"{name}: scikit-image's threshold {threshold} is not a bin centre")
        iso, first_upper = otsu
        check(first_upper == matches[0] + 1,
              f"{name} {bins} bins: isoslab splits before bin {first_upper}, scikit-image before {matches[0] + 1}")
        occupied = first_upper
        while counts[occupied] == 0:
            occupied += 1
        expected = edges[first_upper] if occupied == first_upper else (edges[first_upper] + edges[occupied]) / 2
        check(iso == expected, f"{name} {bins} bins: iso {iso}, expected {expected}")
        differ = int(np.count_nonzero((values >= iso) != (values > threshold)))
        width = edges[1] - edges[0]
        print(f"{name:28} {bins:4} bins  isoslab {iso:<12.6g} scikit-image {threshold:<12.6g} "
              f"split bin {first_upper:4} (same: {first_upper == matches[0] + 1})  "
              f"difference {iso - threshold:.6g} = {(iso - threshold) / width:.3g} bins  "
              f"voxels on other sides {differ} of {values.size}")
    return otsu


with tempfile.TemporaryDirectory() as d:
    # The head phantom (16-bit, few distinct values: one pass).
    head = os.path.join(d, "head.raw")
    subprocess.run([cli, "phantom", "phantom:head?n=64,64,48", "-o", head], check=True, capture_output=True)
    volume = np.fromfile(head, dtype="<i2")
    compare("phantom:head 64x64x48", [head, "--raw-dims", "64,64,48", "--raw-type", "i16"], volume)

    # --iso auto on it: the report's iso is the 256-bin split's.
    report = os.path.join(d, "r.json")
    subprocess.run([cli, "extract", head, "--raw-dims", "64,64,48", "--raw-type", "i16", "--iso", "auto", "-q",
                    "-o", os.path.join(d, "h.ply"), "--report", report], check=True)
    iso256 = info_histogram([head, "--raw-dims", "64,64,48", "--raw-type", "i16"], 256)[1][0]
    check(json.load(open(report))["iso"] == iso256, "extract --iso auto differs from info's 256-bin threshold")

    # Two normal modes in float32, nearly every value distinct (a second pass bins).
    rng = np.random.default_rng(17)
    n = 64 * 64 * 40
    noisy = np.where(rng.random(n) < 0.6, rng.normal(-800, 60, n), rng.normal(40, 30, n)).astype("<f4")
    noisy.tofile(os.path.join(d, "noisy.raw"))
    compare("bimodal float32 64x64x40", [os.path.join(d, "noisy.raw"), "--raw-dims", "64,64,40", "--raw-type", "f32"],
            noisy)

    # Real volumes, when present.
    engine = os.path.join(data, "engine")
    files = sorted(glob.glob(os.path.join(engine, "*.gz")) + glob.glob(os.path.join(engine, "*.raw")))
    if files:
        raw = files[0]
        with (gzip.open(raw) if raw.endswith(".gz") else open(raw, "rb")) as f:
            volume = np.frombuffer(f.read(), dtype=np.uint8)
        compare("engine (u8)", [raw, "--raw-dims", "256,256,128"], volume)
    else:
        left_out.append(f"{engine} is absent")
    cthead = os.path.join(data, "cthead")
    if os.path.isdir(cthead):
        slices = [np.fromfile(os.path.join(cthead, f"CThead.{k}"), dtype=">u2") for k in range(1, 114)]
        compare("CThead (u16 big-endian)", [cthead, "--raw-dims", "256,256", "--raw-type", "u16", "--raw-endian",
                                            "big"], np.concatenate(slices))
    else:
        left_out.append(f"{cthead} is absent")
    philips = os.path.join(data, "ct-philips-head")
    if os.path.isdir(philips):
        try:
            import pydicom
        except ImportError:
            pydicom = None
        if pydicom is not None:
            values = []
            for path in sorted(glob.glob(os.path.join(philips, "I*"))):
                ds = pydicom.dcmread(path)
                values.append(ds.pixel_array.astype(np.float64) * float(ds.RescaleSlope) +
                              float(ds.RescaleIntercept))
            # info lists DICOM series with indented lines; read the one series through its own parser.
            out = subprocess.run([cli, "info", philips, "--histogram"], check=True, capture_output=True,
                                 text=True).stdout
            rows = [line.split() for line in out.splitlines() if re.match(r"^\s{17}\d+\s", line)]
            volume = np.concatenate([v.ravel() for v in values])
            counts, edges = np.histogram(volume, bins=256, range=(volume.min(), volume.max()))
            check([int(r[3]) for r in rows] == counts.tolist(), "Philips CT: counts differ from numpy's")
            m = re.search(r"otsu\s+(\S+) \(over these bins: bins (\d+) \.\.", out)
            threshold = threshold_otsu(volume, nbins=256)
            k = int(np.flatnonzero((edges[:-1] + edges[1:]) / 2 == threshold)[0]) + 1
            check(m and int(m.group(2)) == k, f"Philips CT: split bin {m and m.group(2)} against scikit-image's {k}")
            print(f"{'Philips head CT (DICOM)':28}  256 bins  isoslab {float(m.group(1)):<12.6g} scikit-image "
                  f"{threshold:<12.6g} split bin {m.group(2)} (same: {int(m.group(2)) == k})")
        else:
            left_out.append("pydicom (python3-pydicom) is not installed, for the Philips series")
    else:
        left_out.append(f"{philips} is absent")

if failures:
    print(f"{failures} check(s) failed")
    sys.exit(1)
if left_out:
    print("skipped: the real volumes' part: " + "; ".join(left_out))
    sys.exit(77)
print("histograms and Otsu splits agree with numpy and scikit-image")
