#!/usr/bin/env python3
"""Plot triangles against 3D p99 relative error for the CSVs of mesh_vs_delatin.sh.

Rows are `name,max_error,triangles,p99_rel,max_rel,seconds[,...]`; one series per name.
Usage: plot_mesh.py A.csv [B.csv ...] OUT.png
"""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

LABELS = {
    "pomc": "pomc quadtree (--no-simplify)",
    "pomc-collapse": "pomc quadtree + collapses (--no-greedy)",
    "pomc-simplify": "pomc greedy insertion + collapses (default)",
    "delatin": "Delatin (per face, unstitched)",
    "delatin+strips": "Delatin + pomc's face-joining strips",
}


def main():
    *paths, out = sys.argv[1:]
    series = {}
    for path in paths:
        with open(path) as f:
            for r in csv.reader(f):
                if r:
                    series.setdefault(r[0], []).append((float(r[3]), int(r[2])))
    plt.figure(figsize=(6, 4))
    for name, pts in series.items():
        pts = sorted(pts)
        plt.loglog([p[0] for p in pts], [p[1] for p in pts], "o-", label=LABELS.get(name, name))
    plt.xlabel("3D p99 relative depth error")
    plt.ylabel("triangles")
    plt.title("Room background, 6x1024² cube map")
    plt.grid(True, which="both", alpha=0.3)
    plt.legend()
    plt.tight_layout()
    plt.savefig(out, dpi=110)


if __name__ == "__main__":
    main()
