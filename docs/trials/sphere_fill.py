"""The room's seam sphere (rows 200-310, columns within 60 of the seam): how much of it the
`background` layer's fill covers, its 4-neighbour steps over 2 % and 5 %, and the fill's depth
percentiles (docs/build.md, ninth session). Run from the repository root:

    target/bpy-venv/bin/python docs/trials/sphere_fill.py PANO_DIR [PANO_DIR ...]

PANO_DIR: a `pomc build --no-pack` of the corpus room (e.g. depth_quality.py's pano-blur2).
"""
import sys

import numpy as np

sys.path.insert(0, "tools/eval/realistic")
import run as realistic  # noqa: E402

for pano in sys.argv[1:]:
    b = realistic.read_channels(pano + "/background.exr")["Z"]
    o = realistic.read_channels(pano + "/objects-1.exr")["Z"]
    sph = np.zeros(b.shape, bool)
    sph[200:310, :] = True
    sph[:, 60:960] = False
    inside = sph & np.isfinite(o) & (o > 0)
    cov = np.isfinite(b) & (b > 0)
    r = np.ones(b.shape)
    for dy, dx in ((0, 1), (1, 0)):
        nb = np.roll(np.roll(b, -dy, 0), -dx, 1)
        both = cov & np.roll(np.roll(cov, -dy, 0), -dx, 1)
        r = np.maximum(r, np.where(both, np.maximum(b, nb) / np.minimum(b, nb), 1))
    print(pano, "sphere", inside.sum(), "filled", (inside & cov).sum(), "steps>2%", ((r > 1.02) & inside).sum(),
          ">5%", ((r > 1.05) & inside).sum(), "depth p5/p50/p95", np.nanpercentile(np.where(inside & cov, b, np.nan), [5, 50, 95]))
