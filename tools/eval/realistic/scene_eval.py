#!/usr/bin/env python3
"""`pomc scene` on the realistic corpus, against `pomc build` and the two-layer reference.

For each corpus scene (scenes.py: room, outdoor, extreme), tools/blender/scene_to_pomc.py bakes the
scene's lighting into textures, exports glTF and runs `pomc scene` from the corpus camera (the origin)
with the corpus freedom radius (0.9 m). Every truth view of cameras.json is rendered from that POMC with
`pomc render --method splat` and `--method mesh` and scored as run.py scores (PSNR of sRGB, clipped;
SSIM; holes). `pomc build` and the reference come from a results.json of run.py (--baseline: a
run.py work directory, e.g. one made with `run.py --tag scene-cmp`, same corpus and views).

  <python with bpy> tools/eval/realistic/scene_eval.py [--scenes room,outdoor,extreme] [--width 1024]
        [--baseline target/realistic-eval/<corpus>/<tag>] [--work target/scene-eval] [--reuse]
        [--s2p "extra scene_to_pomc.py options"]
Environment: POMC_BIN (pomc; default target/release/pomc), BPY_PYTHON (default: this Python).
Writes WORK/results.json and WORK/results.md; prints the tables.
"""
import argparse
import json
import os
import shlex
import statistics
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import run  # noqa: E402  (render, score, validate, read_rgb, psnr: scored exactly as run.py scores)

ROOT = run.ROOT
SYSTEMS = ("scene_splat", "scene_mesh", "build_splat", "build_mesh", "ref_splat", "ref_mesh")
BASELINE_KEYS = {"build_splat": "pomc_splat", "build_mesh": "pomc_mesh", "ref_splat": "ref_splat", "ref_mesh": "ref_mesh"}


def scene_pomc(name, work, o, pomc):
    """Run scene_to_pomc.py for a corpus scene (or reuse its report); returns its report."""
    pano, report = os.path.join(work, "pano"), os.path.join(work, "pano-work", "report.json")
    if o.reuse and os.path.exists(report):
        run.log(f"{name}: reusing {report}")
        return json.load(open(report))
    py = os.environ.get("BPY_PYTHON", sys.executable)
    cmd = [py, os.path.join(ROOT, "tools", "blender", "scene_to_pomc.py"), "--corpus", name, "-o", pano,
           "--width", str(o.width), "--freedom-radius", str(run.RADIUS), "--pomc", pomc, *shlex.split(o.s2p)]
    run.log(f"{name}: {' '.join(cmd[1:])}")
    with open(os.path.join(work, "scene_to_pomc.log"), "w") as fh:
        p = subprocess.run(cmd, stdout=fh, stderr=subprocess.STDOUT)
    if not os.path.exists(report):
        sys.exit(f"scene_to_pomc.py failed ({p.returncode}); see {work}/scene_to_pomc.log")
    return json.load(open(report))


def summary(views, key):
    rs = [v[key] for v in views if key in v and "psnr" in v[key]]
    if not rs:
        return None
    worst = min(range(len(rs)), key=lambda i: rs[i]["psnr"])
    return dict(mean_psnr=round(statistics.mean(r["psnr"] for r in rs), 2), worst_psnr=rs[worst]["psnr"],
                worst_view=[v["view"] for v in views if key in v and "psnr" in v[key]][worst],
                mean_ssim=round(statistics.mean(r["ssim"] for r in rs), 4),
                worst_holes_pct=round(100 * max(r["hole_ratio"] or 0 for r in rs), 3),
                nan=sum(r["nan"] for r in rs), failed=sum(1 for v in views if key in v and "error" in v[key]))


def markdown(results, o):
    out = [f"`pomc scene` (tools/blender/scene_to_pomc.py, width {o.width}, freedom radius {run.RADIUS}) vs "
           f"`pomc build` and the two-layer reference ({o.baseline}). PSNR of sRGB (clipped), dB, over "
           "the corpus truth views.", ""]
    for res in results:
        out += [f"### {res['scene']}", "", "| system | mean PSNR | worst PSNR (view) | mean SSIM | worst holes % |",
                "|---|---|---|---|---|"]
        for k in SYSTEMS:
            s = res["summary"].get(k)
            out.append(f"| {k.replace('_', '-')} | " + ("- | - | - | -" if s is None else
                       f"{s['mean_psnr']:.2f} | {s['worst_psnr']:.2f} ({s['worst_view']:02d}) | {s['mean_ssim']:.3f} | "
                       f"{s['worst_holes_pct']:.3f}") + " |")
        out += ["", "| view | eye r | fov | " + " | ".join(k.replace("_", "-") for k in SYSTEMS) + " |",
                "|---|---|---|" + "---|" * len(SYSTEMS)]
        for v in res["views"]:
            out.append(f"| {v['view']:02d} | {v['radius']:.2f} | {v['fov']:g} | " + " | ".join(
                "-" if k not in v else "fail" if "error" in v[k] else
                f"{v[k]['psnr']:.2f} / {100 * (v[k]['hole_ratio'] or 0):.2f} %" for k in SYSTEMS) + " |")
        p, val = res["pomc_scene"] or {}, res["validate"]
        out += ["", f"- pomc validate: {val['errors']} errors, {val['warnings']} warnings {' '.join(val['codes'])}",
                f"- pomc scene: {p.get('triangles')} triangles, {p.get('pieces')} pieces, sky pixels {p.get('sky_pixels')}, "
                f"hits {p.get('hits')} (kept {p.get('kept_hits')}); sky: {res['sky']}",
                "- layers (name, role, occupancy, depth range m): " + "; ".join(
                    f"{l['name']} {l['role']} {occ:.4f} " + (f"[{l['depth_range'][0]:.2f}, {l['depth_range'][1]:.2f}]"
                                                           if l.get("depth_range") else "[inf]")
                    for l, occ in zip(p.get("layers", []), p.get("occupancy", []))),
                "- pomc scene stages (s): " + ", ".join(f"{a} {b:.2f}" for a, b in p.get("stages", [])) +
                f"; read {p.get('read_s', 0):.2f}, write {p.get('write_s', 0):.2f}, total {p.get('total_s', 0):.2f}",
                "- scene_to_pomc steps (s): " + ", ".join(f"{k} {v:.1f}" for k, v in res["seconds"].items()) +
                f"; {res['texels'] / 1e6:.2f} M texels in {len(res['objects'])} textures, .glb {res['glb_bytes'] / 1e6:.1f} MB",
                f"- render (s, mean per view): " + ", ".join(
                    f"{k.replace('_', '-')} {res['summary'][k]['render_s']:.2f}" for k in ("scene_splat", "scene_mesh")
                    if res["summary"].get(k)), ""]
    return "\n".join(out) + "\n"


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenes", default="room,outdoor,extreme")
    ap.add_argument("--width", type=int, default=1024)
    ap.add_argument("--corpus", default=os.path.join(run.TARGET, "realistic-corpus", "85b5eb16750c"))
    ap.add_argument("--baseline", default=os.path.join(run.TARGET, "realistic-eval", "85b5eb16750c", "scene-cmp"),
                    help="run.py work directory with results.json (pomc build and the reference)")
    ap.add_argument("--work", default=os.path.join(run.TARGET, "scene-eval"))
    ap.add_argument("--reuse", action="store_true", help="reuse a scene's POMC when its report exists")
    ap.add_argument("--s2p", default="", help="extra options of scene_to_pomc.py")
    o = ap.parse_args()
    pomc = os.environ.get("POMC_BIN", os.path.join(run.TARGET, "release", "pomc"))
    base = {}
    bpath = os.path.join(o.baseline, "results.json")
    if os.path.exists(bpath):
        base = {r["scene"]: r for r in json.load(open(bpath))["results"]}
    else:
        run.log(f"no {bpath}: build and reference columns left empty (run run.py --tag to make them)")
    results = []
    for name in o.scenes.split(","):
        work, src = os.path.join(o.work, name), os.path.join(o.corpus, name)
        os.makedirs(work, exist_ok=True)
        rep = scene_pomc(name, work, o, pomc)
        pano = os.path.join(work, "pano")
        res = dict(scene=name, sky=rep["sky"], seconds=rep["seconds"], texels=rep["texels"], objects=rep["objects"],
                   glb_bytes=rep["glb_bytes"], pomc_scene=rep["pomc"], command=rep["command"],
                   validate=run.validate(pomc, pano), views=[])
        cams = json.load(open(os.path.join(src, "cameras.json")))["views"]
        bviews = base.get(name, {}).get("views", [])
        for i, cam in enumerate(cams):
            v = dict(view=i, eye=cam["eye"], fov=cam["fov"], radius=round(sum(x * x for x in cam["eye"]) ** 0.5, 3))
            truth = os.path.join(src, cam["file"])
            for method in ("splat", "mesh"):
                out = os.path.join(work, f"{i:02d}-scene-{method}.exr")
                r = run.render(pomc, pano, out, cam, method)
                if "error" not in r:
                    r.update(run.score(out, truth))
                v[f"scene_{method}"] = r
            if i < len(bviews) and bviews[i]["eye"] == cam["eye"]:
                for k, bk in BASELINE_KEYS.items():
                    v[k] = bviews[i][bk]
            run.log(f"{name}: view {i:02d} r={v['radius']:.2f} " + " ".join(
                f"{k}={v[k].get('psnr', 'ERR')}" for k in SYSTEMS if k in v))
            res["views"].append(v)
        res["summary"] = {k: summary(res["views"], k) for k in SYSTEMS}
        for k in ("scene_splat", "scene_mesh"):
            if res["summary"][k]:
                res["summary"][k]["render_s"] = statistics.mean(v[k]["seconds"] for v in res["views"])
        results.append(res)
    json.dump(dict(corpus=o.corpus, baseline=o.baseline, pomc=pomc, width=o.width, results=results),
              open(os.path.join(o.work, "results.json"), "w"), indent=1)
    md = markdown(results, o)
    open(os.path.join(o.work, "results.md"), "w").write(md)
    print(md)


if __name__ == "__main__":
    main()
