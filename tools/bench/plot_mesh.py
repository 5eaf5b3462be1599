#!/usr/bin/env python3
"""Plot triangles against 3D p99 relative error for the CSVs of mesh_vs_delatin.sh."""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def load(path):
    with open(path) as f:
        rows = [r for r in csv.reader(f) if r]
    return [(float(r[3]), int(r[2])) for r in rows]


def main():
    pomc, delatin, out = sys.argv[1:4]
    plt.figure(figsize=(6, 4))
    for path, label in [(pomc, "pomc quadtree (--max-error)"), (delatin, "Delatin (per face)")]:
        pts = sorted(load(path))
        plt.loglog([p[0] for p in pts], [p[1] for p in pts], "o-", label=label)
    plt.xlabel("3D p99 relative depth error")
    plt.ylabel("triangles")
    plt.title("Room background, 6x1024² cube map")
    plt.grid(True, which="both", alpha=0.3)
    plt.legend()
    plt.tight_layout()
    plt.savefig(out, dpi=110)


if __name__ == "__main__":
    main()
