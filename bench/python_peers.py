#!/usr/bin/python3
"""isoslab.marching_cubes against skimage.measure.marching_cubes (lewiner and lorensen) and VTK's
vtkFlyingEdges3D, from Python, on the MRI brain and the head phantom (issue 21;
docs/performance.md "Python").

Every measurement runs in a fresh interpreter that loads the volume as a float32 array first,
then clears the peak RSS (/proc/self/clear_refs) and runs the call R times: the table gives the
median time and the peak memory the call adds above the loaded volume. Rounds alternate the
tools (the machine's speed drifts). One thread everywhere (vtkSMPTools set to 1).

Then extract() from an np.memmap of a 512 x 512 x 1024 int16 file to .glb, against the isoslab
program on the same file: the peak RSS of each (extract() runs the program, so its figure is the
child's, plus what the Python process adds).

Usage: bench/python_peers.py [BUILD_DIR] [--runs R] [--rounds N] [--no-memmap]
(--no-memmap: the table only, without the extract() measure.)
"""
import json
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import textwrap

args = sys.argv[1:]
BUILD = next((a for i, a in enumerate(args) if not a.startswith("--") and (i == 0 or args[i - 1] not in ("--runs", "--rounds"))), "build")
RUNS = int(args[args.index("--runs") + 1]) if "--runs" in args else 3
ROUNDS = int(args[args.index("--rounds") + 1]) if "--rounds" in args else 3
PYTHONPATH = os.path.abspath(os.path.join(BUILD, "python"))
ISOSLAB = os.path.abspath(os.path.join(BUILD, "cli", "isoslab"))
TMP = tempfile.mkdtemp(prefix="isoslab-pypeers-")
BRAIN = "/usr/share/mricron/templates/ch2better.nii.gz"

WORKER = textwrap.dedent(r'''
    import gzip, json, statistics, sys, time
    import numpy as np
    path, level, tool, runs = sys.argv[1], float(sys.argv[2]), sys.argv[3], int(sys.argv[4])
    data = (gzip.open if path.endswith(".gz") else open)(path, "rb").read()
    dims = np.frombuffer(data, "<i2", 3, 42)
    code = int(np.frombuffer(data, "<i2", 1, 70)[0])
    dtype = {2: "u1", 4: "<i2", 16: "<f4", 512: "<u2"}[code]
    offset = int(np.frombuffer(data, "<f4", 1, 108)[0])
    volume = np.frombuffer(data, dtype, int(np.prod(dims)), offset).reshape(dims[::-1]).astype(np.float32)
    del data
    if tool == "isoslab":
        import isoslab
        run = lambda: len(isoslab.marching_cubes(volume, level, method="mc", threads=1)[1])
    elif tool in ("lewiner", "lorensen"):
        from skimage import measure
        run = lambda: len(measure.marching_cubes(volume, level, method=tool)[1])
    else:
        import vtk
        from vtk.util import numpy_support
        vtk.vtkSMPTools.Initialize(1)
        image = vtk.vtkImageData()
        image.SetDimensions(volume.shape[2], volume.shape[1], volume.shape[0])
        image.GetPointData().SetScalars(numpy_support.numpy_to_vtk(volume.ravel(), deep=False))
        def run():
            fe = vtk.vtkFlyingEdges3D()
            fe.SetInputData(image)
            fe.SetValue(0, level)
            fe.ComputeNormalsOn()
            fe.Update()
            return fe.GetOutput().GetNumberOfPolys()
    def status(key):
        for line in open("/proc/self/status"):
            if line.startswith(key):
                return int(line.split()[1]) / 1024
    before = status("VmRSS:")
    open("/proc/self/clear_refs", "w").write("5")  # resets VmHWM to the current RSS
    times, triangles = [], 0
    for _ in range(runs):
        t = time.perf_counter()
        triangles = run()
        times.append(time.perf_counter() - t)
    print(json.dumps({"seconds": statistics.median(times), "added_mib": status("VmHWM:") - before,
                      "triangles": int(triangles)}))
''')


def measure(path, level, tool):
    env = dict(os.environ, PYTHONPATH=PYTHONPATH)
    out = subprocess.run(["/usr/bin/python3", "-c", WORKER, path, str(level), tool, str(RUNS)], env=env,
                         capture_output=True, text=True, check=True)
    return json.loads(out.stdout)


def volumes():
    out = []
    if os.path.exists(BRAIN):
        out.append(("MRI brain 301 x 370 x 316 u8", BRAIN, 50.0))
    phantom = os.path.join(TMP, "phantom.nii")
    subprocess.run([ISOSLAB, "phantom", "phantom:head?n=512,512,256", "-o", phantom], check=True,
                   stdout=subprocess.DEVNULL)
    out.append(("head phantom 512 x 512 x 256 i16", phantom, 300.0))
    return out


def peak_children_mib():
    return resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024


def memmap_extract():
    """extract() on a memmap against the program, each in a fresh process (its own peak)."""
    raw = os.path.join(TMP, "big.raw")
    subprocess.run([ISOSLAB, "phantom", "phantom:head?n=512,512,1024&type=i16", "-o", raw], check=True,
                   stdout=subprocess.DEVNULL)
    program = subprocess.run(["/usr/bin/time", "-f", "%M", ISOSLAB, "extract", raw, "--raw-dims", "512,512,1024",
                              "--raw-type", "i16", "--iso", "300", "-q", "-o", os.path.join(TMP, "a.glb")],
                             capture_output=True, text=True, check=True)
    program_mib = int(program.stderr.split()[-1]) / 1024
    code = textwrap.dedent(f'''
        import resource, numpy as np, isoslab
        v = np.memmap({raw!r}, "<i2", "r", shape=(1024, 512, 512))
        r = isoslab.extract(v, {os.path.join(TMP, "b.glb")!r}, iso=300)
        own = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
        child = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
        print(own, child, r["triangles"])
    ''')
    out = subprocess.run(["/usr/bin/python3", "-c", code], env=dict(os.environ, PYTHONPATH=PYTHONPATH),
                         capture_output=True, text=True, check=True).stdout.split()
    same = open(os.path.join(TMP, "a.glb"), "rb").read() == open(os.path.join(TMP, "b.glb"), "rb").read()
    print("\nextract() from an np.memmap of a 512 x 512 x 1024 int16 file to .glb (iso 300)\n")
    print("| run | peak RSS MiB | same bytes |")
    print("|---|---|---|")
    print(f"| isoslab program | {program_mib:.0f} | |")
    print(f"| isoslab.extract(memmap): the program it runs | {float(out[1]):.0f} | {same} |")
    print(f"| isoslab.extract(memmap): the Python process | {float(out[0]):.0f} | |")


def main():
    tools = ["isoslab", "lewiner", "lorensen", "vtk"]
    try:
        for name, path, level in volumes():
            results = {t: [] for t in tools}
            for _ in range(ROUNDS):
                for t in tools:
                    results[t].append(measure(path, level, t))
            base = statistics.median(r["seconds"] for r in results["isoslab"])
            print(f"\n{name}, iso {level:g}: median of {ROUNDS} rounds x {RUNS} runs, 1 thread\n")
            print("| tool | s | / isoslab | peak MiB added | triangles |")
            print("|---|---|---|---|---|")
            for t in tools:
                s = statistics.median(r["seconds"] for r in results[t])
                mib = max(r["added_mib"] for r in results[t])
                label = {"isoslab": "isoslab.marching_cubes (mc)", "lewiner": "skimage lewiner",
                         "lorensen": "skimage lorensen", "vtk": "vtkFlyingEdges3D (normals)"}[t]
                print(f"| {label} | {s:.3f} | {s / base:.1f} | {mib:.0f} | {results[t][-1]['triangles']} |")
        if "--no-memmap" not in args:
            memmap_extract()
    finally:
        shutil.rmtree(TMP, ignore_errors=True)


main()
