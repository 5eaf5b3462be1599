#!/usr/bin/env python3
"""Omnidirectional stereo truth and scores for `pomc render --camera ods` (docs/stereo.md).

Truth: Blender Cycles' panoramic equirect camera with spherical stereo (parallel convergence, the
given interocular distance, pole merge 60-75 degrees unless --no-pole-merge) renders each scene of
the realistic corpus (scenes.py, same options) for both eyes, at the corpus panorama's size per eye.
The eyes are stored in pomc's equirect convention (azimuth 2 pi x / w from +X towards +Y), as
truth/ods_L.exr and truth/ods_R.exr, next to centre.exr (the corpus colour.exr, converted alike).

Then, with --pomc, each scene is built (`pomc build --convention blender`), the two-layer reference
is made (layers from the true background, as run.py does) and both are rendered with
`--camera ods` (splat and mesh) and `--camera equirect` from the centre; each eye is scored (PSNR of
sRGB, WS-PSNR) against the truth.

  bpy-python stereo.py [scenes.py options] [--ipd 0.064] [--no-pole-merge]
                       [--pomc BIN --fixtures BIN --out DIR]
"""
import argparse
import hashlib
import json
import math
import os
import shutil
import subprocess
import sys
import time

import numpy as np
import OpenEXR

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import scenes  # noqa: E402  (bpy scenes of the corpus)
from run import read_rgb, srgb  # noqa: E402  (the corpus harness's scoring)

import bpy  # noqa: E402


def to_pomc(img):
    """Blender's equirect convention (azimuth pi(1 - 2u)) to pomc's (2 pi x / w): column j of pomc is
    column w/2 - 1 - j of Blender, modulo w."""
    w = img.shape[1]
    return np.ascontiguousarray(np.roll(img[:, ::-1], w // 2, axis=1))


def render_truth(name, out, o, ipd, merge):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scenes.SCENES[name]()
    s = bpy.context.scene
    pano = bpy.data.objects.new("pano", bpy.data.cameras.new("pano"))
    s.collection.objects.link(pano)
    cam = pano.data
    cam.type = "PANO"
    cam.panorama_type = "EQUIRECTANGULAR"
    cam.clip_start, cam.clip_end = 0.001, 1e5
    pano.rotation_euler = scenes.PANO_ROTATION
    st = cam.stereo
    st.convergence_mode = "PARALLEL"
    st.interocular_distance = ipd
    st.use_spherical_stereo = True
    st.use_pole_merge = merge
    st.pole_merge_angle_from = math.radians(60)
    st.pole_merge_angle_to = math.radians(75)
    s.camera = pano
    w, h = o.size
    scenes.setup_render(w, h, o.spp, o.denoise)
    s.render.use_multiview = True
    s.render.views_format = "STEREO_3D"
    s.render.image_settings.views_format = "INDIVIDUAL"
    tmp = os.path.join(out, "_tmp.exr")
    s.render.filepath = tmp
    bpy.ops.render.render(write_still=True)
    for eye in "LR":
        path = os.path.join(out, f"_tmp_{eye}.exr")
        ch = OpenEXR.File(path, separate_channels=True).channels()
        rgb = np.stack([ch[k].pixels for k in sorted(ch) if k.split(".")[-1] in "RGB" and "Combined" in k], -1)
        rgb = rgb[..., ::-1].astype(np.float32)  # sorted: B, G, R
        scenes.write_rgb(os.path.join(out, f"ods_{eye}.exr"), to_pomc(rgb))
        os.remove(path)


def scores(a, b):
    """PSNR and WS-PSNR (rows weighted by cos latitude) of sRGB images."""
    a, b = srgb(a), srgb(b)
    err = ((a - b) ** 2).mean(axis=(1, 2))
    h = a.shape[0]
    wts = np.cos((np.arange(h) + 0.5 - h / 2) / h * np.pi)
    mse, ws = float(err.mean()), float((err * wts).sum() / wts.sum())
    db = lambda m: 99.0 if m == 0 else round(10 * math.log10(1 / m), 2)  # noqa: E731
    return dict(psnr=db(mse), ws_psnr=db(ws))


def run(cmd):
    p = subprocess.run([str(c) for c in cmd], capture_output=True, text=True)
    if p.returncode != 0:
        raise SystemExit(f"failed: {' '.join(map(str, cmd))}\n{p.stderr}")
    return p


def evaluate(name, src, truth, work, pomc, fixtures, w, h):
    os.makedirs(work, exist_ok=True)
    pano, ref = os.path.join(work, "pano"), os.path.join(work, "reference")
    for d in (pano, ref):
        shutil.rmtree(d, ignore_errors=True)
    build = [pomc, "build", "--convention", "blender", "--freedom-radius", "0.9"]
    run([*build, "--colour", os.path.join(src, "colour.exr"), "--depth", os.path.join(src, "depth.exr"), "-o", pano])
    run([*build, "--colour", os.path.join(src, "bg_colour.exr"), "--depth", os.path.join(src, "bg_depth.exr"),
         "-o", ref])
    run([fixtures, "add-layer", ref, os.path.join(src, "colour.exr"), os.path.join(src, "depth.exr"),
         "--where-nearer-than", os.path.join(src, "bg_depth.exr")])
    res = dict(scene=name)
    eyes = {e: read_rgb(os.path.join(truth, f"ods_{e}.exr")) for e in "LR"}
    centre = read_rgb(os.path.join(truth, "centre.exr"))
    for system, d in (("pomc", pano), ("ref", ref)):
        for method in ("splat", "mesh"):
            out = os.path.join(work, f"{system}-{method}-ods.exr")
            t = time.time()
            p = run([pomc, "render", d, "--camera", "ods", "--size", f"{w}x{2 * h}", "--method", method,
                     "-o", out, "--json"] + extra_args)
            secs = time.time() - t
            rep = json.loads(p.stdout)
            img = read_rgb(out)
            r = dict(hole_ratio=rep["hole_ratio"], seconds=round(secs, 2))
            r["left"], r["right"] = scores(img[:h], eyes["L"]), scores(img[h:], eyes["R"])
            mono = os.path.join(work, f"{system}-{method}-centre.exr")
            run([pomc, "render", d, "--camera", "equirect", "--size", f"{w}x{h}", "--method", method, "-o", mono])
            r["centre"] = scores(read_rgb(mono), centre)
            res[f"{system}_{method}"] = r
            print(f"[stereo] {name} {system} {method}: left {r['left']} right {r['right']} centre {r['centre']} "
                  f"holes {100 * r['hole_ratio']:.4f} %", flush=True)
    return res


extra_args = []


def main():
    argv = sys.argv[1:] if "--" not in sys.argv else sys.argv[sys.argv.index("--") + 1:]
    ap = argparse.ArgumentParser(add_help=False)
    ap.add_argument("--ipd", type=float, default=0.064)
    ap.add_argument("--no-pole-merge", action="store_true")
    ap.add_argument("--pomc")
    ap.add_argument("--fixtures")
    ap.add_argument("--out")
    mine, rest = ap.parse_known_args(argv)
    o = scenes.options(rest)
    base = scenes.corpus_dir(o)
    merge = not mine.no_pole_merge
    if not merge:
        extra_args.append("--no-pole-merge")
    extra_args.append(f"--ipd={mine.ipd:g}")
    with open(os.path.abspath(__file__), "rb") as fh:
        key = hashlib.sha256(fh.read() + json.dumps([mine.ipd, merge]).encode()).hexdigest()[:8]
    results = []
    for name in o.scenes.split(","):
        src = os.path.join(base, name)
        if not os.path.exists(os.path.join(src, "done.json")):
            raise SystemExit(f"{src}: render the corpus first (scenes.py with the same options)")
        truth = os.path.join(src, f"stereo-{key}")
        if not os.path.exists(os.path.join(truth, "done.json")):
            shutil.rmtree(truth, ignore_errors=True)
            os.makedirs(truth)
            t = time.time()
            render_truth(name, truth, o, mine.ipd, merge)
            scenes.write_rgb(os.path.join(truth, "centre.exr"),
                             to_pomc(read_rgb(os.path.join(src, "colour.exr")).astype(np.float32)))
            with open(os.path.join(truth, "done.json"), "w") as fh:
                json.dump(dict(ipd=mine.ipd, pole_merge=merge, seconds=round(time.time() - t, 1)), fh)
            print(f"[stereo] {name}: truth in {time.time() - t:.0f} s", flush=True)
        if mine.pomc:
            w, h = o.size
            out = mine.out or os.path.join(os.path.dirname(base), "..", "stereo-eval")
            results.append(evaluate(name, src, truth, os.path.join(out, name), mine.pomc, mine.fixtures, w, h))
    if results:
        out = mine.out or os.path.join(os.path.dirname(base), "..", "stereo-eval")
        with open(os.path.join(out, "results.json"), "w") as fh:
            json.dump(results, fh, indent=1)
        print(json.dumps(results, indent=1))


if __name__ == "__main__":
    main()
