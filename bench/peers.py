#!/usr/bin/python3
"""isoslab against its peers on the same volumes and iso values, medians of several runs.

Peers (Debian packages, run with /usr/bin/python3): VTK 9.1's vtkFlyingEdges3D and
vtkMarchingCubes (python3-vtk9) and scikit-image's marching_cubes (python3-skimage).
- "extract" times: the volume already in memory. For isoslab, bench/isoslab_extract_only: the
  volume is read into memory first, then the pipeline's wall time is taken with its slices
  streamed from memory into a sink that only counts (as VTK's output stays in memory).
- "end to end": file in, binary PLY out. VTK's is its NIfTI reader + vtkFlyingEdges3D +
  vtkPLYWriter in a fresh process; isoslab's is `isoslab extract` (which also measures the mesh),
  with --threads 1 (everything on one thread) and 2 (two extraction workers, with reader and
  writer threads beside them).
- Per method (isoslab only): extraction at 1 and 2 threads, and the paper's "constant time": the
  extraction with an iso value above every voxel (no cell handled) against one read of the file.
- The DICOM series (../shared/data/ct-philips-head) to .glb, end to end, when present; and
  Draco's encoder options against meshoptimizer's codec on its mesh (bench/isoslab_codecs).
- Thread scaling: mc extraction at 1 and 2 threads in paired rounds, pinned with taskset to two
  cores and to one, and Amdahl's model for 4, 8 and 16 threads from the measured serial fraction.
- peak RSS: the process's maximum resident set size.

Usage: bench/peers.py [BUILD_DIR] [--runs N] [--quick]   (prints a Markdown table)
"""
import atexit
import gzip
import json
import shutil
import os
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np

BUILD = next((a for i, a in enumerate(sys.argv[1:], 1)
              if not a.startswith("--") and sys.argv[i - 1] not in ("--runs", "--rounds")), "build")
RUNS = int(sys.argv[sys.argv.index("--runs") + 1]) if "--runs" in sys.argv else 3
ISOSLAB = os.path.join(BUILD, "cli", "isoslab")
EXTRACT_ONLY = os.path.join(BUILD, "bench", "isoslab_extract_only")
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
TMP = tempfile.mkdtemp(prefix="isoslab-peers-")
atexit.register(shutil.rmtree, TMP, ignore_errors=True)


def nifti(path):
    """The voxels of a NIfTI-1 file (.nii or .nii.gz) as a numpy array indexed [z, y, x]."""
    data = (gzip.open if path.endswith(".gz") else open)(path, "rb").read()
    dims = np.frombuffer(data, "<i2", 8, 40)
    dtype = {2: "<u1", 4: "<i2", 8: "<i4", 16: "<f4", 64: "<f8", 256: "i1", 512: "<u2", 768: "<u4"}[int(np.frombuffer(data, "<i2", 1, 70)[0])]
    offset = int(np.frombuffer(data, "<f4", 1, 108)[0])
    nx, ny, nz = (int(d) for d in dims[1:4])
    return np.frombuffer(data, dtype, nx * ny * nz, offset).reshape(nz, ny, nx)


def volumes():
    """(name, .nii path for isoslab and VTK's reader, iso)."""
    out = []
    brain = "/usr/share/mricron/templates/ch2better.nii.gz"
    if os.path.exists(brain):
        plain = os.path.join(TMP, "brain.nii")
        open(plain, "wb").write(gzip.open(brain).read())
        out.append(("MRI brain 301x370x316 u8", plain, 50.0))
    phantom = os.path.join(TMP, "phantom.nii")
    subprocess.run([ISOSLAB, "phantom", "phantom:head?n=512,512,256", "-o", phantom], check=True, stdout=subprocess.DEVNULL)
    out.append(("head phantom 512x512x256 i16", phantom, 300.0))
    engine = os.path.join(ROOT, "..", "shared", "data", "engine", "engine_256x256x128_uint8.raw.gz")
    if os.path.exists(engine):
        path = os.path.join(TMP, "engine.nii")
        # Wrap the raw engine in a NIfTI-1 header through isoslab's own raw reader and writer.
        write_nifti_from_raw(engine, (256, 256, 128), path)
        out.append(("engine CT 256x256x128 u8", path, 90.0))
    return out


def write_nifti_from_raw(raw_gz, dims, path):
    data = gzip.open(raw_gz).read()
    header = bytearray(352)
    header[0:4] = np.int32(348).tobytes()
    header[40:56] = np.array([3, dims[0], dims[1], dims[2], 1, 1, 1, 1], "<i2").tobytes()
    header[70:72] = np.int16(2).tobytes()
    header[72:74] = np.int16(8).tobytes()
    header[76:108] = np.array([1, 1, 1, 1, 1, 1, 1, 1], "<f4").tobytes()
    header[108:112] = np.float32(352).tobytes()
    header[344:348] = b"n+1\0"
    open(path, "wb").write(bytes(header) + data)


def median_time(fn, runs=RUNS):
    times = []
    result = None
    for _ in range(runs):
        t = time.perf_counter()
        result = fn()
        times.append(time.perf_counter() - t)
    return statistics.median(times), result


def vtk_image(vol):
    """A vtkImageData holding a copy of vol (indexed [z, y, x])."""
    import vtk
    from vtk.util import numpy_support
    image = vtk.vtkImageData()
    image.SetDimensions(vol.shape[2], vol.shape[1], vol.shape[0])
    image.GetPointData().SetScalars(numpy_support.numpy_to_vtk(vol.ravel(), deep=True))
    return image


def flying_edges(image, iso, threads):
    """vtkFlyingEdges3D on image at iso, on `threads` threads, computing triangles only."""
    import vtk
    vtk.vtkSMPTools.Initialize(threads)
    fe = vtk.vtkFlyingEdges3D()
    fe.SetInputData(image)
    fe.SetValue(0, iso)
    fe.ComputeNormalsOff()
    fe.ComputeGradientsOff()
    fe.ComputeScalarsOff()
    return fe


def extract_only(path, iso, threads, method="mc", cpus=None, extra=()):
    """(median seconds, triangles, seconds to read the file once) from bench/isoslab_extract_only;
    cpus: a taskset CPU list to pin the process to."""
    cmd = [EXTRACT_ONLY, path, "--iso", str(iso), "--threads", str(threads), "--method", method, "--runs", str(RUNS),
           *extra]
    if cpus is not None:
        cmd = ["taskset", "-c", cpus] + cmd
    r = json.loads(subprocess.run(cmd, check=True, capture_output=True, text=True).stdout)
    return r["median_seconds"], r["triangles"], r["load_seconds"]


def scaling(methods):
    """mc extraction at 1 and 2 threads, alternated within each round so that the machine's drift
    hits both alike (paired ratios, median over the rounds); pinned with taskset to one core and to
    two. The model: N threads do the 1-thread work plus an overhead o (each thread's own buffers
    to fault in, the runs' first slices classified twice, stitching), of which a part s cannot
    overlap: T(N) = T1 (s + (1 + o - s) / N) on N cores. Two threads on one core give 1 + o (all of
    it runs in turn); two threads on two cores then give s; the model predicts 4, 8 and 16."""
    print()
    print("Thread scaling, mc extraction only (medians of paired rounds; taskset pins the process):")
    print()
    print("| volume | 1 thread s | 2 threads s | speed-up | 2 threads on 1 core s | 1 + o | s | model 4 | model 8 | model 16 |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    rounds = max(3, RUNS)
    for name, path, iso in methods:
        one, two, pinned, ratios, pinned_ratios = [], [], [], [], []
        for _ in range(rounds):
            t1, _, _ = extract_only(path, iso, 1, cpus="0,1")
            t2, _, _ = extract_only(path, iso, 2, cpus="0,1")
            tp, _, _ = extract_only(path, iso, 2, cpus="0")
            one.append(t1)
            two.append(t2)
            pinned.append(tp)
            ratios.append(t1 / t2)
            pinned_ratios.append(tp / t1)
        speedup = statistics.median(ratios)
        work = max(1.0, statistics.median(pinned_ratios))  # 1 + o
        s = max(0.0, min(1.0, 2.0 / speedup - work))       # 1 / speed-up = s + (work - s) / 2
        model = [1.0 / (s + (work - s) / n) for n in (4, 8, 16)]
        print(f"| {name} | {statistics.median(one):.3f} | {statistics.median(two):.3f} | {speedup:.2f} | "
              f"{statistics.median(pinned):.3f} | {work:.2f} | {s:.2f} | "
              + " | ".join(f"{m:.1f}" for m in model) + " |")


def run_isoslab(path, iso, threads=None):
    report = os.path.join(TMP, "r.json")
    cmd = [ISOSLAB, "extract", path, "--iso", str(iso), "-q", "-o", os.path.join(TMP, "iso.ply"), "--report", report]
    if threads:
        cmd += ["--threads", str(threads)]
    extract, total, rss, tris = [], [], [], 0
    for _ in range(RUNS):
        subprocess.run(cmd, check=True)
        r = json.load(open(report))
        extract.append(r["seconds"]["extract"])
        total.append(r["seconds"]["total"])
        rss.append(r["peak_rss_mib"])
        tris = r["triangles"]
    return statistics.median(extract), statistics.median(total), max(rss), tris


VTK_E2E = r"""
import resource, sys, time, vtk
t = time.perf_counter()
r = vtk.vtkNIFTIImageReader(); r.SetFileName(sys.argv[1])
fe = vtk.vtkFlyingEdges3D(); fe.SetInputConnection(r.GetOutputPort()); fe.SetValue(0, float(sys.argv[2]))
w = vtk.vtkPLYWriter(); w.SetInputConnection(fe.GetOutputPort()); w.SetFileName(sys.argv[3]); w.SetFileTypeToBinary(); w.Write()
print(time.perf_counter() - t, resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024)
"""


def main():
    import vtk
    try:
        from skimage.measure import marching_cubes
    except ImportError:
        marching_cubes = None
    print("| volume | tool | threads | extract s | Mvox/s | end-to-end s | triangles | peak RSS MiB |")
    print("|---|---|---|---|---|---|---|---|")
    ratios = []
    methods = []
    for name, path, iso in volumes():
        vol = nifti(path)
        voxels = vol.size
        image = vtk_image(vol)
        rows = {}
        for threads in (1, 2):
            fe = flying_edges(image, iso, threads)
            t, _ = median_time(lambda: (fe.Modified(), fe.Update()))
            tris = fe.GetOutput().GetNumberOfCells()
            e2e = []
            rss = 0
            for _ in range(RUNS):
                out = subprocess.run(["/usr/bin/python3", "-c", VTK_E2E, path, str(iso), os.path.join(TMP, "vtk.ply")],
                                     check=True, capture_output=True, text=True, env={**os.environ, "OMP_NUM_THREADS": str(threads)}).stdout.split()
                e2e.append(float(out[0]))
                rss = max(rss, float(out[1]))
            rows[("fe", threads)] = t
            print(f"| {name} | vtkFlyingEdges3D | {threads} | {t:.3f} | {voxels / t / 1e6:.0f} | {statistics.median(e2e):.3f} | {tris:,} | {rss:.0f} |")
        mc = vtk.vtkMarchingCubes()
        mc.SetInputData(image)
        mc.SetValue(0, iso)
        mc.ComputeNormalsOff()
        mc.ComputeScalarsOff()
        t, _ = median_time(lambda: (mc.Modified(), mc.Update()), runs=1)
        print(f"| {name} | vtkMarchingCubes | 1 | {t:.3f} | {voxels / t / 1e6:.0f} | | {mc.GetOutput().GetNumberOfCells():,} | |")
        if marching_cubes is not None and "--quick" not in sys.argv:
            t, res = median_time(lambda: marching_cubes(vol, iso), runs=1)
            print(f"| {name} | skimage marching_cubes | 1 | {t:.3f} | {voxels / t / 1e6:.0f} | | {len(res[1]):,} | |")
        for threads in (1, 2):
            _, total, rss, tris = run_isoslab(path, iso, threads)
            extract, _, _ = extract_only(path, iso, threads)
            print(f"| {name} | isoslab mc | {threads} | {extract:.3f} | {voxels / extract / 1e6:.0f} | {total:.3f} | {tris:,} | {rss:.0f} |")
            ratios.append((name, threads, extract / rows[("fe", threads)]))
        methods.append((name, path, iso))
    print()
    for name, threads, r in ratios:
        print(f"- {name}: isoslab mc extraction time / vtkFlyingEdges3D, {threads} thread(s) = {r:.2f}")
    print()
    print("Per method, extraction only (median of the runs), and the constant time (iso above every voxel):")
    print()
    print("| volume | method | triangles | 1 thread s | 2 threads s | / mc (1 thread) | / mt6 (1 thread) | constant s | read once s |")
    print("|---|---|---|---|---|---|---|---|---|")
    for name, path, iso in methods:
        base = {}
        for method in ("mc", "mt5", "mt6", "bcc12", "mt24", "mc33"):
            t1, tris, load = extract_only(path, iso, 1, method)
            t2, _, _ = extract_only(path, iso, 2, method)
            empty, _, _ = extract_only(path, 1e9, 1, method)
            base[method] = t1
            over_mc = f"{t1 / base['mc']:.2f}"
            over_mt6 = f"{t1 / base['mt6']:.2f}" if "mt6" in base else ""
            print(f"| {name} | {method} | {tris:,} | {t1:.3f} | {t2:.3f} | {over_mc} | {over_mt6} | {empty:.3f} | {load:.3f} |")
    scaling(methods)
    dicom = os.path.join(ROOT, "..", "shared", "data", "ct-philips-head")
    if os.path.isdir(dicom):
        print()
        print("DICOM series to .glb, end to end (isoslab only; medians):")
        print()
        print("| series | iso | threads | seconds | triangles | bytes | peak RSS MiB |")
        print("|---|---|---|---|---|---|---|")
        for threads in (1, 2):
            out = os.path.join(TMP, "dicom.glb")
            report = os.path.join(TMP, "d.json")
            times, rss = [], 0
            for _ in range(RUNS):
                subprocess.run([ISOSLAB, "extract", dicom, "--iso", "-400", "-q", "--threads", str(threads), "-o", out,
                                "--report", report], check=True, stderr=subprocess.DEVNULL)
                r = json.load(open(report))
                times.append(r["seconds"]["total"])
                rss = max(rss, r["peak_rss_mib"])
            print(f"| ct-philips-head | -400 | {threads} | {statistics.median(times):.2f} | {r['triangles']:,} | {r['output']['bytes']:,} | {rss:.0f} |")
        codecs = os.path.join(BUILD, "bench", "isoslab_codecs")
        if os.path.exists(codecs):
            # Draco's encoder options and meshoptimizer's codec on the same mesh (bench/codecs.cpp).
            ply = os.path.join(TMP, "dicom.ply")
            subprocess.run([ISOSLAB, "extract", dicom, "--iso", "-400", "-q", "--threads", "1", "-o", ply], check=True,
                           stderr=subprocess.DEVNULL)
            print()
            print("Codecs on the same mesh, whole (bench/codecs.cpp):")
            print()
            print(subprocess.run([codecs, ply, "--runs", str(RUNS)], check=True, capture_output=True, text=True).stdout)


if __name__ == "__main__":
    main()
