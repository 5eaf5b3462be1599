#!/usr/bin/env python3
"""Show that a refactoring changed no behaviour (issue 54): run two `pomc` binaries side by side on
the same commands and compare what they print and write.

    python3 tools/refactor/same_behaviour.py OLD_POMC NEW_POMC [--work DIR]

- CLI cases: `--help` of every command, `info`, `mesh`, `convert`, `render`, `build` on the bundled
  fixtures; stdout, stderr and exit status must match (JSON compared without timings; human lines
  with times dropped); every file they write must be byte-identical (names aside).
- Builds: the bundled room, a 768 cube room (`pomc-fixtures rgbd`, built when missing) and, when
  present, the realistic corpus (`target/realistic-corpus/<hash>/{room,outdoor,extreme}`) exact and
  degraded (`target/depth-quality/<hash>/default/...`, from tools/eval/depth_quality.py); each
  output directory must hold the same files, byte-identical.

With `--pixels` (needs numpy and OpenEXR, e.g. `target/bpy-venv/bin/python`), EXR files count as the
same when their header attributes other than compression details and every channel's samples are equal:
for a change of the encoder (its deflate), where the bytes differ and the layers do not.

OLD_POMC is typically a release build of the commit before the change in a worktree:
`git worktree add /tmp/wt REV && (cd /tmp/wt && cargo build --release -p pomc-cli)`.
"""
import argparse
import glob
import json
import os
import shutil
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
F = os.path.join(ROOT, "fixtures", "data")


PIXELS = False


def exr_same(p, q):
    """The same channels with equal samples (NaN equal to NaN), and the same data window."""
    import numpy as np
    import OpenEXR
    a, b = OpenEXR.File(p), OpenEXR.File(q)
    ca, cb = a.channels(), b.channels()
    wa, wb = a.header().get("dataWindow"), b.header().get("dataWindow")
    if set(ca) != set(cb) or not np.array_equal(np.asarray(wa), np.asarray(wb)):
        return False
    for k in ca:
        x, y = ca[k].pixels, cb[k].pixels
        if x.dtype != y.dtype or not np.array_equal(x, y, equal_nan=x.dtype.kind == "f"):
            return False
    return True


def same_file(p, q, strip_a=b"", strip_b=b""):
    if not os.path.exists(q):
        return False
    a, b = open(p, "rb").read(), open(q, "rb").read()
    if strip_a:
        a, b = a.replace(strip_a, b""), b.replace(strip_b, b"")
    if a == b:
        return True
    return PIXELS and p.endswith(".exr") and exr_same(p, q)


def same_tree(a, b):
    names = lambda d: sorted(os.path.relpath(os.path.join(r, n), d) for r, _, ns in os.walk(d) for n in ns)
    return names(a) == names(b) and all(same_file(os.path.join(a, n), os.path.join(b, n)) for n in names(a))


def strip(v):
    if isinstance(v, dict):
        return {k: strip(x) for k, x in v.items()
                if not (k.endswith("_ms") or k.endswith("_s") or k in ("times_ms", "timings_ms", "stages", "seconds"))}
    if isinstance(v, list):
        return [strip(x) for x in v]
    return v


def cli_cases():
    cases = [
        ["info", f"{F}/room-equirect", "--json"], ["info", f"{F}/room-equirect", "--stats", "--json"],
        ["info", f"{F}/room-equirect", "--stats"], ["info", f"{F}/room-rgbd/colour.png", "--json"],
        ["info", f"{F}/room-rgbd/colour.png"], ["info", f"{F}/room-rgbd/depth.exr", "--json"],
        ["info", f"{F}/room-rgbd/depth.exr"], ["info", "/nonexistent", "--json"],
        ["mesh", f"{F}/room-equirect", "--json"], ["mesh", f"{F}/room-equirect", "--layer", "1", "--json", "-o", "@l.glb"],
        ["mesh", f"{F}/room-equirect", "-o", "@m.obj", "--json"], ["mesh", f"{F}/room-equirect", "--layer", "0", "-o", "@l.ply"],
        ["mesh", f"{F}/room-equirect"],
        ["convert", f"{F}/room-rgbd/colour.png", "-o", "@c.png", "--to", "cube", "--json"],
        ["convert", f"{F}/room-rgbd/colour.png", "-o", "@c2.png", "--to", "cube"],
        ["convert", f"{F}/room-equirect", "-o", "@pano", "--to", "cube", "--json"],
        ["convert", f"{F}/room-equirect", "-o", "@pano2", "--to", "cube"],
        ["convert", "/nonexistent.png", "-o", "@x.png", "--to", "cube", "--json"],
        ["render", f"{F}/room-equirect", "-o", "@r1.png", "--json"],
        ["render", f"{F}/room-equirect", "-o", "@r2.png", "--camera", "ods", "--json"],
        ["render", f"{F}/room-equirect", "-o", "@r3.png", "--camera", "cube", "--stereo", "--json", "--method", "mesh"],
        ["render", f"{F}/room-equirect", "-o", "@r4.exr", "--camera", "vr180", "--eye", "0.1,0,1.2", "--no-pole-merge", "--json"],
        ["render", f"{F}/room-equirect", "-o", "@r5.png", "--camera", "cube", "--size", "100x100", "--json"],
        ["render", f"{F}/room-equirect", "-o", "@r6.png", "--camera", "equirect", "--size", "256x128", "--orientation", "player", "--json"],
        ["build", "--colour", f"{F}/room-rgbd/colour.png", "--depth", f"{F}/room-rgbd/depth.exr", "-o", "@b", "--json"],
        ["validate", f"{F}/room-equirect"], ["validate", f"{F}/room-cube", "--json"],
        ["validate", "/nonexistent", "--json"], ["validate", "--list-codes"], ["codes", "--json"],
        ["view", f"{F}/room-equirect", "--export", "@site", "--json"], ["view", f"{F}/room-equirect", "--export", "@site2"],
        ["view", "/nonexistent", "--export", "@site3"],
        ["prepare", "--colour", f"{F}/room-rgbd/colour.png", "--depth", f"{F}/room-rgbd/depth.exr", "-o", "@p.exr", "--json"],
        ["prepare", "--colour", f"{F}/room-rgbd/colour.png", "--depth", f"{F}/room-rgbd/depth.exr", "-o", "@p2.exr"],
        ["prepare", "--colour", f"{F}/room-rgbd/colour.png", "--depth", "/nonexistent.exr", "-o", "@p3.exr"],
    ]
    for cmd in ["", "validate", "codes", "info", "convert", "build", "scene", "prepare", "pack", "unpack", "mesh",
                "render", "view"]:
        cases.append(([cmd] if cmd else []) + ["--help"])
    return cases


def run(binary, args, out):
    args = [a.replace("@", out + "/") for a in args]
    r = subprocess.run([binary, *args], capture_output=True, text=True)
    return r.returncode, r.stdout.replace(out, "OUT"), r.stderr.replace(out, "OUT")


def compare_cli(old, new, work):
    bad = 0
    dirs = {k: os.path.join(work, k) for k in ("old", "new")}
    for d in dirs.values():
        shutil.rmtree(d, ignore_errors=True)
        os.makedirs(d)
    cases = cli_cases()
    for c in cases:
        a, b = run(old, c, dirs["old"]), run(new, c, dirs["new"])
        if "--json" in c:
            try:
                same = strip(json.loads(a[1])) == strip(json.loads(b[1]))
            except ValueError:
                same = a[1] == b[1]
            same = same and a[0] == b[0]
        else:
            keep = lambda s: [ln for ln in s.splitlines() if " ms" not in ln and "(ms)" not in ln and " s," not in ln]
            same = a[0] == b[0] and keep(a[1]) == keep(b[1]) and keep(a[2]) == keep(b[2])
        if not same:
            bad += 1
            print("DIFF", " ".join(c), "\n old:", a[0], a[1][:800], a[2][:300], "\n new:", b[0], b[1][:800], b[2][:300])
    files = 0
    for root, _, names in os.walk(dirs["old"]):
        for n in names:
            p = os.path.join(root, n)
            q = os.path.join(dirs["new"], os.path.relpath(p, dirs["old"]))
            files += 1
            if not same_file(p, q, dirs["old"].encode(), dirs["new"].encode()):
                bad += 1
                print("FILE DIFF", os.path.relpath(p, dirs["old"]))
    print(f"CLI cases {len(cases)}, files {files}: {bad} differences")
    return bad


def compare_builds(old, new, work):
    inputs = [("room-rgbd", ["--colour", f"{F}/room-rgbd/colour.png", "--depth", f"{F}/room-rgbd/depth.exr"])]
    cube = os.path.join(work, "cube-room")
    fixtures = shutil.which("pomc-fixtures") or os.path.join(ROOT, "target", "release", "pomc-fixtures")
    if not os.path.isdir(cube) and os.path.exists(fixtures):
        subprocess.run([fixtures, "rgbd", cube, "768", "cube", "room"], check=True, capture_output=True)
    if os.path.isdir(cube):
        inputs.append(("cube-room", ["--colour", f"{cube}/colour.png", "--depth", f"{cube}/depth.exr"]))
    for corpus in sorted(glob.glob(os.path.join(ROOT, "target", "realistic-corpus", "*"))):
        deg = os.path.join(ROOT, "target", "depth-quality", os.path.basename(corpus), "default")
        for scene in ("room", "outdoor", "extreme"):
            src, d = os.path.join(corpus, scene), os.path.join(deg, scene)
            if not os.path.exists(os.path.join(src, "depth.exr")):
                continue
            inputs.append((f"{scene}-exact", ["--colour", f"{src}/colour.exr", "--depth", f"{src}/depth.exr"]))
            for k in ("blur2", "mono"):
                if os.path.exists(f"{d}/input-{k}-depth.exr"):
                    inputs.append((f"{scene}-{k}", ["--colour", f"{d}/input-{k}-colour.exr", "--depth", f"{d}/input-{k}-depth.exr"]))
            for k in ("scanner", "lidar"):
                if os.path.exists(f"{d}/input-{k}-depth.png"):
                    inputs.append((f"{scene}-{k}", ["--colour", f"{src}/colour.exr", "--depth", f"{d}/input-{k}-depth.png",
                                                     "--depth-scale", "0.001", "--unknown-depth", "sky"]))
        break
    bad = 0
    for name, args in inputs:
        outs = []
        for tag, binary in (("old", old), ("new", new)):
            out = os.path.join(work, "builds", f"{tag}-{name}")
            shutil.rmtree(out, ignore_errors=True)
            subprocess.run([binary, "build", *args, "-o", out, "--quiet"], capture_output=True)
            outs.append(out)
        if not same_tree(*outs):
            bad += 1
            print("BUILD DIFF", name)
    print(f"builds {len(inputs)}: {bad} differ")
    return bad


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("old")
    ap.add_argument("new")
    ap.add_argument("--work", default=os.path.join(ROOT, "target", "same-behaviour"))
    ap.add_argument("--pixels", action="store_true", help="EXR files compared by their samples, not bytes")
    a = ap.parse_args()
    global PIXELS
    PIXELS = a.pixels
    os.makedirs(a.work, exist_ok=True)
    bad = compare_cli(a.old, a.new, a.work) + compare_builds(a.old, a.new, a.work)
    sys.exit(1 if bad else 0)


if __name__ == "__main__":
    main()
