#!/usr/bin/env python3
"""Try a depth snap on prepared depth in numpy and score it with depth_quality.py's flying share,
before any of it is written in Rust (issue 51, figure 2).

Reads `prepared-KIND.exr` of an earlier `depth_quality.py --tag TAG` run, applies the snap named by
`--method`, and prints the flying share (%) before and after per scene and kind, with the share of
pixels the snap moved and, on exact depth, how many it moved at all.

    python3 tools/eval/snap_trial.py --from default --method minmax --radius 6
    SNAP_SLOPE=0.5 python3 tools/eval/snap_trial.py --from default --method minmax --radius 8
    python3 tools/eval/snap_trial.py --from on --method where     # where the flying pixels are

Methods:
- `minmax`: grey erosion and dilation of log depth over a (2R+1)² window give each pixel a near and
  a far candidate (the sides' own values); a pixel in a step (the two more than JUMP apart) and more
  than TOL from both goes to the side whose colour (3 × 3 mean at the window's nearest or farthest
  pixel) is closer to its own.
- `sideplane`: `oracle-plane`'s continued side planes, the side chosen by colour (a rule).
- `oracle-plane`: the bounds of taking any settled depth within R, and of each side's plane in
  disparity continued into the pixel.
- `oracle-wide`: the bound of a side choice between the nearest and farthest settled depth within R.
- `third`: in a strong step, a pixel in between whose colour matches neither side takes the near
  side (`THIRD`: the colour distance, default 0.1).
- `ramp`: `third`'s candidates kept only where the pixel lies in a short blurred ramp (≤ 6 px between
  kinks, along 2 of 4 lines, a colour edge across it) and no side's disparity continued linearly
  predicts it (a real slope); see docs/build.md, seventeenth session.
- `wmf`: a weighted mode filter (colour, distance and settledness weights) on pixels inside a step.
- `segplane`: colour superpixels, a plane in disparity per superpixel from its settled pixels, the
  in-between pixels near steps take their superpixel's plane (see `segplane`; needs scikit-image).
"""

import argparse
import os
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(HERE, "realistic"))

import numpy as np  # noqa: E402
from scipy import ndimage  # noqa: E402

import depth_quality as dq  # noqa: E402
import run as realistic  # noqa: E402

SKY_LOG = np.log(1e4)
SLOPE = float(os.environ.get("SNAP_SLOPE", "0"))  # 0: no slope test
SETTLE_BY = os.environ.get("SETTLE_BY", "colour")
CUT_SMOOTH = float(os.environ.get("CUT_SMOOTH", "0.3"))
THIRD = float(os.environ.get("THIRD", "0.1"))


def colour_of(src, work, kind):
    path = os.path.join(work, f"input-{kind}-colour.exr")
    if not os.path.exists(path):
        path = os.path.join(src, "colour.exr")
    c = realistic.read_channels(path)
    rgb = np.stack([c["R"], c["G"], c["B"]], axis=-1)
    # Perceptual-ish: the square root of linear light, 3 × 3 mean against noise.
    rgb = np.sqrt(np.clip(rgb, 0, None))
    return ndimage.uniform_filter(rgb, size=(3, 3, 1), mode=("nearest", "wrap", "nearest"))


def log_depth(d):
    """Log depth with the sky (and unknown depth) at SKY_LOG."""
    L = np.where(np.isinf(d), SKY_LOG, np.log(np.where(d > 0, d, np.nan)))
    return np.where(np.isnan(L), SKY_LOG, L)


def extremes(L, rgb, radius, disc):
    """The nearest and farthest log depth within `radius` (a disc or a square) and the colour there."""
    lo, hi = L.copy(), L.copy()
    c_lo, c_hi = rgb.copy(), rgb.copy()
    for dy in range(-radius, radius + 1):
        for dx in range(-radius, radius + 1):
            if disc and dx * dx + dy * dy > radius * radius:
                continue
            s = dq.shifted(L, dy, dx)
            cs = np.stack([dq.shifted(rgb[..., k], dy, dx) for k in range(3)], axis=-1)
            m = s < lo
            lo, c_lo = np.where(m, s, lo), np.where(m[..., None], cs, c_lo)
            m = s > hi
            hi, c_hi = np.where(m, s, hi), np.where(m[..., None], cs, c_hi)
    return lo, hi, c_lo, c_hi


def in_step(d, rgb, radius, jump, tol):
    """Log depth, the window's extremes, the pixels in between them in a step (range over `jump`,
    more than `tol` from both ends) and each pixel's colour distance to the near and far side."""
    L = log_depth(d)
    lo, hi, c_lo, c_hi = extremes(L, rgb, radius, disc=True)
    band = (hi - lo > np.log(1 + jump)) & (L - lo > np.log(1 + tol)) & (hi - L > np.log(1 + tol))
    return L, lo, hi, band, np.linalg.norm(rgb - c_lo, axis=-1), np.linalg.norm(rgb - c_hi, axis=-1)


def minmax(d, rgb, radius, jump, tol):
    L, lo, hi, band, dn, df = in_step(d, rgb, radius, jump, tol)
    # A step, not a slope: across a slope the window spans 2R times the local gradient; across a
    # blurred step far less (its sides are flat next to its ramp).
    g = np.maximum(np.abs(dq.shifted(L, 0, -1) - dq.shifted(L, 0, 1)),
                   np.abs(dq.shifted(L, -1, 0) - dq.shifted(L, 1, 0))) / 2
    if SLOPE > 0:
        band &= hi - lo < SLOPE * 2 * radius * g
    out = np.where(band & (dn <= df), lo, np.where(band & (dn > df), hi, L))
    res = np.where(out >= SKY_LOG - 1e-6, np.inf, np.exp(out))
    return np.where(np.isnan(d), np.nan, np.where(band, res, d)), band


def third(d, rgb, radius, jump, tol):
    """In a strong step (window range over `jump`), a pixel in between whose colour is far from both
    sides' (more than THIRD, the 3 × 3 mean's square-root RGB distance) takes the near side: a
    strip of its own colour along an occluding edge (a box's top face seen edge-on) is the
    occluder's more often than what it hides."""
    _, lo, hi, band, dn, df = in_step(d, rgb, radius, jump, tol)
    band &= (np.minimum(dn, df) > THIRD) & (hi < SKY_LOG - 1e-6)
    res = np.where(lo >= SKY_LOG - 1e-6, np.inf, np.exp(lo))
    return np.where(np.isnan(d), np.nan, np.where(band, res, d)), band


RAMP = dict(W=6, E=0.05, KINK=2.0, NDIR=2, FMIN=0.2, GATE=1.0, UNIF=1.3, CE=0.1, PASSES=1)
RAMP.update({k: float(v) for k, v in (a.split("=") for a in os.environ.get("RAMP", "").split(",") if a)})
RAMP_DIRS = ((0, 1), (1, 0), (1, 1), (1, -1))


def _along(a, ys, xs, uy, ux, k):
    """`a` at (ys, xs) + k·(uy, ux) (k a number or an array): the seam wraps, the poles clamp."""
    h, w = a.shape
    return a[np.clip(ys + k * uy, 0, h - 1), (xs + k * ux) % w]


def ramp(d, rgb, radius, jump, tol):
    """Ramp, not slope (issue 51): in a strong step (the disc's range over `jump`), a pixel more than
    `tol` inside both ends is a blurred ramp, and takes a side, when
    - along at least NDIR of the four lines through it (row, column, two diagonals) whose own range
      over ±`radius` is over `jump`, it sits in a short run of in-between pixels (at most W) that ends
      on the near side (within `tol` of the line's nearest) one way and on the far side the other way,
      at a log-depth fraction FMIN..1−FMIN between them, with disparity changing over KINK times
      faster across the run than over the 3 px beyond either end, visibly off both ends (their
      parallax for an eye 0.5 m out over GATE pixels), and with colours beyond the two ends more than
      CE apart (an occlusion edge, not a textured surface);
    - and it is not on a slope: along no line with range over `jump` does one side's disparity
      (least squares over 3..6 px out) continued linearly predict the pixel's within E, nor do four
      pixels in a row through it or its neighbour step evenly in disparity (largest step at most UNIF
      times the smallest, all one sign: a slanted face between an edge and a crease).
    The side: a pixel whose colour is far from both window extremes' (over THIRD) takes the near
    side (the nearest value on the near end's half of the first qualifying line), otherwise the
    side whose colour is nearer (the farthest on the far end's half). PASSES: repeat on the result."""
    out = d
    moved = np.zeros(d.shape, bool)
    for _ in range(int(RAMP["PASSES"])):
        out, m = _ramp_pass(out, rgb, radius, jump, tol)
        moved |= m
    return out, moved


def _ramp_pass(d, rgb, radius, jump, tol):
    p = RAMP
    R, W = radius, int(p["W"])
    L, lo, hi, band, dn, df = in_step(d, rgb, R, jump, tol)
    band &= hi < SKY_LOG - 1e-6  # the far side not the sky
    third = np.minimum(dn, df) > THIRD
    inv = dq.inverse(np.where(np.isnan(d), np.inf, d))
    ys, xs = np.nonzero(band)
    n = len(ys)
    t = np.log(1 + tol)
    ang = 2 * np.pi / d.shape[1]
    Lp, ip = L[ys, xs], inv[ys, xs]
    nsand = np.zeros(n, int)
    slope = np.zeros(n, bool)
    val = np.full(n, np.nan)
    tt = np.arange(3, 7, dtype=float)
    A = np.stack([tt, np.ones_like(tt)], 1)
    pick_far = ~third[ys, xs] & (df[ys, xs] < dn[ys, xs])
    for uy, ux in RAMP_DIRS:
        prof = np.stack([_along(L, ys, xs, uy, ux, k) for k in range(-R, R + 1)], 1)
        lo_u, hi_u = prof.min(1), prof.max(1)
        strong = hi_u - lo_u > np.log(1 + jump)
        ends = {}
        for s in (1, -1):
            kk, typ = np.zeros(n, int), np.zeros(n, int)  # first px out at a side; 1 near, 2 far
            for k in range(1, R + 1):
                v = prof[:, R + s * k]
                isn, isf = v <= lo_u + t, v >= hi_u - t
                new = (kk == 0) & (isn | isf)
                kk[new], typ[new] = k, np.where(isn[new], 1, 2)
            ends[s] = (kk, typ)
        (kp, tp), (km, tm) = ends[1], ends[-1]
        sand = strong & (kp > 0) & (km > 0) & (tp * tm == 2) & (kp + km - 1 <= W)
        f = (Lp - lo_u) / np.maximum(hi_u - lo_u, 1e-9)
        sand &= (f >= p["FMIN"]) & (f <= 1 - p["FMIN"])
        g_run = np.abs(_along(inv, ys, xs, uy, ux, kp) - _along(inv, ys, xs, uy, ux, -km)) / (kp + km)
        g_p = np.abs(_along(inv, ys, xs, uy, ux, kp + 3) - _along(inv, ys, xs, uy, ux, kp)) / 3
        g_m = np.abs(_along(inv, ys, xs, uy, ux, -km - 3) - _along(inv, ys, xs, uy, ux, -km)) / 3
        sand &= g_run > p["KINK"] * np.maximum(g_p, g_m)
        inear, ifar = np.exp(-lo_u), np.where(hi_u >= SKY_LOG - 1e-6, 0.0, np.exp(-hi_u))
        sand &= ((ip - ifar) * dq.EYE > p["GATE"] * ang) & ((inear - ip) * dq.EYE > p["GATE"] * ang)
        ca = np.stack([_along(rgb[..., c], ys, xs, uy, ux, kp + 1) for c in range(3)], 1)
        cb = np.stack([_along(rgb[..., c], ys, xs, uy, ux, -km - 1) for c in range(3)], 1)
        sand &= np.linalg.norm(ca - cb, axis=1) > p["CE"]
        nside = np.where(tp == 1, prof[:, R + 1:].min(1), prof[:, :R].min(1))
        fside = np.where(tp == 2, prof[:, R + 1:].max(1), prof[:, :R].max(1))
        val = np.where(sand & (nsand == 0), np.where(pick_far, fside, nside), val)
        nsand += sand
        # Slope: one side's disparity 3..6 px out, continued linearly, predicts the pixel's.
        on = np.zeros(n, bool)
        for s in (1, -1):
            iv = np.stack([_along(inv, ys, xs, uy * s, ux * s, k) for k in tt.astype(int)], 1)
            coef = np.linalg.lstsq(A, iv.T, rcond=None)[0]
            on |= np.abs(coef[1] - ip) <= p["E"] * np.maximum(ip, 1e-9)
        # Slope: four pixels in a row through the pixel or its neighbour step evenly in disparity.
        q = np.stack([_along(inv, ys, xs, uy, ux, k) for k in range(-4, 5)], 1)
        st_all = np.diff(q, axis=1)
        for a in range(6):
            st = st_all[:, a:a + 3]
            same = np.all(st > 0, 1) | np.all(st < 0, 1)
            mx, mn = np.abs(st).max(1), np.abs(st).min(1)
            on |= same & (mx <= p["UNIF"] * mn) & (mx > 1e-3 * np.maximum(ip, 1e-9))
        slope |= on & strong
    ok = (nsand >= p["NDIR"]) & ~slope
    moved = np.zeros(d.shape, bool)
    moved[ys[ok], xs[ok]] = True
    out = d.copy()
    v = val[ok]
    out[ys[ok], xs[ok]] = np.where(v >= SKY_LOG - 1e-6, np.inf, np.exp(v))
    return out, moved


def settle(d, rgb, radius, tol, moved):
    """The pixels the median snap `moved` that it left in between: to the nearer in colour of the
    nearest and farthest depth within `radius` (the sides, snapped)."""
    L = log_depth(d)
    lo, hi, c_lo, c_hi = extremes(L, rgb, radius, disc=False)
    if os.environ.get("SETTLE_ALL"):
        moved = hi - lo > np.log(1.1)
    band = moved & (L - lo > np.log(1 + tol)) & (hi - L > np.log(1 + tol))
    if SETTLE_BY == "far":
        near = np.zeros(L.shape, bool)
    elif SETTLE_BY == "depth":
        near = (L - lo) <= (hi - L)
    elif SETTLE_BY == "nearest-colour":
        # Each side's pixels within the window (within tol of its depth); the side holding the pixel
        # of nearest colour wins (a textured side's mean colour matches neither side).
        t = np.log(1 + tol)
        dn, df = np.full(L.shape, np.inf), np.full(L.shape, np.inf)
        for dy in range(-radius, radius + 1):
            for dx in range(-radius, radius + 1):
                if dy == 0 and dx == 0:
                    continue
                s = dq.shifted(L, dy, dx)
                cs = np.stack([dq.shifted(rgb[..., k], dy, dx) for k in range(3)], axis=-1)
                dist = np.linalg.norm(rgb - cs, axis=-1)
                dn = np.where(s <= lo + t, np.minimum(dn, dist), dn)
                df = np.where(s >= hi - t, np.minimum(df, dist), df)
        near = dn <= df
    else:
        near = np.linalg.norm(rgb - c_lo, axis=-1) <= np.linalg.norm(rgb - c_hi, axis=-1)
    out = np.where(band & near, lo, np.where(band, hi, L))
    res = np.where(out >= SKY_LOG - 1e-6, np.inf, np.exp(out))
    return np.where(band, res, d), band


def cut(d, rgb, radius, tol, moved):
    """Two labels, near and far, for the pixels of a step (those the median snap `moved`, 1 px
    around, and more than `tol` from both sides): each side's depth is the nearest or farthest
    within `radius`; each side's colour the mean over its plateau in the window (pixels within `tol`
    of it); a graph cut (PyMaxflow) with a colour data term, a Potts term weighted by colour
    likeness between band pixels, and a pull towards the side of each neighbour outside the band."""
    import maxflow
    L = log_depth(d)
    offs = [(dy, dx) for dy in range(-radius, radius + 1) for dx in range(-radius, radius + 1)]
    lo, hi = L.copy(), L.copy()
    for dy, dx in offs:
        s = dq.shifted(L, dy, dx)
        lo, hi = np.minimum(lo, s), np.maximum(hi, s)
    t = np.log(1 + tol)
    sum_lo, sum_hi = np.zeros(rgb.shape), np.zeros(rgb.shape)
    n_lo, n_hi = np.zeros(L.shape), np.zeros(L.shape)
    for dy, dx in offs:
        s = dq.shifted(L, dy, dx)
        cs = np.stack([dq.shifted(rgb[..., k], dy, dx) for k in range(3)], axis=-1)
        m = s <= lo + t
        sum_lo += cs * m[..., None]
        n_lo += m
        m = s >= hi - t
        sum_hi += cs * m[..., None]
        n_hi += m
    c_lo, c_hi = sum_lo / np.maximum(n_lo, 1)[..., None], sum_hi / np.maximum(n_hi, 1)[..., None]
    grown = moved.copy()
    for dy, dx in ((0, 1), (0, -1), (1, 0), (-1, 0)):
        grown |= dq.shifted(moved, dy, dx)
    band = grown & (hi - lo > np.log(1.1)) & (L - lo > t) & (hi - L > t)
    idx = -np.ones(L.shape, int)
    ys, xs = np.nonzero(band)
    idx[ys, xs] = np.arange(len(ys))
    if len(ys) == 0:
        return d, band
    g = maxflow.Graph[float]()
    g.add_nodes(len(ys))
    dn = np.linalg.norm(rgb - c_lo, axis=-1)[ys, xs]
    df = np.linalg.norm(rgb - c_hi, axis=-1)[ys, xs]
    # Source side = near: the cost of near goes on the sink edge.
    cost_near, cost_far = dn.copy(), df.copy()
    h, w = L.shape
    sigma2 = 0.01
    for dy, dx in ((0, 1), (1, 0), (0, -1), (-1, 0)):
        qy, qx = np.clip(ys + dy, 0, h - 1), (xs + dx) % w
        qi = idx[qy, qx]
        like = CUT_SMOOTH * np.exp(-np.sum((rgb[ys, xs] - rgb[qy, qx]) ** 2, axis=-1) / sigma2)
        inside = qi >= 0
        if dy >= 0 and dx >= 0:
            for a, b, c in zip(np.arange(len(ys))[inside], qi[inside], like[inside]):
                g.add_edge(int(a), int(b), float(c), float(c))
        # A neighbour outside the band pulls towards the side its depth is on.
        out = ~inside
        lq = L[qy, qx]
        to_near = np.abs(lq - lo[ys, xs]) < np.abs(lq - hi[ys, xs])
        cost_far += np.where(out & to_near, like, 0)
        cost_near += np.where(out & ~to_near, like, 0)
    for i in range(len(ys)):
        g.add_tedge(i, float(cost_far[i]), float(cost_near[i]))
    g.maxflow()
    seg = np.array([g.get_segment(i) for i in range(len(ys))])  # 0: source (near)
    out = L.copy()
    out[ys, xs] = np.where(seg == 0, lo[ys, xs], hi[ys, xs])
    res = np.where(out >= SKY_LOG - 1e-6, np.inf, np.exp(out))
    return np.where(band, res, d), band


SEG_PX = int(os.environ.get("SEG_PX", "64"))  # segplane: mean superpixel size, px
SEG_C = float(os.environ.get("SEG_C", "10"))  # segplane: SLIC compactness
SEG_GRAD = float(os.environ.get("SEG_GRAD", "0.01"))  # segplane: settled below this log-depth step


def log_step(L):
    """Per pixel, the larger of the central log-depth differences along rows and columns (per pixel)."""
    g = np.zeros(L.shape)
    for dy, dx in ((0, 1), (1, 0)):
        g = np.maximum(g, np.abs(dq.shifted(L, -dy, -dx) - dq.shifted(L, dy, dx)) / 2)
    return g


def rays(h, w):
    """Unit ray per pixel of an equirect canvas (any right-handed frame will do for plane fits)."""
    th = (np.arange(h) + 0.5) / h * np.pi
    ph = (np.arange(w) + 0.5) / w * 2 * np.pi
    st = np.sin(th)[:, None]
    return np.stack([st * np.cos(ph)[None, :], np.repeat(np.cos(th)[:, None], w, 1), st * np.sin(ph)[None, :]], -1)


def plane_fits(labels, n, r, disp, use):
    """Least-squares disparity = a · ray per label over the pixels `use`, reweighted twice (Tukey)
    against ramps inside a segment; NaN rows where a label has under 6 such pixels."""
    lab, rr, dd = labels[use], r[use], disp[use]
    wgt = np.ones(len(dd))
    coef = np.full((n, 3), np.nan)
    for _ in range(3):
        A = np.zeros((n, 3, 3))
        b = np.zeros((n, 3))
        for i in range(3):
            b[:, i] = np.bincount(lab, wgt * rr[:, i] * dd, n)
            for j in range(3):
                A[:, i, j] = np.bincount(lab, wgt * rr[:, i] * rr[:, j], n)
        cnt = np.bincount(lab, wgt > 0, n)
        ok = (cnt >= 6) & (np.abs(np.linalg.det(A)) > 1e-12 * np.maximum(A[:, 0, 0] + A[:, 1, 1] + A[:, 2, 2], 1e-30) ** 3)
        coef[:] = np.nan
        coef[ok] = np.linalg.solve(A[ok], b[ok][..., None])[..., 0]
        pred = np.einsum("ij,ij->i", rr, np.nan_to_num(coef[lab]))
        res = np.abs(pred - dd) / np.maximum(np.abs(dd), 1e-6)
        scale = 0.05
        wgt = np.where(res < scale, (1 - (res / scale) ** 2) ** 2, 0.0)
    return coef


def segplane(d, rgb, jump, tol, radius):
    """Colour superpixels (SLIC), a plane in disparity fitted to each from its settled pixels (log
    depth steps under SEG_GRAD), superpixels without enough taking the plane of the adjacent one of
    nearest mean colour; pixels within `radius` of a step (window range over `jump`) take their
    superpixel's plane where it lies within the window's range."""
    from skimage.segmentation import slic
    h, w = d.shape
    L = log_depth(d)
    disp = np.where(np.isinf(d), 0.0, 1.0 / np.where(d > 0, d, np.nan))
    labels = slic(rgb, n_segments=max(h * w // SEG_PX, 1), compactness=SEG_C, start_label=0,
                  channel_axis=-1, enforce_connectivity=True)
    n = labels.max() + 1
    g = log_step(L)
    r = rays(h, w)
    use = (g < SEG_GRAD) & np.isfinite(disp)
    coef = plane_fits(labels, n, r, disp, use)
    # Mean colour per label, and adjacency, to hand planes to superpixels without one.
    mean = np.stack([np.bincount(labels.ravel(), rgb[..., k].ravel(), n) for k in range(3)], -1)
    mean /= np.maximum(np.bincount(labels.ravel(), None, n), 1)[:, None]
    pairs = set()
    for dy, dx in ((0, 1), (1, 0)):
        a, b = labels, dq.shifted(labels, -dy, -dx)
        m = a != b
        pairs |= set(zip(a[m].tolist(), b[m].tolist()))
    adj = [[] for _ in range(n)]
    for a, b in pairs:
        adj[a].append(b)
        adj[b].append(a)
    for _ in range(8):
        missing = np.nonzero(np.isnan(coef[:, 0]))[0]
        if len(missing) == 0:
            break
        new = coef.copy()
        for s in missing:
            cands = [t for t in adj[s] if not np.isnan(coef[t, 0])]
            if cands:
                t = min(cands, key=lambda t: np.sum((mean[s] - mean[t]) ** 2))
                new[s] = coef[t]
        coef = new
    pred = np.einsum("hwi,hwi->hw", r, np.nan_to_num(coef[labels], nan=np.nan))
    lo, hi, _, _ = extremes(L, rgb, radius, disc=False)
    with np.errstate(divide="ignore", invalid="ignore"):
        pl = np.where(pred <= 1e-6, SKY_LOG, -np.log(pred))
    t = np.log(1 + tol)
    band = (hi - lo > np.log(1 + jump)) & np.isfinite(pl) & (pl >= lo - t) & (pl <= hi + t) & ~np.isnan(d)
    band &= np.abs(pl - L) > 1e-6
    if not os.environ.get("SEG_ALL"):
        band &= (L - lo > t) & (hi - L > t)  # only what lies between the window's sides
    res = np.where(pl >= SKY_LOG - 1e-6, np.inf, np.exp(pl))
    return np.where(band, res, d), band


def oracle(prep, truth, rgb, radius, tol):
    """The bound of any side decision over the window's extremes: each flying pixel takes whichever of
    the nearest and farthest depth within `radius` is nearer the truth. Also the share of flying
    pixels where the nearest-colour rule (SETTLE_BY=nearest-colour, window 7 × 7) picks that side."""
    L, T = log_depth(prep), log_depth(truth)
    lo, hi, _, _ = extremes(L, rgb, radius, disc=False)
    fly = dq.flying(prep, truth)[0]
    near = np.abs(lo - T) < np.abs(hi - T)
    best = np.where(near, lo, hi)
    out = prep.copy()
    out[fly] = np.where(best[fly] >= SKY_LOG - 1e-6, np.inf, np.exp(best[fly]))
    t = np.log(1 + tol)
    dn, df = np.full(L.shape, np.inf), np.full(L.shape, np.inf)
    for dy in range(-3, 4):
        for dx in range(-3, 4):
            if dy or dx:
                s = dq.shifted(L, dy, dx)
                cs = np.stack([dq.shifted(rgb[..., k], dy, dx) for k in range(3)], axis=-1)
                dist = np.linalg.norm(rgb - cs, axis=-1)
                dn = np.where(s <= lo + t, np.minimum(dn, dist), dn)
                df = np.where(s >= hi - t, np.minimum(df, dist), df)
    agree = ((dn <= df) == near)[fly].mean() * 100 if fly.any() else 100.0
    return (f"{fly.mean() * 100:.2f} → oracle {dq.flying(out, truth)[0].mean() * 100:.2f}; "
            f"colour picks the oracle's side for {agree:.0f} %")


def oracle_wide(prep, truth, radius):
    """The bound of a side decision over settled candidates from afar: the nearest and farthest log
    depth within `radius` among settled pixels (log-depth gradient under SEG_GRAD); each flying pixel
    takes whichever is nearer the truth."""
    L, T = log_depth(prep), log_depth(truth)
    g = log_step(L)
    settled = g < SEG_GRAD
    fp = np.ones((2 * radius + 1, 2 * radius + 1), bool)
    lo = ndimage.grey_erosion(np.where(settled, L, np.inf), footprint=fp, mode="wrap")
    hi = ndimage.grey_dilation(np.where(settled, L, -np.inf), footprint=fp, mode="wrap")
    lo, hi = np.where(np.isfinite(lo), lo, L), np.where(np.isfinite(hi), hi, L)
    fly = dq.flying(prep, truth)[0]
    near = np.abs(lo - T) < np.abs(hi - T)
    best = np.where(near, lo, hi)
    out = prep.copy()
    out[fly] = np.where(best[fly] >= SKY_LOG - 1e-6, np.inf, np.exp(best[fly]))
    return (f"{fly.mean() * 100:.2f} → wide oracle {dq.flying(out, truth)[0].mean() * 100:.2f}, "
            f"settled {settled.mean() * 100:.0f} %")


def oracle_plane(prep, truth, radius):
    """Bounds of rules that give a flying pixel depth from what lies within `radius` (settled pixels
    only: log-depth step under SEG_GRAD): `any` takes the settled value nearest the truth (the bound of
    every rule that picks an observed depth); `plane` splits the window's settled pixels into a near and
    a far side (at the middle of their log-depth range) and continues each side's plane in disparity
    (least squares, disparity = a · ray; the sky is disparity 0) to the pixel, taking whichever of the
    two continued depths (or the two sides' medians) is nearer the truth."""
    L, T = log_depth(prep), log_depth(truth)
    h, w = L.shape
    g = log_step(L)
    settled = (g < SEG_GRAD) & ~np.isnan(prep)
    disp = np.where(np.isinf(prep), 0.0, 1.0 / np.where(prep > 0, prep, np.nan))
    r = rays(h, w)
    fly = dq.flying(prep, truth)[0]
    out_any, out_plane = prep.copy(), prep.copy()
    ys, xs = np.nonzero(fly)
    R = radius
    cols_base = np.arange(-R, R + 1)
    for y, x in zip(ys.tolist(), xs.tolist()):
        y0, y1 = max(0, y - R), min(h, y + R + 1)
        cols = (x + cols_base) % w
        m = settled[y0:y1][:, cols]
        if not m.any():
            continue
        Lw = L[y0:y1][:, cols][m]
        t = T[y, x]
        best = Lw[np.argmin(np.abs(Lw - t))]
        out_any[y, x] = np.inf if best >= SKY_LOG - 1e-6 else np.exp(best)
        lo, hi = Lw.min(), Lw.max()
        cands = []
        dw, rw = disp[y0:y1][:, cols][m], r[y0:y1][:, cols][m]
        sides = [np.ones(len(Lw), bool)] if hi - lo < np.log(1.1) else [Lw <= (lo + hi) / 2, Lw > (lo + hi) / 2]
        for side in sides:
            cands.append(np.median(Lw[side]))
            if side.sum() >= 6:
                coef, *_ = np.linalg.lstsq(rw[side], dw[side], rcond=None)
                dp = float(coef @ r[y, x])
                cands.append(SKY_LOG if dp <= 1e-4 else min(-np.log(dp), SKY_LOG))
        c = min(cands, key=lambda v: abs(v - t))
        out_plane[y, x] = np.inf if c >= SKY_LOG - 1e-6 else np.exp(c)
    f_any = dq.flying(out_any, truth)[0].mean() * 100
    f_plane = dq.flying(out_plane, truth)[0].mean() * 100
    return f"{fly.mean() * 100:.2f} → any settled {f_any:.2f}, side planes {f_plane:.2f}"


def side_plane(d, rgb, radius, jump, tol):
    """A rule, not a bound (`oracle-plane`'s side planes with the side chosen by colour): a pixel that
    is not settled (log-depth step over SEG_GRAD), whose window of settled pixels spans a step (range
    over `jump`) and that lies more than `tol` inside both ends, takes the continued plane (or the
    median) of the side whose mean colour over its settled pixels in the window is nearer its own."""
    L = log_depth(d)
    h, w = L.shape
    g = log_step(L)
    settled = (g < SEG_GRAD) & ~np.isnan(d)
    disp = np.where(np.isinf(d), 0.0, 1.0 / np.where(d > 0, d, np.nan))
    r = rays(h, w)
    fp = np.ones((2 * radius + 1, 2 * radius + 1), bool)
    lo = ndimage.grey_erosion(np.where(settled, L, np.inf), footprint=fp, mode="wrap")
    hi = ndimage.grey_dilation(np.where(settled, L, -np.inf), footprint=fp, mode="wrap")
    t = np.log(1 + tol)
    cand = ~settled & ~np.isnan(d) & np.isfinite(lo) & np.isfinite(hi) & (hi - lo > np.log(1 + jump))
    cand &= (L > lo + t) & (L < hi - t)
    out = d.copy()
    R = radius
    cols_base = np.arange(-R, R + 1)
    for y, x in zip(*[v.tolist() for v in np.nonzero(cand)]):
        y0, y1 = max(0, y - R), min(h, y + R + 1)
        cols = (x + cols_base) % w
        m = settled[y0:y1][:, cols]
        Lw = L[y0:y1][:, cols][m]
        mid = (Lw.min() + Lw.max()) / 2
        cw = rgb[y0:y1][:, cols][m]
        best, val = np.inf, None
        for side in (Lw <= mid, Lw > mid):
            dist = np.linalg.norm(cw[side].mean(0) - rgb[y, x])
            if dist >= best:
                continue
            best = dist
            v = np.median(Lw[side])
            if side.sum() >= 6:
                coef, *_ = np.linalg.lstsq(r[y0:y1][:, cols][m][side], disp[y0:y1][:, cols][m][side], rcond=None)
                dp = float(coef @ r[y, x])
                v = SKY_LOG if dp <= 1e-4 else min(-np.log(dp), SKY_LOG)
            val = v
        out[y, x] = np.inf if val >= SKY_LOG - 1e-6 else np.exp(val)
    return out, cand


WMF_BIN = float(os.environ.get("WMF_BIN", "0.02"))  # wmf: histogram bin, log depth
WMF_COLOUR = float(os.environ.get("WMF_COLOUR", "0.06"))  # wmf: colour sigma (sqrt linear RGB)
WMF_SETTLE = float(os.environ.get("WMF_SETTLE", "0.01"))  # wmf: ramp weight falls past this step
WMF_EYE = float(os.environ.get("WMF_EYE", "0.5"))  # wmf: m, parallax gate (0.5: the flying test's)
WMF_RUNS = float(os.environ.get("WMF_RUNS", "0"))  # wmf: >0: settled too where the +-1 px slope is within this share of the +-WMF_SPAN one
WMF_SPAN = int(os.environ.get("WMF_SPAN", "5"))  # wmf: the slope test's wide span (px)
WMF_PLANE = float(os.environ.get("WMF_PLANE", "0.05"))  # wmf: line-fit residual / span under which a window is a plane


def wmf(d, rgb, radius, jump, tol):
    """Weighted mode filter (Min, Lu and Do 2012) on the pixels inside a step of their window:
    a histogram of the window's log depths, each weighted by distance, colour likeness and how
    settled it is (ramp values count less), smoothed by one bin; the pixel takes the weighted mean
    of the values in the mode's bin and its neighbours. Never an in-between value unless the
    window's own weights put one first."""
    L = log_depth(d)
    lo, hi, _, _ = extremes(L, rgb, radius, disc=True)
    band = (hi - lo > np.log(1 + jump)) & (L - lo > np.log(1 + tol)) & (hi - L > np.log(1 + tol))
    h, w = L.shape
    inv = np.exp(-L) * (L < SKY_LOG - 1e-6)
    # Only where the sides' parallax for an eye WMF_EYE out is over a pixel: elsewhere no choice
    # moves anything (far mountains against the sky).
    band &= (np.exp(-lo) - np.where(hi >= SKY_LOG - 1e-6, 0.0, np.exp(-hi))) * WMF_EYE > 2 * np.pi / w
    if WMF_PLANE > 0:
        # Not a plane: disparity along the steeper axis is not a line over the window (grazing
        # ground is; a blurred step is flat, ramp, flat).
        gx = np.abs(dq.shifted(inv, 0, -1) - dq.shifted(inv, 0, 1))
        gy = np.abs(dq.shifted(inv, -1, 0) - dq.shifted(inv, 1, 0))
        t = np.arange(-radius, radius + 1, dtype=float)
        t -= t.mean()
        for axis_x in (True, False):
            sel = band & ((gx >= gy) == axis_x)
            ii = np.flatnonzero(sel)
            if len(ii) == 0:
                continue
            yy, xx = np.unravel_index(ii, L.shape)
            prof = np.stack([inv[yy, (xx + o) % w] if axis_x else inv[np.clip(yy + o, 0, h - 1), xx]
                             for o in range(-radius, radius + 1)], axis=1)
            slope = prof @ t / (t @ t)
            res = prof - prof.mean(axis=1, keepdims=True) - slope[:, None] * t[None, :]
            span = prof.max(axis=1) - prof.min(axis=1)
            plane = np.sqrt((res ** 2).mean(axis=1)) < WMF_PLANE * np.maximum(span, 1e-12)
            band.flat[ii[plane]] = False
    idx = np.flatnonzero(band)
    if len(idx) == 0:
        return d, band
    g = log_step(L)
    settled = np.exp(-(g / WMF_SETTLE) ** 2)
    if WMF_RUNS > 0:
        # Grazing ground steps as much as a ramp but runs on as a plane (disparity linear over
        # +-2 px along both axes): settled too, or the sky beside the horizon outweighs it.
        flat = np.ones(L.shape, bool)
        # The local slope equals the slope over +-WMF_SPAN (a ramp's middle is steeper than its
        # span's mean, even where its second differences vanish by symmetry).
        for dy, dx in ((0, 1), (1, 0)):
            k = WMF_SPAN
            s1 = (dq.shifted(inv, -dy, -dx) - dq.shifted(inv, dy, dx)) / 2
            sk = (dq.shifted(inv, -k * dy, -k * dx) - dq.shifted(inv, k * dy, k * dx)) / (2 * k)
            flat &= np.abs(s1 - sk) <= WMF_RUNS * np.abs(sk) + 1e-9
        settled = np.where(flat & (L < SKY_LOG - 1e-6), 1.0, settled)
    L0 = L.min()
    nb = int((max(SKY_LOG, L.max()) - L0) / WMF_BIN) + 3
    by, bx = np.unravel_index(idx, L.shape)
    c0 = rgb.reshape(-1, 3)[idx]
    sig = max(radius / 2, 1.0)
    offsets = [(dy, dx) for dy in range(-radius, radius + 1) for dx in range(-radius, radius + 1)
               if dx * dx + dy * dy <= radius * radius]
    out = L.copy()
    for start in range(0, len(idx), 20000):
        sl = slice(start, start + 20000)
        n = len(idx[sl])
        hist = np.zeros((n, nb))
        vals = []
        for dy, dx in offsets:
            yy = np.clip(by[sl] + dy, 0, h - 1)
            xx = (bx[sl] + dx) % w
            v = L[yy, xx]
            cw = np.exp(-np.sum((rgb[yy, xx] - c0[sl]) ** 2, axis=-1) / (2 * WMF_COLOUR ** 2))
            wt = np.exp(-(dx * dx + dy * dy) / (2 * sig * sig)) * cw * settled[yy, xx]
            b = ((v - L0) / WMF_BIN).astype(int) + 1
            np.add.at(hist, (np.arange(n), b), wt)
            vals.append((v, wt, b))
        sm = hist.copy()
        sm[:, 1:] += hist[:, :-1]
        sm[:, :-1] += hist[:, 1:]
        mode = sm.argmax(axis=1)
        num = np.zeros(n)
        den = np.zeros(n)
        for v, wt, b in vals:
            m = np.abs(b - mode) <= 1
            num += np.where(m, wt * v, 0)
            den += np.where(m, wt, 0)
        out.flat[idx[sl]] = np.where(den > 0, num / np.maximum(den, 1e-30), L.flat[idx[sl]])
    res = np.where(out >= SKY_LOG - 1e-6, np.inf, np.exp(out))
    return np.where(np.isnan(d), np.nan, np.where(band, res, d)), band


def where(prep, truth):
    """Where the flying pixels are: shares by distance to the nearest exact occlusion edge (< 1, 1–2,
    2–5, 5–20 px and more), and the share whose truth is the sky."""
    fly = dq.flying(prep, truth)[0]
    far = np.where(np.isnan(truth), 0, np.where(np.isinf(truth), 1e6, truth))
    edge = np.zeros(truth.shape, bool)
    for dy, dx in ((0, 1), (0, -1), (1, 0), (-1, 0)):
        s = dq.shifted(far, dy, dx)
        edge |= (s > dq.EDGE_RATIO * far) | (far > dq.EDGE_RATIO * s)
    dist = ndimage.distance_transform_edt(~edge)[fly]
    n = max(int(fly.sum()), 1)
    shares = np.histogram(dist, [0, 1, 2, 5, 20, np.inf])[0] / n * 100
    sky = np.isinf(truth[fly]).sum() / n * 100
    return f"{fly.mean() * 100:.2f} % flying: " + " / ".join(f"{v:.0f}" for v in shares) + f" %; sky {sky:.0f} %"


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--from", dest="tag", default="default", help="the depth_quality.py run to start from")
    ap.add_argument("--scenes", default="room,outdoor,extreme")
    ap.add_argument("--kinds", default=",".join(dq.KINDS))
    ap.add_argument("--method", default="minmax", help="minmax; settle (needs --base: the run before the snap); where (no snap: where the flying pixels are)")
    ap.add_argument("--base", default="default", help="settle: the run without the snap (what it moved)")
    ap.add_argument("--radius", type=int, default=6)
    ap.add_argument("--jump", type=float, default=0.1)
    ap.add_argument("--tol", type=float, default=0.03)
    ap.add_argument("--work", default=os.path.join(realistic.TARGET, "depth-quality"))
    ap.add_argument("--corpus", default="85b5eb16750c")
    a = ap.parse_args()
    corpus = os.path.join(realistic.TARGET, "realistic-corpus", a.corpus)
    print(f"| kind | {' | '.join(a.scenes.split(','))} |  (flying % before → after, moved %)")
    for kind in a.kinds.split(","):
        cells = []
        for scene in a.scenes.split(","):
            src, work = os.path.join(corpus, scene), os.path.join(a.work, a.corpus, a.tag, scene)
            prep = realistic.read_channels(os.path.join(work, f"prepared-{kind}.exr"))["Z"]
            truth = realistic.read_channels(os.path.join(src, "depth.exr"))["Z"]
            if truth.shape != prep.shape:
                truth = dq.nearest_up(truth, prep.shape)
            rgb = colour_of(src, work, kind)
            if rgb.shape[:2] != prep.shape:
                rgb = np.stack([dq.nearest_up(rgb[..., k], prep.shape) for k in range(3)], axis=-1)
            t0 = time.time()
            if a.method == "where":
                cells.append(where(prep, truth))
                continue
            if a.method == "oracle-wide":
                cells.append(oracle_wide(prep, truth, a.radius))
                continue
            if a.method == "oracle-plane":
                cells.append(oracle_plane(prep, truth, a.radius))
                continue
            if a.method == "oracle":
                cells.append(oracle(prep, truth, rgb, a.radius, a.tol))
                continue
            if a.method == "cut":
                base = realistic.read_channels(
                    os.path.join(a.work, a.corpus, a.base, scene, f"prepared-{kind}.exr"))["Z"]
                changed = ~((prep == base) | (np.isnan(prep) & np.isnan(base)))
                out, moved = cut(prep, rgb, a.radius, a.tol, changed)
            elif a.method == "settle":
                base = realistic.read_channels(
                    os.path.join(a.work, a.corpus, a.base, scene, f"prepared-{kind}.exr"))["Z"]
                changed = ~((prep == base) | (np.isnan(prep) & np.isnan(base)))
                out, moved = settle(prep, rgb, a.radius, a.tol, changed)
            elif a.method == "sideplane":
                out, moved = side_plane(prep, rgb, a.radius, a.jump, a.tol)
            elif a.method == "third":
                out, moved = third(prep, rgb, a.radius, a.jump, a.tol)
            elif a.method == "ramp":
                out, moved = ramp(prep, rgb, a.radius, a.jump, a.tol)
            elif a.method == "wmf":
                out, moved = wmf(prep, rgb, a.radius, a.jump, a.tol)
            elif a.method == "segplane":
                out, moved = segplane(prep, rgb, a.jump, a.tol, a.radius)
            else:
                out, moved = minmax(prep, rgb, a.radius, a.jump, a.tol)
            dt = time.time() - t0
            before = dq.flying(prep, truth)[0].mean() * 100
            after = dq.flying(out, truth)[0].mean() * 100
            cells.append(f"{before:.2f} → **{after:.2f}** ({moved.mean() * 100:.2f} %, {int(moved.sum())} px, {dt:.1f} s)")
        print(f"| `{kind}` | {' | '.join(cells)} |", flush=True)


if __name__ == "__main__":
    main()
