#!/usr/bin/env python3
"""Each tag's views against the build from exact depth (docs/build.md, "Depth preparation"): per scene
the mean PSNR gap of `pomc render` (splat and mesh) to the `exact` tag's, the worst view's (mesh), the
worst hole ratio, the layer counts and `pomc validate`'s errors/warnings; first the mean gap over both
methods and every view. With `--views`, then every view's mesh gap and hole share, a column per tag
(which views a change moves, and by how much).

    python3 tools/eval/realistic/against.py target/realistic-eval/<corpus> [--exact exact] [--views] TAG [TAG ...]
"""
import argparse
import json
import os


def load(base, tag):
    return {r["scene"]: r for r in json.load(open(os.path.join(base, tag, "results.json")))["results"]}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("base")
    ap.add_argument("tags", nargs="+")
    ap.add_argument("--exact", default="exact", help="the tag built from exact depth")
    ap.add_argument("--views", action="store_true", help="also every view's mesh gap and holes, per tag")
    o = ap.parse_args()
    ex = load(o.base, o.exact)
    runs = [load(o.base, tag) for tag in o.tags]
    for tag, r in zip(o.tags, runs):
        cells, gaps = [], []
        for sc, e in ex.items():
            if sc not in r:
                continue
            g = {m: [r[sc]["views"][i][f"pomc_{m}"].get("psnr", 0) - v[f"pomc_{m}"]["psnr"]
                     for i, v in enumerate(e["views"])] for m in ("splat", "mesh")}
            gaps += g["splat"] + g["mesh"]
            holes = max(max(v["pomc_splat"].get("hole_ratio", 1), v["pomc_mesh"].get("hole_ratio", 1))
                        for v in r[sc]["views"])
            val = r[sc]["validate"]
            cells.append(f"{sc}: mesh {sum(g['mesh']) / len(g['mesh']):+.2f} (worst {min(g['mesh']):+.2f}) "
                         f"splat {sum(g['splat']) / len(g['splat']):+.2f} holes {100 * holes:.3f}% "
                         f"layers {r[sc]['build']['layers']}/{e['build']['layers']} "
                         f"validate {val['errors']}E/{val['warnings']}W")
        print(f"{tag:12s} mean {sum(gaps) / len(gaps):+.2f} | " + " | ".join(cells))
    if o.views:
        per_view(o.tags, runs, ex)


def per_view(tags, runs, ex):
    print("view | exact mesh dB | " + " | ".join(f"{t}: gap dB, holes %" for t in tags))
    for sc, e in ex.items():
        for i, v in enumerate(e["views"]):
            ref = v["pomc_mesh"]["psnr"]
            cells = []
            for r in runs:
                m = r[sc]["views"][i]["pomc_mesh"] if sc in r else {}
                cells.append(f"{m.get('psnr', 0) - ref:+6.2f} {100 * m.get('hole_ratio', 1):5.2f}" if m else "–")
            print(f"{sc} {i} | {ref:6.2f} | " + " | ".join(cells))


if __name__ == "__main__":
    main()
