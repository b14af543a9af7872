#!/usr/bin/python3
"""Charts of `isoslab compare --suite spheres51`, mirroring Charts 1-7 of Skala and Brus.

Usage: plot_precision.py RESULTS.csv OUT_DIR   (Debian: /usr/bin/python3 with python3-matplotlib)
Writes chart1_triangles.png .. chart7_volume_error.png, each with the binary and the distance
field side by side and one line per method (smoothed runs, "mc+sinc20", dashed).
"""
import csv
import math
import sys
from collections import defaultdict

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

CHARTS = [
    ("chart1_triangles", "triangles", "Chart 1: triangles", "triangles"),
    ("chart2_radius_error", "vertex_error_sum", "Chart 2: radius error (sum over 3T vertices)", "sum of (|v-c|-r)/r"),
    ("chart3_radius_error_per_triangle", "vertex_error_sum_per_triangle", "Chart 3: radius error / triangles", "sum / T"),
    ("chart4_centroid_error", "centroid_error_sum", "Chart 4: centroid radius error (sum over T)", "sum of (|g-c|-r)/r"),
    ("chart5_centroid_error_per_triangle", "centroid_error_sum_per_triangle", "Chart 5: centroid error / triangles", "sum / T"),
    ("chart6_area_error", "area_error", "Chart 6: area error", "(S - 4 pi r^2) / 4 pi r^2"),
    ("chart7_volume_error", "volume_error", "Chart 7: volume error", "(V - 4/3 pi r^3) / (4/3 pi r^3)"),
]
STYLE = {
    "mc": ("tab:blue", "o"),
    "mt5": ("tab:green", "s"),
    "mt6": ("tab:orange", "^"),
    "bcc12": ("tab:red", "v"),
    "mt24": ("tab:purple", "D"),
    "mc33": ("tab:cyan", "x"),
}


def main():
    rows = list(csv.DictReader(open(sys.argv[1])))
    out = sys.argv[2]
    series = defaultdict(list)  # (field, method) -> rows
    for r in rows:
        series[(r["field"], r["method"])].append(r)
    fields = [f for f in ("binary", "distance") if any(k[0] == f for k in series)]
    # Smoothed rows ("mc+sinc20") are drawn dashed, in their method's colour.
    base = lambda m: m.split("+")[0]
    methods = sorted({k[1] for k in series if base(k[1]) in STYLE}, key=lambda m: (list(STYLE).index(base(m)), m))
    for name, column, title, ylabel in CHARTS:
        fig, axes = plt.subplots(1, len(fields), figsize=(6 * len(fields), 4.2), squeeze=False)
        for ax, field in zip(axes[0], fields):
            for m in methods:
                data = sorted(series[(field, m)], key=lambda r: float(r["radius"]))
                xs = [float(r["radius"]) for r in data if r[column] not in ("", "nan")]
                ys = [float(r[column]) for r in data if r[column] not in ("", "nan")]
                color, marker = STYLE[base(m)]
                ax.plot(xs, ys, label=m, color=color, marker=marker, markersize=3, linewidth=1,
                        linestyle="--" if "+" in m else "-")
            ax.set_title(f"{field} field")
            ax.set_xlabel("radius (voxels)")
            ax.set_ylabel(ylabel)
            ax.grid(True, alpha=0.3)
            if column == "triangles":
                ax.set_yscale("log")
            ax.legend()
        fig.suptitle(title)
        fig.tight_layout()
        fig.savefig(f"{out}/{name}.png", dpi=90)
        plt.close(fig)


if __name__ == "__main__":
    main()
