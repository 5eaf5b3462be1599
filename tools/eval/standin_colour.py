#!/usr/bin/env python3
"""Make a stand-in colour panorama from a 16-bit depth PNG whose colour was not published.

The real-capture figures of docs/build.md use it for crs4/SliceNet's Matterport3D sample, whose colour
image is not in the repository. The colour is shaded from the depth's own geometry (normals by finite
differences of the 3D points, lit from above and one side, hue from log depth), so its edges lie on the
depth's edges: it measures geometry only, not how a real photograph's edges guide `prepare`. Unknown
depth (stored 0) is mid grey. Deterministic: the same depth gives the same bytes.

usage: standin_colour.py DEPTH.png OUT.png
"""
import sys

import numpy as np
from PIL import Image


def main() -> None:
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    depth = np.asarray(Image.open(sys.argv[1])).astype(np.float64)
    if depth.ndim != 2:
        sys.exit(f"{sys.argv[1]}: expected a one-channel depth image")
    h, w = depth.shape
    known = depth > 0
    lon = (np.arange(w) + 0.5) / w * 2 * np.pi - np.pi
    lat = np.pi / 2 - (np.arange(h) + 0.5) / h * np.pi
    lon, lat = np.meshgrid(lon, lat)
    ray = np.stack([np.cos(lat) * np.sin(lon), np.sin(lat), -np.cos(lat) * np.cos(lon)], axis=-1)
    d = np.where(known, depth, np.nan)
    p = ray * d[..., None]
    dx = np.roll(p, -1, axis=1) - np.roll(p, 1, axis=1)
    dy = np.roll(p, -1, axis=0) - np.roll(p, 1, axis=0)
    n = np.cross(dx, dy)
    n /= np.linalg.norm(n, axis=-1, keepdims=True) + 1e-12
    light = np.array([0.3, 0.8, 0.5])
    light /= np.linalg.norm(light)
    shade = 0.35 + 0.65 * np.abs(n @ light)
    logd = np.log(np.where(known, depth, 1.0))
    lo, hi = np.nanpercentile(np.where(known, logd, np.nan), [1, 99])
    t = np.clip((logd - lo) / max(hi - lo, 1e-9), 0, 1)
    base = np.stack([0.55 + 0.4 * t, 0.75 - 0.2 * t, 0.95 - 0.6 * t], axis=-1)
    rgb = base * np.nan_to_num(shade, nan=0.6)[..., None]
    rgb[~known] = 0.5
    Image.fromarray((np.clip(rgb, 0, 1) * 255 + 0.5).astype(np.uint8)).save(sys.argv[2])


if __name__ == "__main__":
    main()
