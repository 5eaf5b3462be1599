#!/usr/bin/env python3
"""Compare run.py results of several `--tag`s view by view: PSNR / SSIM of `pomc render --method mesh`
against the truth, the gap to the two-layer reference, holes, and the build's fill stages.

    python3 tools/eval/realistic/compare.py target/realistic-eval/<corpus>/{nearest,exemplar}
"""
import json
import os
import sys


def load(d):
    return {r["scene"]: r for r in json.load(open(os.path.join(d, "results.json")))["results"]}


def main():
    dirs = sys.argv[1:]
    runs = [load(d) for d in dirs]
    tags = [os.path.basename(os.path.normpath(d)) for d in dirs]
    print("| scene | view | reference | " + " | ".join(tags) + " |")
    print("|---|---|---|" + "---|" * len(tags))
    gaps = {t: [] for t in tags}
    holes = {t: [] for t in tags}
    for scene in runs[0]:
        for i, v in enumerate(runs[0][scene]["views"]):
            ref = v["ref_mesh"]["psnr"]
            cells = []
            for t, r in zip(tags, runs):
                m = r[scene]["views"][i]["pomc_mesh"]
                gaps[t].append(m["psnr"] - ref)
                holes[t].append(100 * (m.get("hole_ratio") or 0.0))
                cells.append(f"{m['psnr']:.2f} / {m['ssim']:.3f} ({m['psnr'] - ref:+.2f})")
            print(f"| {scene} | {v['view']:02d} | {ref:.2f} / {v['ref_mesh']['ssim']:.3f} | " + " | ".join(cells) + " |")
    print()
    for t in tags:
        g = gaps[t]
        h = holes[t]
        print(f"{t}: mean gap {sum(g) / len(g):+.2f} dB, worst {min(g):+.2f} dB; "
              f"holes mean {sum(h) / len(h):.3f} %, worst {max(h):.3f} %")
    for t, r in zip(tags, runs):
        for scene, x in r.items():
            st = dict(x["build"].get("stages") or [])
            print(f"{t} {scene}: build {x['build']['seconds']:.2f} s, fill {st.get('fill', 0):.3f} s, "
                  f"fill colour {st.get('fill colour', 0):.3f} s")


if __name__ == "__main__":
    main()
