#!/usr/bin/env python3
"""Delatin (pydelatin) on the room background, per cube face, at a sweep of max errors.

The heightmap given to Delatin is w = |r| / depth over each face's pixel-centre lattice (r the
unnormalised cube ray). On a cube face a planar triangle is exactly linear in w, so Delatin's linear
interpolation of w is the true ray/mesh intersection, like pomc's; the relative depth error of a pixel
is |w - w_mesh| / w_mesh. The room is the fixture's box (fixtures/src/lib.rs, Scene::room):
min (-3, -2.5, -1.2), max (4, 3, 1.6), seen from the origin. Faces are meshed independently (no
stitching strips: pomc's counts include its strips, which favours Delatin slightly).

Prints CSV lines: delatin,max_error,triangles,p99_rel,max_rel,seconds,face_triangles,seconds and, for
the same meshes closed like pomc's (the strips pomc zips between faces: one triangle per vertex step
on either side of each cube edge, one per cube corner), delatin+strips with the strips counted.
Usage: mesh_vs_delatin.py [N]   (needs: pip install pydelatin numpy)
"""
import sys
import time

import numpy as np
from pydelatin import Delatin

LO = np.array([-3.0, -2.5, -1.2])
HI = np.array([4.0, 3.0, 1.6])
# (centre, right, down) per face, digest section 6 / pomc::mapping::CubeFace::frame.
X, Y, Z = np.eye(3)
# Each face's time is the best of REPEAT runs (the machine is shared), like pomc's.
REPEAT = 3
FRAMES = [(X, -Y, -Z), (Y, X, -Z), (Z, -X, -Y), (-X, Y, -Z), (-Y, -X, -Z), (-Z, X, -Y)]


def face_w(n, frame):
    c, r, d = frame
    s = 2.0 * (np.arange(n) + 0.5) / n - 1.0
    rays = c[None, None, :] + s[None, :, None] * r[None, None, :] + s[:, None, None] * d[None, None, :]
    bound = np.where(rays > 0, HI, LO)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(rays != 0, rays / bound, 0.0)
    # Distance along r to the box is min_k bound_k / r_k = 1 / max_k (r_k / bound_k).
    return ratio.max(axis=2)


def interpolate(w_shape, vertices, triangles, heights):
    """Per-pixel linear interpolation of `heights` over the triangles (lattice coordinates)."""
    h, w = w_shape
    out = np.full((h, w), np.nan)
    for tri in triangles:
        p = vertices[tri]
        z = heights[tri]
        x0, y0 = np.floor(p.min(axis=0)).astype(int)
        x1, y1 = np.ceil(p.max(axis=0)).astype(int)
        xs, ys = np.meshgrid(np.arange(max(x0, 0), min(x1, w - 1) + 1), np.arange(max(y0, 0), min(y1, h - 1) + 1))
        (ax, ay), (bx, by), (cx, cy) = p
        den = (by - cy) * (ax - cx) + (cx - bx) * (ay - cy)
        if den == 0:
            continue
        l0 = ((by - cy) * (xs - cx) + (cx - bx) * (ys - cy)) / den
        l1 = ((cy - ay) * (xs - cx) + (ax - cx) * (ys - cy)) / den
        l2 = 1 - l0 - l1
        inside = (l0 >= -1e-9) & (l1 >= -1e-9) & (l2 >= -1e-9)
        out[ys[inside], xs[inside]] = (l0 * z[0] + l1 * z[1] + l2 * z[2])[inside]
    return out


def side_keys(n, frame):
    """Cube-edge key (its two cube corners, sorted) of each face side: 0 top, 1 right, 2 bottom, 3 left."""
    c, r, d = frame
    ends = [((-1, -1), (1, -1)), ((1, -1), (1, 1)), ((-1, 1), (1, 1)), ((-1, -1), (-1, 1))]
    return [tuple(sorted(tuple(np.rint(c + s * r + t * d).astype(int)) for s, t in e)) for e in ends]


def strip_triangles(n, sides):
    """Triangles of pomc-style stitching: per cube edge, (vertices on side A − 1) + (on side B − 1); 8 corners."""
    per_edge = {}
    for f, frame in enumerate(FRAMES):
        for k, key in enumerate(side_keys(n, frame)):
            per_edge.setdefault(key, []).append(sides[f][k])
    return sum(sum(c - 1 for c in counts) for counts in per_edge.values()) + 8


def main():
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 1024
    faces = [face_w(n, f) for f in FRAMES]
    for max_error in [2e-3, 1e-3, 5e-4, 2e-4, 1e-4, 5e-5]:
        tris, rel, secs, sides = 0, [], 0.0, []
        for w in faces:
            wf = w.astype(np.float32)
            best = float("inf")
            for _ in range(REPEAT):
                t = time.perf_counter()
                tin = Delatin(wf, width=n, height=n, max_error=max_error)
                best = min(best, time.perf_counter() - t)
            secs += best
            v, tr = tin.vertices[:, :2], tin.triangles
            tris += len(tr)
            # Vertices on each side (y up in pydelatin: row 0 is y = n − 1).
            x, y = v[:, 0].astype(int), v[:, 1].astype(int)
            sides.append([np.sum(y == n - 1), np.sum(x == n - 1), np.sum(y == 0), np.sum(x == 0)])
            # pydelatin's y axis points up: its vertex (x, y) is row n-1-y of the input array.
            flipped = w[::-1]
            heights = flipped[v[:, 1].astype(int), v[:, 0].astype(int)]
            wi = interpolate(w.shape, v, tr, heights)
            w_cmp = flipped
            ok = ~np.isnan(wi)
            rel.append(np.abs(w_cmp[ok] - wi[ok]) / wi[ok])
        rel = np.concatenate(rel)
        p99, mx = np.percentile(rel, 99), rel.max()
        print(f"CSV delatin,{max_error},{tris},{p99},{mx},{secs},{tris},{secs}", flush=True)
        closed = tris + strip_triangles(n, sides)
        print(f"CSV delatin+strips,{max_error},{closed},{p99},{mx},{secs},{tris},{secs}", flush=True)


if __name__ == "__main__":
    main()
