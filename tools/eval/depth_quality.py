#!/usr/bin/env python3
"""Depth quality against the truth, no rendering (issue 51, figure 1): each scene of the path-traced
corpus (tools/eval/realistic/scenes.py) degraded as users have it (run.py's kinds), passed through
`pomc prepare`, and the prepared depth scored against the exact depth; then `pomc build` of the same
input for the layer structure.

  python3 tools/eval/depth_quality.py [--small] [--scenes room,outdoor,extreme] [--kinds exact,blur1,...]
                                      [--prepare-args='--refine on'] [--no-build] [--tag T] [--work DIR]

Figures (docs/build.md, "Depth quality"):
- flying: share of pixels whose prepared depth d' is more than 5 % from the exact depth d of every pixel
  within 2 px (the 5 x 5 window, the seam wrapped) *and* would land more than one pixel's angle
  (2 pi / width) from each of them for an eye 0.5 m out: |1/d' - 1/d| * 0.5 m > angle. Far grazing
  ground, where 5 % moves nothing, does not fly.
- F1@1, F1@2: boundary F1 of occlusion edges at 1 and 2 px tolerance (Chebyshev), as Depth Pro and MoGe
  score them: a pixel is on an edge when a 4-neighbour is more than 1.1 times farther (the near side).
- layers: the build's layer count, and the pixels in pieces under 64 px (8-connected pieces of each
  layer's domain, `--no-pack` so every layer is a full canvas).
Environment: POMC_BIN (default target/release/pomc, built when missing); runs under the corpus's bpy
Python (run.py's venv) for numpy, OpenEXR and scipy. Results: WORK/results.json and results.md.
"""
import argparse
import json
import os
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
REAL = os.path.join(HERE, "realistic")
sys.path.insert(0, REAL)

try:
    import numpy as np
    import OpenEXR  # noqa: F401
    from scipy import ndimage
except ImportError:
    if __name__ == "__main__" and not os.environ.get("_DEPTH_QUALITY_REEXEC"):
        os.environ["_REALISTIC_REEXEC"] = "1"  # run.py must not re-exec on import below
        import run as realistic  # noqa: E402
        py = realistic.bpy_python()
        subprocess.run([py, "-m", "pip", "install", "-q", "scipy"], check=True)
        os.environ["_DEPTH_QUALITY_REEXEC"] = "1"
        os.execv(py, [py, os.path.abspath(__file__), *sys.argv[1:]])
    raise

import run as realistic  # noqa: E402  (numpy and OpenEXR are here now)

KINDS = ("exact", "blur1", "blur2", "blur3", "upsample2", "low2", "low4", "low8", "mono", "relinv", "scanner",
         "lidar", "nearness8")
WINDOW = 2  # px: the flying test's neighbourhood
REL = 0.05  # the flying test's relative depth tolerance
EYE = 0.5  # m: the flying test's eye offset
EDGE_RATIO = 1.1
SMALL_PIECE = 64


def log(msg):
    print(f"[depth-quality {time.strftime('%H:%M:%S')}] {msg}", flush=True)


def shifted(a, dy, dx):
    """`a` moved by (dy, dx): the seam wraps, the poles repeat their row."""
    h = a.shape[0]
    rows = np.clip(np.arange(h) - dy, 0, h - 1)
    return np.roll(a[rows], dx, axis=1)


def inverse(d):
    with np.errstate(divide="ignore"):
        return np.where(np.isinf(d), 0.0, 1.0 / d)


def flying(prep, truth):
    """Boolean map of flying pixels (see the module doc) and the count of NaN prepared pixels."""
    angle = 2 * np.pi / truth.shape[1]
    ok = np.zeros(truth.shape, bool)
    ip = inverse(prep)
    with np.errstate(invalid="ignore"):
        for dy in range(-WINDOW, WINDOW + 1):
            for dx in range(-WINDOW, WINDOW + 1):
                t = shifted(truth, dy, dx)
                near = (np.isinf(t) & np.isinf(prep)) | (
                    np.isfinite(t) & np.isfinite(prep) & (np.abs(prep - t) <= REL * t))
                still = np.abs(ip - inverse(t)) * EYE <= angle
                ok |= near | still
    known = ~np.isnan(truth)
    return ~ok & known, int((np.isnan(prep) & known).sum())


def edges(d):
    """Near-side pixels of occlusion edges: a 4-neighbour more than EDGE_RATIO times farther."""
    far = np.where(np.isnan(d), 0.0, d)
    e = np.zeros(d.shape, bool)
    with np.errstate(invalid="ignore"):
        for dy, dx in ((0, 1), (0, -1), (1, 0), (-1, 0)):
            e |= shifted(far, dy, dx) > EDGE_RATIO * far
    return e & np.isfinite(d)


def dilate(mask, r):
    out = mask.copy()
    for dy in range(-r, r + 1):
        for dx in range(-r, r + 1):
            out |= shifted(mask, dy, dx)
    return out


def boundary_f1(prep, truth, tol):
    ep, et = edges(prep), edges(truth)
    if not ep.any() or not et.any():
        return None
    precision = (ep & dilate(et, tol)).sum() / ep.sum()
    recall = (et & dilate(ep, tol)).sum() / et.sum()
    return 0.0 if precision + recall == 0 else float(2 * precision * recall / (precision + recall))


def pieces_under(domain, size):
    """Pixels of `domain` in 8-connected pieces smaller than `size` (pieces joined across the seam)."""
    labels, n = ndimage.label(domain, structure=np.ones((3, 3), int))
    if n == 0:
        return 0
    parent = np.arange(n + 1)

    def find(a):
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a

    h = labels.shape[0]
    for y in range(h):
        a = labels[y, -1]
        if not a:
            continue
        for yy in (y - 1, y, y + 1):
            if 0 <= yy < h and labels[yy, 0]:
                ra, rb = find(a), find(labels[yy, 0])
                if ra != rb:
                    parent[ra] = rb
    roots = np.array([find(i) for i in range(n + 1)])
    sizes = np.bincount(roots[labels.ravel()], minlength=n + 1)
    sizes[0] = 0
    return int(sizes[roots[labels]][domain & (sizes[roots[labels]] < size)].size)


def layer_structure(pano):
    """The layer count, and the pixels the centre sees in pieces under SMALL_PIECE: each pixel
    belongs to the nearest layer there (fill behind it does not count), pieces are 8-connected."""
    import xml.etree.ElementTree as ET
    zs = []
    for layer in ET.parse(os.path.join(pano, "panorama.xml")).getroot().iter("Layer"):
        z = realistic.read_channels(os.path.join(pano, layer.find("Image").get("file")))["Z"]
        zs.append(np.where(np.isnan(z), np.inf, z) if layer.get("role") != "infinity" else
                  np.where(np.isnan(z), np.inf, np.nextafter(np.inf, 0)))
    if not zs:
        return 0, 0
    stack = np.stack(zs)
    front = np.argmin(stack, axis=0)
    seen = np.isfinite(stack.min(axis=0))
    small = sum(pieces_under(seen & (front == i), SMALL_PIECE) for i in range(len(zs)))
    return len(zs), small


def nearest_up(a, shape):
    h, w = a.shape
    ys = np.minimum((np.arange(shape[0]) * h) // shape[0], h - 1)
    xs = np.minimum((np.arange(shape[1]) * w) // shape[1], w - 1)
    return a[ys][:, xs]


def inputs(src, work, kind, scene):
    if kind == "exact":
        return os.path.join(src, "colour.exr"), os.path.join(src, "depth.exr"), []
    return realistic.degrade(src, work, kind, scene)


def one(pomc, src, work, scene, kind, prepare_args, build_args, do_build):
    colour, depth, args = inputs(src, work, kind, scene)
    out = os.path.join(work, f"prepared-{kind}.exr")
    p, dt = realistic.run([pomc, "prepare", "--colour", colour, "--depth", depth, "-o", out, "--json", "--quiet",
                           *args, *prepare_args])
    rep = json.loads(p.stdout) if p.stdout.strip() else {}
    prep = realistic.read_channels(out)["Z"]
    truth = realistic.read_channels(os.path.join(src, "depth.exr"))["Z"]
    if truth.shape != prep.shape:
        truth = nearest_up(truth, prep.shape)
    fly, nan = flying(prep, truth)
    res = dict(scene=scene, kind=kind, prepare_s=round(dt, 2), flying=float(fly.mean()), nan=nan,
               f1_1=boundary_f1(prep, truth, 1), f1_2=boundary_f1(prep, truth, 2),
               snapped=rep.get("snapped_pixels", rep.get("prepare", {}).get("snapped_pixels")))
    np.save(os.path.join(work, f"flying-{kind}.npy"), np.packbits(fly))
    if do_build:
        pano = os.path.join(work, f"pano-{kind}")
        realistic.build(pomc, colour, depth, pano, [*args, *prepare_args, *build_args, "--no-pack"])
        res["layers"], res["small_px"] = layer_structure(pano)
    return res


def fmt(v, spec):
    return "–" if v is None else format(v, spec)


def markdown(results, kinds):
    scenes = sorted({r["scene"] for r in results}, key=lambda s: ["room", "outdoor", "extreme"].index(s)
                    if s in ("room", "outdoor", "extreme") else 9)
    by = {(r["scene"], r["kind"]): r for r in results}
    lines = ["| kind | " + " | ".join(f"{s}: flying % / F1@1 / F1@2 / layers / px < 64" for s in scenes) + " |",
             "|---|" + "---|" * len(scenes)]
    for k in kinds:
        cells = []
        for s in scenes:
            r = by.get((s, k))
            if not r:
                cells.append("")
                continue
            cells.append(f"{100 * r['flying']:.3f} / {fmt(r['f1_1'], '.3f')} / {fmt(r['f1_2'], '.3f')} / "
                         f"{r.get('layers', '–')} / {r.get('small_px', '–')}")
        lines.append(f"| `{k}` | " + " | ".join(cells) + " |")
    worst = max((r["flying"] for r in results if r["kind"] != "exact"), default=None)
    if worst is not None:
        lines.append(f"\nWorst flying share over the degraded kinds: {100 * worst:.3f} %.")
    return "\n".join(lines)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--small", action="store_true", help="the CI corpus (512 x 256)")
    ap.add_argument("--scenes", default="room,outdoor,extreme")
    ap.add_argument("--kinds", default=",".join(KINDS))
    ap.add_argument("--prepare-args", default="", help="extra `pomc prepare` and `pomc build` options")
    ap.add_argument("--build-args", default="", help="extra `pomc build` options only")
    ap.add_argument("--no-build", action="store_true", help="depth figures only")
    ap.add_argument("--tag", default="")
    ap.add_argument("--work", default=os.path.join(realistic.TARGET, "depth-quality"))
    o = ap.parse_args()
    pomc = os.environ.get("POMC_BIN") or realistic.binaries()[0]
    py = realistic.bpy_python()
    sc = [py, os.path.join(REAL, "scenes.py"), "--scenes", o.scenes] + (["--small"] if o.small else [])
    p = subprocess.run(sc, stdout=subprocess.PIPE, text=True)
    if p.returncode != 0:
        sys.exit(f"scenes.py failed ({p.returncode})")
    corpus = p.stdout.strip().splitlines()[-1]
    work = os.path.join(o.work, os.path.basename(corpus), o.tag)
    kinds = o.kinds.split(",")
    results = []
    for scene in o.scenes.split(","):
        for kind in kinds:
            t = time.perf_counter()
            r = one(pomc, os.path.join(corpus, scene), os.path.join(work, scene), scene, kind,
                    o.prepare_args.split(), o.build_args.split(), not o.no_build)
            results.append(r)
            log(f"{scene} {kind}: flying {100 * r['flying']:.3f} %, F1@2 {fmt(r['f1_2'], '.3f')}, layers "
                f"{r.get('layers', '–')}, px<64 {r.get('small_px', '–')} ({time.perf_counter() - t:.1f} s)")
    os.makedirs(work, exist_ok=True)
    json.dump(dict(corpus=corpus, pomc=pomc, prepare_args=o.prepare_args, results=results),
              open(os.path.join(work, "results.json"), "w"), indent=1)
    md = markdown(results, kinds)
    open(os.path.join(work, "results.md"), "w").write(md + "\n")
    print(md)
    log(f"results in {work}/results.json, results.md")


if __name__ == "__main__":
    main()
