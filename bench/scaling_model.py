#!/usr/bin/python3
"""The model of docs/scaling.md: time and memory of `mpirun -np N isoslab extract` on a 4000^3 u16
volume, from per-voxel and per-triangle costs measured on this machine (bench/ranks.py and
bench/peers.py), with the cluster's terms stated as assumptions. Prints a Markdown table.

Usage: bench/scaling_model.py [--cores C] [--fs-node GBps] [--fs-total GBps] [--net GBps]
"""
import sys

args = sys.argv[1:]


def arg(name, default):
    return float(args[args.index(name) + 1]) if name in args else default


# Measured (docs/scaling.md, bench/ranks.py at the commit of issue 20, 1 thread):
EXTRACT_NS_PER_VOXEL = 0.32e-3 / (512 * 512) * 1e9  # mc, head phantom: 0.32 ms a 512 x 512 slab
PLY_US_PER_TRIANGLE = 0.61e-3 / (2586612 / 511) * 1e6  # rank 0's emit of a .ply (measures included)
GLB_US_PER_TRIANGLE = 6.74e-3 / (2586612 / 511) * 1e6  # rank 0's emit of a .glb (Draco, one encoder)
RUN_BYTES_PER_TRIANGLE = 25  # a run on the wire: 12 B a triangle, ~0.5 vertex of 25 B (position, normal, faces)
MPI_START_S = 0.4  # mpirun and MPI_Init, measured with -np 1 against no mpirun
SPEEDUP_16_THREADS = 6.1  # mc on 16 threads, the model of docs/performance.md (brain)
# The workstation model of docs/performance.md gives the speed-up of C threads from 1 + o and s.
ONE_PLUS_O, SERIAL = 1.43, 0.08

# Assumed (stated in docs/scaling.md): the volume and its surface.
NX = NY = NZ = 4000
VOXEL_BYTES = 2
TRIANGLES = 2586612 * (NX / 512) ** 2  # the phantom's surface scaled by area: about 158 million

CORES = arg("--cores", 16)
FS_NODE = arg("--fs-node", 1.0) * 1e9  # bytes/s one node reads
FS_TOTAL = arg("--fs-total", 20.0) * 1e9  # bytes/s the file system gives all nodes together
NET = arg("--net", 1.25) * 1e9  # bytes/s into rank 0 (10 Gb/s)


def threads_speedup(c):
    return 1.0 / (SERIAL + (ONE_PLUS_O - SERIAL) / c)


def model(nodes):
    volume_bytes = NX * NY * NZ * VOXEL_BYTES
    read = volume_bytes / min(nodes * FS_NODE, FS_TOTAL)
    extract = NX * NY * NZ * EXTRACT_NS_PER_VOXEL * 1e-9 / (nodes * threads_speedup(CORES))
    # Rank 0 emits every triangle; the other ranks' runs cross the network meanwhile.
    emit_ply = TRIANGLES * PLY_US_PER_TRIANGLE * 1e-6
    emit_glb = TRIANGLES * GLB_US_PER_TRIANGLE * 1e-6 / CORES  # rank 0's encoder threads
    wire = TRIANGLES * RUN_BYTES_PER_TRIANGLE * (nodes - 1) / nodes / NET
    # Rank 0 emits its own share while the others extract; the rest of the emit follows.
    own = (read + extract)
    ply = MPI_START_S + own + max(emit_ply * (nodes - 1) / nodes, wire) + emit_ply / nodes
    glb = MPI_START_S + max(own, emit_glb / nodes) + max(emit_glb * (nodes - 1) / nodes, wire)
    return read, extract, emit_ply, emit_glb, wire, ply, glb


def memory_mib(threads):
    slice_bytes = NX * NY * 4
    ring = (2 + 2 * (threads + 1)) * slice_bytes  # the slices of the runs in flight
    caches = threads * 3 * (3 * NX * NY) * 4  # 3 planes of mc's 3 slots a point: at most (mapped as touched)
    return (ring + caches) / 2**20


def main():
    print(f"4000^3 u16 ({NX * NY * NZ * VOXEL_BYTES / 1e9:.0f} GB), about {TRIANGLES / 1e6:.0f} million triangles; "
          f"{CORES:.0f} cores a node, one rank a node; file system {FS_NODE / 1e9:.1f} GB/s a node, "
          f"{FS_TOTAL / 1e9:.0f} GB/s in all; {NET / 1e9:.2f} GB/s into rank 0\n")
    print("| nodes | read s | extract s | wire s | .ply s | .glb s | .ply speed-up | .glb speed-up |")
    print("|---|---|---|---|---|---|---|---|")
    base = model(1)
    for n in (1, 2, 4, 8, 16, 32, 64):
        read, extract, emit_ply, emit_glb, wire, ply, glb = model(n)
        print(f"| {n} | {read:.1f} | {extract:.1f} | {wire:.1f} | {ply:.1f} | {glb:.1f} | {base[5] / ply:.1f} | "
              f"{base[6] / glb:.1f} |")
    print(f"\nrank 0's emit alone: .ply {base[2]:.0f} s, .glb {base[3]:.0f} s on {CORES:.0f} encoder threads")
    print(f"memory a rank (slices and welding caches, {CORES:.0f} threads): at most {memory_mib(CORES):.0f} MiB, "
          f"whatever the number of nodes (--max-memory must allow it); 1 thread: {memory_mib(1):.0f} MiB")


main()
