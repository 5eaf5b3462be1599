#!/usr/bin/env python3
"""Driver of the evaluation harness (entry point: tools/eval/run.sh, which builds and installs first).

Analytic scenes (pomc-fixtures) -> `pomc build` -> `pomc mesh` -> `pomc render` from a camera grid
inside the freedom radius -> compared with exact ray-cast views (`pomc-eval score`). Three systems:
the single-layer baseline (the RGB-D panorama as one layer), the layered splat and the layered mesh
(`pomc render --method mesh`, skipped with a note when the binary lacks it). Then parameter sweeps of
build and mesh, and peer comparisons (ffmpeg v360 and py360convert for conversion, Delatin for
meshing), all in the same run. Writes docs/eval-results.json, docs/eval-*.png and the generated part
of docs/evaluation.md.
"""
import argparse
import datetime
import json
import os
import platform
import shutil
import statistics
import subprocess
import sys
import time

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
BIN = os.path.join(os.environ.get("CARGO_TARGET_DIR", os.path.join(ROOT, "target")), "release")
POMC = os.path.join(BIN, "pomc")
FIX = os.path.join(BIN, "pomc-fixtures")
EVAL = os.path.join(BIN, "pomc-eval")
DOCS = os.path.join(ROOT, "docs")

# Run modes: panorama width, scenes, which views of the grid, sweep values, peer sizes.
MODES = {
    "quick": dict(
        width=1024, scenes=["room-equirect", "room-cube"], rings=(0.0, 0.5), diagonals=False, persp=(0,),
        eq_width=512, jump=[0.04, 0.08, 0.16], radius=[0.25, 0.5, 0.75], margin=[0.0, 2.0],
        max_error=[0.002, 0.005, 0.02], sweep_persp=(0,), convert_width=2048, convert_runs=2, mesh_face=512,
        ss=2,
    ),
    "default": dict(
        width=2048, scenes=["room-equirect", "room-cube", "near-far", "sky"], rings=(0.0, 0.25, 0.5),
        diagonals=False, persp=(0, 2), eq_width=1024, jump=[0.04, 0.08, 0.16, 0.32],
        radius=[0.25, 0.5, 0.75, 1.0], margin=[0.0, 2.0, 6.0], max_error=[0.001, 0.002, 0.005, 0.01, 0.02, 0.05],
        sweep_persp=(0,), convert_width=4096, convert_runs=3, mesh_face=1024, ss=2,
    ),
    "full": dict(
        width=2048, scenes=["room-equirect", "room-cube", "near-far", "sky"], rings=(0.0, 0.25, 0.5),
        diagonals=True, persp=(0, 1, 2, 3), eq_width=1024, jump=[0.02, 0.04, 0.08, 0.16, 0.32],
        radius=[0.25, 0.5, 0.75, 1.0], margin=[0.0, 1.0, 2.0, 4.0, 8.0],
        max_error=[0.0005, 0.001, 0.002, 0.005, 0.01, 0.02, 0.05], sweep_persp=(0, 1, 2, 3), convert_width=4096,
        convert_runs=5, mesh_face=1024, ss=3,
    ),
}
# scene key -> (fixtures scene, mapping)
SCENES = {
    "room-equirect": ("room", "equirect"),
    "room-cube": ("room", "cube"),
    "near-far": ("near-far", "equirect"),
    "sky": ("sky", "equirect"),
}
RADIUS = 0.5  # freedom radius of every build and of the camera grid


def log(msg):
    print(f"[eval {time.strftime('%H:%M:%S')}] {msg}", flush=True)


def run(cmd, check=True, **kw):
    """Run a command; return (stdout, seconds)."""
    t = time.perf_counter()
    p = subprocess.run([str(c) for c in cmd], capture_output=True, text=True, **kw)
    dt = time.perf_counter() - t
    if check and p.returncode != 0:
        raise RuntimeError(f"command failed ({p.returncode}): {' '.join(map(str, cmd))}\n{p.stderr[-2000:]}")
    return p, dt


def run_json(cmd):
    p, dt = run(cmd)
    return json.loads(p.stdout), dt


def vec(v):
    return ",".join(f"{x + 0.0:.6g}" for x in v)


def mean(v):
    v = [x for x in v if x is not None]
    return statistics.fmean(v) if v else None


def fmt(x, spec=".2f"):
    return "—" if x is None else format(x, spec)


# ---------------------------------------------------------------------------------------------
# Machine, tools


def machine():
    def sh(cmd):
        try:
            return subprocess.run(cmd, shell=True, capture_output=True, text=True).stdout.strip()
        except OSError:
            return ""

    m = {
        "nproc": int(sh("nproc") or 0),
        "cpu": sh("lscpu | sed -n 's/^Model name: *//p' | head -1") or platform.processor(),
        "arch": platform.machine(),
        "ram_gb": round(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") / 1e9, 1),
        "os": sh("uname -sr"),
        "rustc": sh("rustc --version"),
        "python": platform.python_version(),
        "commit": sh(f"git -C {ROOT} rev-parse HEAD"),
        "branch": sh(f"git -C {ROOT} rev-parse --abbrev-ref HEAD"),
        "dirty": bool(sh(f"git -C {ROOT} status --porcelain --untracked-files=no")),
        "date_utc": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
        "loadavg_start": os.getloadavg()[0],
    }
    m["ffmpeg"] = sh("ffmpeg -version 2>/dev/null | head -1").split(" Copyright")[0] if shutil.which("ffmpeg") else None
    try:
        import py360convert  # noqa: F401
        from importlib.metadata import version

        m["py360convert"] = version("py360convert")
    except Exception:
        m["py360convert"] = None
    try:
        from importlib.metadata import version

        m["pydelatin"] = version("pydelatin")
    except Exception:
        m["pydelatin"] = None
    return m


def mesh_render_supported():
    p, _ = run([POMC, "render", "--help"], check=False)
    text = p.stdout
    i = text.find("--method")
    return i >= 0 and "mesh" in text[i:]


# ---------------------------------------------------------------------------------------------
# Scenes, systems, renders


def make_inputs(work, key, width):
    scene, mapping = SCENES[key]
    d = os.path.join(work, key)
    os.makedirs(d, exist_ok=True)
    w = width if mapping == "equirect" else width * 3 // 4  # cube: 3×2 faces of width/4
    run([FIX, "rgbd", os.path.join(d, "rgbd"), w, mapping, scene])
    return d


def build(d, rgbd, out, extra=()):
    extra = list(extra)
    if "--freedom-radius" not in extra:
        extra += ["--freedom-radius", RADIUS]
    rep, wall = run_json([POMC, "build", "--colour", os.path.join(rgbd, "colour.png"), "--depth",
                          os.path.join(rgbd, "depth.exr"), "-o", out, "--json", *extra])
    return {"wall_s": wall, "total_s": rep.get("total_s"), "layers": [l["name"] for l in rep.get("layers", [])],
            "stages": rep.get("stages"), "max_band_deg": rep.get("max_band_deg")}


def layer_count(pano):
    info, _ = run_json([POMC, "info", pano, "--json"])
    return len(info.get("layers", []))


def encoded_sum(layers):
    """Total encoded bytes, or a dash when a layer's quadtree was not built (greedy faces, no --store)."""
    enc = [l.get("encoded_bytes") for l in layers]
    return f"{sum(enc):,}" if enc and all(e is not None for e in enc) else "—"


def mesh_layers(pano, max_error, store=False, metric=True):
    """`pomc mesh` on every layer; returns per-layer figures (errors of layers that cannot be meshed)."""
    out = []
    for k in range(layer_count(pano)):
        cmd = [POMC, "mesh", pano, "--layer", k, "--max-error", max_error, "--json"]
        if store:
            cmd.append("--store")
        if not metric:
            cmd.append("--no-metric")
        p, wall = run(cmd, check=False)
        if p.returncode != 0:
            out.append({"layer": k, "error": (p.stdout + p.stderr).strip()[-300:], "wall_s": wall})
            continue
        r = json.loads(p.stdout)
        t = r["times_ms"]
        out.append({
            "layer": k, "triangles": r["triangles"], "encoded_bytes": r["encoded_bytes"], "wall_s": wall,
            "mesh_s": (t["sample"] + t.get("greedy", 0) + t["quadtree"] + t["triangulate"] + t["assemble"]
                       + t.get("simplify", 0)) / 1e3,
            "p99_rel": (r.get("error") or {}).get("p99_rel"), "max_rel": (r.get("error") or {}).get("max_rel"),
            "rms_abs": (r.get("error") or {}).get("rms_abs"),
        })
    return out


def render(pano, view, out, method):
    cmd = [POMC, "render", pano, "-o", out + ".exr", "--depth", out + "_d.exr", "--method", method, "--json",
           f"--eye={vec(view['eye'])}"]
    if view["camera"] == "equirect":
        cmd += ["--camera", "equirect", "--size", f"{view['width']}x{view['height']}"]
    else:
        cmd += [f"--look-at={vec(view['look_at'])}", "--fov", view["fov"], "--size",
                f"{view['width']}x{view['height']}"]
    p, wall = run(cmd, check=False)
    if p.returncode != 0:
        return {"error": (p.stdout + p.stderr).strip()[-300:], "wall_s": wall}
    r = json.loads(p.stdout)
    st = r.get("stages", {})
    return {"wall_s": wall, "render_s": st.get("total_s"), "splat_s": st.get("splat_s"), "read_s": st.get("read_s"),
            "cli_hole_ratio": r.get("hole_ratio")}


def score(scene, jobs, work, ss):
    """Render jobs -> metrics (pomc-eval score); jobs that failed to render are kept with their error."""
    ok = [j for j in jobs if "error" not in j]
    path = os.path.join(work, "jobs.json")
    with open(path, "w") as f:
        json.dump(ok, f)
    scored = []
    if ok:
        p, _ = run([EVAL, "score", "--scene", scene, "--jobs", path, "--ss", ss])
        scored = json.loads(p.stdout)
    for j in scored:
        for k in ("colour", "depth"):
            try:
                os.remove(j[k])
            except (OSError, KeyError):
                pass
    return scored + [j for j in jobs if "error" in j]


def views(cfg):
    p, _ = run([EVAL, "views", "--radius", RADIUS, "--eq-width", cfg["eq_width"]]
               + (["--full"] if cfg["diagonals"] else []))
    vs = json.loads(p.stdout)
    keep = []
    for v in vs:
        if not any(abs(v["ring"] - r) < 1e-9 for r in cfg["rings"]):
            continue
        if v["camera"] == "perspective" and int(v["id"][-1]) not in cfg["persp"]:
            continue
        keep.append(v)
    return keep


def render_jobs(systems, vs, work, tag):
    jobs = []
    for sname, (pano, method) in systems.items():
        for v in vs:
            out = os.path.join(work, f"{tag}-{sname}-{v['id']}")
            j = {"system": sname, "view": v, "colour": out + ".exr", "depth": out + "_d.exr"}
            j.update(render(pano, v, out, method))
            jobs.append(j)
    return jobs


# ---------------------------------------------------------------------------------------------
# Stages


def main_eval(cfg, work, has_mesh, results):
    vs = views(cfg)
    log(f"camera grid: {len({v['eye_index'] for v in vs})} eyes, {len(vs)} views per system")
    scenes = {}
    for key in cfg["scenes"]:
        scene = SCENES[key][0]
        t0 = time.perf_counter()
        d = make_inputs(work, key, cfg["width"])
        rgbd = os.path.join(d, "rgbd")
        lay = os.path.join(d, "layered")
        b = build(d, rgbd, lay)
        run([EVAL, "single", rgbd, os.path.join(d, "single"), "--freedom-radius", RADIUS])
        systems = {"baseline": (os.path.join(d, "single"), "splat"), "layered-splat": (lay, "splat")}
        mesh = None
        if has_mesh:
            lm = os.path.join(d, "layered-mesh")
            shutil.copytree(lay, lm)
            mesh = mesh_layers(lm, 0.005, store=True, metric=False)
            systems["layered-mesh"] = (lm, "mesh")
        log(f"{key}: built {b['layers']} in {b['total_s']:.2f} s; rendering {len(systems)} systems")
        jobs = render_jobs(systems, vs, d, "v")
        scored = score(scene, jobs, d, cfg["ss"])
        scenes[key] = {"build": b, "mesh": mesh, "jobs": scored, "seconds": time.perf_counter() - t0}
        log(f"{key}: done in {scenes[key]['seconds']:.0f} s")
    results["scenes"] = scenes


def edge_views(cfg):
    return [v for v in views(dict(cfg, rings=(RADIUS,), persp=cfg["sweep_persp"])) if v["camera"] == "perspective"]


def sweeps(cfg, work, has_mesh, results):
    key = "room-equirect"
    d = os.path.join(work, key)
    rgbd = os.path.join(d, "rgbd")
    if not os.path.isdir(rgbd):
        d = make_inputs(work, key, cfg["width"])
    ev = edge_views(cfg)
    rows = []
    points = [("jump", v, ["--jump", v]) for v in cfg["jump"]]
    points += [("freedom-radius", v, ["--freedom-radius", v]) for v in cfg["radius"]]
    points += [("fill-margin", v, ["--fill-margin", v]) for v in cfg["margin"]]
    for param, value, extra in points:
        out = os.path.join(d, f"sweep-{param}-{value}")
        shutil.rmtree(out, ignore_errors=True)
        b = build(d, rgbd, out, extra)
        jobs = render_jobs({"layered-splat": (out, "splat")}, ev, d, f"s-{param}-{value}")
        scored = score("room", jobs, d, cfg["ss"])
        rows.append({"param": param, "value": value, "build": b, "jobs": scored})
        log(f"build sweep {param}={value}: {b['total_s']:.2f} s, {len(b['layers'])} layers, "
            f"PSNR {fmt(mean([j.get('psnr') for j in scored]))}")
        shutil.rmtree(out, ignore_errors=True)
    results["build_sweep"] = rows

    lay = os.path.join(d, "layered")
    if not os.path.isdir(lay):
        build(d, rgbd, lay)
    mrows = []
    for e in cfg["max_error"]:
        layers = mesh_layers(lay, e)
        row = {"max_error": e, "layers": layers}
        if has_mesh:
            lm = os.path.join(d, f"mesh-sweep-{e}")
            shutil.rmtree(lm, ignore_errors=True)
            shutil.copytree(lay, lm)
            mesh_layers(lm, e, store=True, metric=False)
            jobs = render_jobs({"layered-mesh": (lm, "mesh")}, ev, d, f"m-{e}")
            row["jobs"] = score("room", jobs, d, cfg["ss"])
            shutil.rmtree(lm, ignore_errors=True)
        mrows.append(row)
        log(f"mesh sweep max-error {e}: {sum(l.get('triangles', 0) for l in layers)} triangles")
    results["mesh_sweep"] = mrows


def peers_convert(cfg, work, results):
    """pomc convert vs ffmpeg v360 vs py360convert: equirect colour -> cube, against the exact cube."""
    import numpy as np
    from PIL import Image

    d = os.path.join(work, "convert")
    os.makedirs(d, exist_ok=True)
    w = cfg["convert_width"]
    n = w // 4
    run([FIX, "rgbd", os.path.join(d, "eq"), w, "equirect", "room"])
    run([FIX, "rgbd", os.path.join(d, "cube"), 3 * n, "cube", "room"])
    src = os.path.join(d, "eq", "colour.png")
    truth = {"canonical": os.path.join(d, "cube", "colour.png")}
    for layout in ("ffmpeg-c3x2", "py360-horizon"):
        truth[layout] = os.path.join(d, f"truth-{layout}.png")
        run([POMC, "-q", "convert", truth["canonical"], "-o", truth[layout], "--to", "cube", "--in-layout",
             "canonical", "--layout", layout, "--interp", "nearest"])

    def psnr(a_path, b_path):
        a = np.asarray(Image.open(a_path).convert("RGB"), dtype=np.float64)
        b = np.asarray(Image.open(b_path).convert("RGB"), dtype=np.float64)
        if a.shape != b.shape:
            return None
        mse = ((a - b) ** 2).mean()
        return 10 * np.log10(255.0 ** 2 / mse) if mse > 0 else 100.0

    rows = []
    runs = cfg["convert_runs"]

    def timed(label, layout, interp, fn, out):
        times = []
        for _ in range(runs):
            times.append(fn())
        rows.append({"tool": label, "interp": interp, "layout": layout, "median_s": statistics.median(times),
                     "min_s": min(times), "psnr_db": psnr(out, truth[layout])})
        log(f"convert {label} ({interp}): {rows[-1]['median_s']:.3f} s, PSNR {fmt(rows[-1]['psnr_db'])} dB")

    for interp in ("nearest", "bilinear", "bicubic"):
        out = os.path.join(d, f"pomc-{interp}.png")
        timed("pomc convert", "canonical", interp,
              lambda: run([POMC, "-q", "convert", src, "-o", out, "--to", "cube", "--face-size", n, "--interp",
                           interp])[1], out)
    notes = []
    if shutil.which("ffmpeg"):
        for interp, ff in (("nearest", "near"), ("bilinear", "linear"), ("bicubic", "cubic")):
            out = os.path.join(d, f"ffmpeg-{interp}.png")
            timed("ffmpeg v360", "ffmpeg-c3x2", interp,
                  lambda: run(["ffmpeg", "-v", "error", "-threads", os.cpu_count() or 1, "-i", src, "-vf",
                               f"v360=e:c3x2:interp={ff}:w={3 * n}:h={2 * n}", "-y", out])[1], out)
    else:
        notes.append("ffmpeg not available: v360 skipped")
    try:
        import py360convert

        for interp in ("nearest", "bilinear", "bicubic"):
            out = os.path.join(d, f"py360-{interp}.png")

            def go(interp=interp, out=out):
                t = time.perf_counter()
                img = np.asarray(Image.open(src).convert("RGB"))
                cube = py360convert.e2c(img, face_w=n, mode=interp, cube_format="horizon")
                Image.fromarray(np.clip(np.rint(cube), 0, 255).astype(np.uint8)).save(out)
                return time.perf_counter() - t

            timed("py360convert", "py360-horizon", interp, go, out)
    except ImportError:
        notes.append("py360convert not installed: skipped")
    layout_checks = {}
    for script in ("check_ffmpeg_layout.sh", "check_py360_layout.sh"):
        p, _ = run(["bash", os.path.join(ROOT, "tools", "bench", script), "512"], check=False)
        layout_checks[script] = (p.stdout if p.returncode == 0 else "failed: " + p.stderr[-500:]).strip()
    results["convert"] = {"width": w, "face": n, "runs": runs, "rows": rows, "notes": notes,
                          "layout_checks": layout_checks}


def peers_mesh(cfg, work, results):
    """pomc mesh vs Delatin on the room background cube map (tools/bench/mesh_vs_delatin.py)."""
    n = cfg["mesh_face"]
    d = os.path.join(work, "mesh-peer")
    run([FIX, "room", d, 3 * n, "cube"])
    ours = []
    for e in [0.0005, 0.001, 0.002, 0.005, 0.01, 0.02]:
        r = mesh_layers(d, e)[0]
        r["max_error"] = e
        ours.append(r)
    delatin, notes = [], []
    p, wall = run([sys.executable, os.path.join(ROOT, "tools", "bench", "mesh_vs_delatin.py"), n], check=False)
    if p.returncode == 0:
        closed = {}
        for line in p.stdout.splitlines():
            if line.startswith("CSV delatin+strips,"):
                f = line[4:].split(",")
                closed[float(f[1])] = int(f[2])
        for line in p.stdout.splitlines():
            if line.startswith("CSV delatin,"):
                _, e, tris, p99, mx, secs = line[4:].split(",")[:6]
                delatin.append({"max_error": float(e), "triangles": int(tris), "p99_rel": float(p99),
                                "max_rel": float(mx), "mesh_s": float(secs),
                                "triangles_closed": closed.get(float(e))})
    else:
        notes.append("Delatin skipped: " + p.stderr.strip().splitlines()[-1] if p.stderr.strip() else "failed")
    results["mesh_peer"] = {"face": n, "pomc": ours, "delatin": delatin, "notes": notes}
    for label, rows in (("pomc mesh", ours), ("Delatin", delatin)):
        log(f"mesh peer {label}: " + ", ".join(f"{r['triangles']} tris @ p99 {r['p99_rel']:.1e} in {r['mesh_s']:.2f} s"
                                               for r in rows if "triangles" in r))


# ---------------------------------------------------------------------------------------------
# Report


def agg(jobs, pred):
    sel = [j for j in jobs if pred(j) and "error" not in j]
    persp = [j for j in sel if j["view"]["camera"] == "perspective"]
    eq = [j for j in sel if j["view"]["camera"] == "equirect"]
    p = [j["psnr"] for j in persp]
    ws = [j["ws_psnr"] for j in eq]
    holes = [j["hole_ratio"] for j in sel]
    return {
        "n": len(sel), "psnr_mean": mean(p), "psnr_min": min(p) if p else None,
        "ws_mean": mean(ws), "ws_min": min(ws) if ws else None,
        "holes_mean": mean(holes), "holes_max": max(holes) if holes else None,
        "depth_err": mean([j.get("depth_error") for j in sel]),
        "render_s": mean([j.get("render_s") for j in sel]),
        "nan": sum(j.get("nan_colour", 0) + j.get("nan_depth", 0) for j in sel),
        "failed": len([j for j in jobs if pred(j) and "error" in j]),
    }


def systems_of(jobs):
    order = ["baseline", "layered-splat", "layered-mesh"]
    present = {j["system"] for j in jobs}
    return [s for s in order if s in present] + sorted(present - set(order))


def eye_label(v):
    e = v["eye"]
    if v["ring"] == 0:
        return "centre"
    names = []
    for k, axis in enumerate("xyz"):
        if abs(e[k]) > 1e-9:
            names.append(f"{'+' if e[k] > 0 else '−'}{axis}")
    return f"{v['ring']:g} m " + "".join(names)


def issues(results):
    out = []
    for key, s in results.get("scenes", {}).items():
        for j in s["jobs"]:
            v = j["view"]
            if "error" in j:
                out.append(f"{key} {j['system']} {v['id']} ({eye_label(v)}): render failed: {j['error'][:160]}")
                continue
            if j.get("nan_colour") or j.get("nan_depth"):
                out.append(f"{key} {j['system']} {v['id']} ({eye_label(v)}): NaN colour {j['nan_colour']} "
                           f"depth {j['nan_depth']}")
            if j["system"] != "baseline" and j["hole_ratio"] > 1e-3:
                out.append(f"{key} {j['system']} {v['id']} ({eye_label(v)}, eye {vec(v['eye'])}"
                           f"{', look-at ' + vec(v['look_at']) if 'look_at' in v else ', equirect'}): "
                           f"holes {100 * j['hole_ratio']:.3f} % inside the freedom radius")
    return out


def plots(results, mode):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    made = []
    scenes = results.get("scenes", {})
    if scenes:
        fig, axes = plt.subplots(1, len(scenes), figsize=(3.2 * len(scenes), 3.0), sharey=True, squeeze=False)
        for ax, (key, s) in zip(axes[0], scenes.items()):
            rings = sorted({j["view"]["ring"] for j in s["jobs"]})
            for sys_ in systems_of(s["jobs"]):
                ys = [agg(s["jobs"], lambda j: j["system"] == sys_ and j["view"]["ring"] == r)["psnr_mean"]
                      for r in rings]
                ax.plot(rings, ys, "o-", label=sys_)
            ax.set_title(key, fontsize=9)
            ax.set_xlabel("eye distance from centre (m)", fontsize=8)
            ax.grid(alpha=0.3)
        axes[0][0].set_ylabel("PSNR, perspective (dB)", fontsize=8)
        axes[0][0].legend(fontsize=7)
        fig.tight_layout()
        path = os.path.join(DOCS, "eval-psnr-radius.png")
        fig.savefig(path, dpi=80)
        plt.close(fig)
        made.append(path)
    if results.get("build_sweep"):
        fig, axes = plt.subplots(1, 2, figsize=(8, 3.2))
        for param in ("jump", "freedom-radius", "fill-margin"):
            rows = [r for r in results["build_sweep"] if r["param"] == param]
            xs = [r["build"]["total_s"] for r in rows]
            ps = [agg(r["jobs"], lambda j: True)["psnr_mean"] for r in rows]
            hs = [100 * (agg(r["jobs"], lambda j: True)["holes_mean"] or 0) for r in rows]
            axes[0].plot(xs, ps, "o-", label=param)
            axes[1].plot(xs, hs, "o-", label=param)
            for x, p, h, r in zip(xs, ps, hs, rows):
                axes[0].annotate(f"{r['value']:g}", (x, p), fontsize=6)
                axes[1].annotate(f"{r['value']:g}", (x, h), fontsize=6)
        axes[0].set_ylabel("PSNR at the 0.5 m edge (dB)", fontsize=8)
        axes[1].set_ylabel("holes at the 0.5 m edge (%)", fontsize=8)
        for ax in axes:
            ax.set_xlabel("pomc build time (s)", fontsize=8)
            ax.grid(alpha=0.3)
            ax.legend(fontsize=7)
        fig.suptitle("build sweep (room, layered splat)", fontsize=9)
        fig.tight_layout()
        path = os.path.join(DOCS, "eval-build-sweep.png")
        fig.savefig(path, dpi=80)
        plt.close(fig)
        made.append(path)
    mp = results.get("mesh_peer")
    ms = results.get("mesh_sweep")
    if mp or ms:
        fig, axes = plt.subplots(1, 2, figsize=(8, 3.2))
        if mp:
            for label, rows in (("pomc mesh", [r for r in mp["pomc"] if "triangles" in r]),
                                ("Delatin", mp["delatin"])):
                rows = sorted(rows, key=lambda r: r["p99_rel"] or 0)
                axes[0].loglog([r["p99_rel"] for r in rows], [r["triangles"] for r in rows], "o-", label=label)
                axes[1].loglog([r["p99_rel"] for r in rows], [r["mesh_s"] for r in rows], "o-", label=label)
        if ms:
            tri = [sum(l.get("triangles", 0) for l in r["layers"]) for r in ms]
            p99 = [max((l.get("p99_rel") or 0) for l in r["layers"]) for r in ms]
            secs = [sum(l.get("mesh_s", 0) for l in r["layers"]) for r in ms]
            axes[0].loglog(p99, tri, "s--", label="pomc mesh, built room layers")
            axes[1].loglog(p99, secs, "s--", label="pomc mesh, built room layers")
        axes[0].set_ylabel("triangles", fontsize=8)
        axes[1].set_ylabel("meshing time (s)", fontsize=8)
        for ax in axes:
            ax.set_xlabel("3D p99 relative depth error", fontsize=8)
            ax.grid(alpha=0.3, which="both")
            ax.legend(fontsize=7)
        fig.tight_layout()
        path = os.path.join(DOCS, "eval-mesh.png")
        fig.savefig(path, dpi=80)
        plt.close(fig)
        made.append(path)
    cv = results.get("convert")
    if cv and cv["rows"]:
        fig, ax = plt.subplots(figsize=(5, 3.2))
        for tool in sorted({r["tool"] for r in cv["rows"]}):
            rows = [r for r in cv["rows"] if r["tool"] == tool]
            ax.plot([r["median_s"] for r in rows], [r["psnr_db"] for r in rows], "o-", label=tool)
            for r in rows:
                ax.annotate(r["interp"], (r["median_s"], r["psnr_db"]), fontsize=6)
        ax.set_xscale("log")
        ax.set_xlabel("wall time per conversion (s)", fontsize=8)
        ax.set_ylabel("PSNR vs exact cube (dB)", fontsize=8)
        ax.set_title(f"equirect {cv['width']}x{cv['width'] // 2} -> cube 6x{cv['face']}²", fontsize=9)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
        fig.tight_layout()
        path = os.path.join(DOCS, "eval-convert.png")
        fig.savefig(path, dpi=80)
        plt.close(fig)
        made.append(path)
    return made


def report(results, mode, cfg):
    m = results["machine"]
    L = []
    L.append("<!-- Generated by tools/eval/run.sh: edit tools/eval/eval.py, not this block. -->")
    L.append("")
    L.append("## Tool-chain harness: results")
    L.append("")
    L.append(f"Run: `tools/eval/run.sh{'' if mode == 'default' else ' --' + mode}` ({mode} mode), {m['date_utc']}, "
             f"{results['seconds']:.0f} s wall clock in all.")
    L.append("")
    L.append(f"**Machine:** {m['nproc']} cores ({m['cpu']}, {m['arch']}), {m['ram_gb']} GB RAM, {m['os']}, "
             f"{m['rustc']}, Python {m['python']}, {m['ffmpeg'] or 'no ffmpeg'}, py360convert "
             f"{m['py360convert'] or '—'}, pydelatin {m['pydelatin'] or '—'}; load average "
             f"{m['loadavg_start']:.1f} at the start (shared machine). **Commit:** `{m['commit'][:12]}` "
             f"(branch `{m['branch']}`{', with uncommitted changes' if m['dirty'] else ''}).")
    L.append("")
    notes = results.get("notes", [])
    if notes:
        for n in notes:
            L.append(f"- Note: {n}")
        L.append("")
    L.append(f"Set-up: panoramas {cfg['width']}×{cfg['width'] // 2} (equirect) or 3×2 faces of {cfg['width'] // 4}² "
             f"(cube), built with `pomc build` defaults (freedom radius {RADIUS} m); eyes on the centre and on the "
             f"axis points{' and cube diagonals' if cfg['diagonals'] else ''} at "
             f"{', '.join(f'{r:g}' for r in cfg['rings'] if r > 0)} m (the last is the edge of the freedom radius); "
             f"per eye {len(cfg['persp'])} perspective view(s) 960×540, 60° horizontal fov, 20° down, and one "
             f"{cfg['eq_width']}×{cfg['eq_width'] // 2} equirect view. Truth: exact ray casting, colour averaged "
             f"over {cfg['ss']}×{cfg['ss']} rays per pixel. PSNR on perspective views, WS-PSNR on equirect views "
             f"(linear RGB clamped to [0, 1], holes count as black); depth error: mean |distance − true distance| "
             f"(m) over pixels covered in both; holes: share of pixels no sample reached (all views). Render time: "
             f"`pomc render --json` `total_s` (reading the layers, rendering, writing EXR).")
    L.append("")
    scenes = results.get("scenes", {})
    if scenes:
        L.append("### Views from inside the freedom radius")
        L.append("")
        L.append("| scene | eye radius (m) | system | PSNR mean / min (dB) | WS-PSNR mean / min (dB) | holes mean / max (%) "
                 "| depth error (m) | render (s) | NaN |")
        L.append("|---|---|---|---|---|---|---|---|---|")
        for key, s in scenes.items():
            rings = sorted({j["view"]["ring"] for j in s["jobs"]})
            for r in rings:
                for sys_ in systems_of(s["jobs"]):
                    a = agg(s["jobs"], lambda j: j["system"] == sys_ and j["view"]["ring"] == r)
                    hm = None if a["holes_mean"] is None else 100 * a["holes_mean"]
                    hx = None if a["holes_max"] is None else 100 * a["holes_max"]
                    L.append(f"| {key} | {r:g} | {sys_} | {fmt(a['psnr_mean'])} / {fmt(a['psnr_min'])} | "
                             f"{fmt(a['ws_mean'])} / {fmt(a['ws_min'])} | {fmt(hm, '.3f')} / {fmt(hx, '.3f')} | "
                             f"{fmt(a['depth_err'], '.4f')} | {fmt(a['render_s'])} | {a['nan']}"
                             f"{' (' + str(a['failed']) + ' failed)' if a['failed'] else ''} |")
        L.append("")
        L.append("Gain of the layered splat over the baseline at the edge of the freedom radius "
                 f"({RADIUS} m), mean PSNR over the perspective views:")
        L.append("")
        for key, s in scenes.items():
            b = agg(s["jobs"], lambda j: j["system"] == "baseline" and j["view"]["ring"] == RADIUS)
            l = agg(s["jobs"], lambda j: j["system"] == "layered-splat" and j["view"]["ring"] == RADIUS)
            if b["psnr_mean"] is not None and l["psnr_mean"] is not None:
                L.append(f"- {key}: {l['psnr_mean']:.2f} dB vs {b['psnr_mean']:.2f} dB "
                         f"(**{l['psnr_mean'] - b['psnr_mean']:+.2f} dB**), holes {100 * l['holes_mean']:.3f} % vs "
                         f"{100 * b['holes_mean']:.3f} %; build {s['build']['total_s']:.2f} s "
                         f"({len(s['build']['layers'])} layers: {', '.join(s['build']['layers'])}).")
        L.append("")
        L.append("![PSNR against eye distance](eval-psnr-radius.png)")
        L.append("")
        L.append("<details><summary>Per scene and eye position (mean over the eye's views)</summary>")
        L.append("")
        syss = sorted({s_ for s in scenes.values() for s_ in systems_of(s["jobs"])},
                      key=lambda x: ["baseline", "layered-splat", "layered-mesh"].index(x)
                      if x in ["baseline", "layered-splat", "layered-mesh"] else 9)
        L.append("| scene | eye | " + " | ".join(f"{s_} PSNR / WS-PSNR (dB), holes (%)" for s_ in syss) + " |")
        L.append("|---|---|" + "---|" * len(syss))
        for key, s in scenes.items():
            for e in sorted({j["view"]["eye_index"] for j in s["jobs"]}):
                v0 = next(j["view"] for j in s["jobs"] if j["view"]["eye_index"] == e)
                cells = []
                for s_ in syss:
                    a = agg(s["jobs"], lambda j: j["system"] == s_ and j["view"]["eye_index"] == e)
                    cells.append(f"{fmt(a['psnr_mean'])} / {fmt(a['ws_mean'])}, "
                                 f"{fmt(None if a['holes_mean'] is None else 100 * a['holes_mean'], '.3f')}")
                L.append(f"| {key} | {eye_label(v0)} | " + " | ".join(cells) + " |")
        L.append("")
        L.append("</details>")
        L.append("")
    iss = results.get("issues", [])
    L.append("### Anomalies found by the run")
    L.append("")
    if iss:
        L.append("Views of a layered system with more than 0.1 % holes, NaNs or failed renders:")
        L.append("")
        for i in iss[:40]:
            L.append(f"- {i}")
        if len(iss) > 40:
            L.append(f"- … and {len(iss) - 40} more (docs/eval-results.json)")
    else:
        L.append("None: no NaN, no failed render, no layered view with more than 0.1 % holes.")
    L.append("")
    bs = results.get("build_sweep")
    if bs:
        L.append("### Build parameters: error against run time")
        L.append("")
        L.append(f"Room (equirect {cfg['width']}×{cfg['width'] // 2}), one `pomc build` parameter changed at a time "
                 f"from the defaults (`--jump 0.08 --freedom-radius 0.5 --fill-margin 2`), layered splat rendered "
                 f"from the eyes at the {RADIUS} m edge ({len(cfg['sweep_persp'])} perspective view(s) per eye).")
        L.append("")
        L.append("| parameter | value | build (s) | layers | PSNR mean / min (dB) | holes mean / max (%) | render (s) |")
        L.append("|---|---|---|---|---|---|---|")
        for r in bs:
            a = agg(r["jobs"], lambda j: True)
            L.append(f"| `--{r['param']}` | {r['value']:g} | {r['build']['total_s']:.2f} | {len(r['build']['layers'])} | "
                     f"{fmt(a['psnr_mean'])} / {fmt(a['psnr_min'])} | "
                     f"{fmt(None if a['holes_mean'] is None else 100 * a['holes_mean'], '.3f')} / "
                     f"{fmt(None if a['holes_max'] is None else 100 * a['holes_max'], '.3f')} | {fmt(a['render_s'])} |")
        L.append("")
        L.append("![build sweep](eval-build-sweep.png)")
        L.append("")
    ms = results.get("mesh_sweep")
    if ms:
        L.append("### Mesh tolerance: error against run time")
        L.append("")
        L.append("`pomc mesh --max-error E` on every layer of the built room (layered, equirect). Time: the "
                 "command's own sample + quadtree + triangulate + assemble stages, summed over layers; error: "
                 "3D relative distance along each pixel's ray (largest p99 over the layers)."
                 + (" PSNR: `pomc render --method mesh` from the edge eyes." if any("jobs" in r for r in ms) else ""))
        L.append("")
        L.append("| max-error | triangles | p99 rel | max rel | mesh (s) | encoded (bytes) |"
                 + (" PSNR mean (dB) | holes mean (%) |" if any("jobs" in r for r in ms) else ""))
        L.append("|---|---|---|---|---|---|" + ("---|---|" if any("jobs" in r for r in ms) else ""))
        for r in ms:
            ls = [l for l in r["layers"] if "triangles" in l]
            row = (f"| {r['max_error']:g} | {sum(l['triangles'] for l in ls):,} | "
                   f"{fmt(max((l['p99_rel'] or 0) for l in ls) if ls else None, '.2e')} | "
                   f"{fmt(max((l['max_rel'] or 0) for l in ls) if ls else None, '.2e')} | "
                   f"{sum(l['mesh_s'] for l in ls):.3f} | {encoded_sum(ls)} |")
            if "jobs" in r:
                a = agg(r["jobs"], lambda j: True)
                row += f" {fmt(a['psnr_mean'])} | {fmt(None if a['holes_mean'] is None else 100 * a['holes_mean'], '.3f')} |"
            L.append(row)
        failed = [f"layer {l['layer']}: {l['error']}" for l in ms[0]["layers"] if "error" in l]
        if failed:
            L.append("")
            L.append("Layers `pomc mesh` refused: " + "; ".join(failed))
        L.append("")
    mp = results.get("mesh_peer")
    if mp:
        L.append("### Peer: pomc mesh vs Delatin")
        L.append("")
        L.append(f"Room background (exact, no objects) as a 6×{mp['face']}² cube map (`pomc-fixtures room`); "
                 "pomc: `pomc mesh --layer 0 --max-error E` (CLI defaults otherwise: greedy insertion on clean "
                 "faces, 20° cap; stitched faces, stage times); Delatin: "
                 "`tools/bench/mesh_vs_delatin.py` per face on `|r|/depth` (single thread, faces not stitched; "
                 "in brackets the triangles once closed with pomc's face-joining strips), same 3D relative error.")
        L.append("")
        L.append("| tool | max-error | triangles | p99 rel | max rel | time (s) |")
        L.append("|---|---|---|---|---|---|")
        for r in mp["pomc"]:
            if "triangles" in r:
                L.append(f"| pomc mesh | {r['max_error']:g} | {r['triangles']:,} | {fmt(r['p99_rel'], '.2e')} | "
                         f"{fmt(r['max_rel'], '.2e')} | {r['mesh_s']:.3f} |")
        for r in mp["delatin"]:
            closed = f" ({r['triangles_closed']:,})" if r.get("triangles_closed") else ""
            L.append(f"| Delatin | {r['max_error']:g} | {r['triangles']:,}{closed} | {r['p99_rel']:.2e} | "
                     f"{r['max_rel']:.2e} | {r['mesh_s']:.3f} |")
        for n in mp["notes"]:
            L.append(f"\nNote: {n}")
        L.append("")
        L.append("![mesh error against triangles and time](eval-mesh.png)")
        L.append("")
    cv = results.get("convert")
    if cv:
        L.append("### Peer: conversion (pomc convert vs ffmpeg v360 vs py360convert)")
        L.append("")
        L.append(f"The room's colour panorama ({cv['width']}×{cv['width'] // 2} equirect PNG) to a 6×{cv['face']}² "
                 "cube map, compared with the exact ray-cast cube map of the same scene (8-bit PSNR, peak 255) in "
                 "each tool's own layout (the exact cube re-laid out losslessly with `pomc convert --interp "
                 f"nearest`). Wall time of the whole conversion (decode, resample, encode), median of {cv['runs']} "
                 "runs; py360convert: PIL decode + `e2c` + PIL encode in-process; ffmpeg with `-threads "
                 f"{m['nproc']}`.")
        L.append("")
        L.append("| tool | filter | layout | median (s) | min (s) | PSNR vs exact (dB) |")
        L.append("|---|---|---|---|---|---|")
        for r in cv["rows"]:
            L.append(f"| {r['tool']} | {r['interp']} | {r['layout']} | {r['median_s']:.3f} | {r['min_s']:.3f} | "
                     f"{fmt(r['psnr_db'])} |")
        for n in cv["notes"]:
            L.append(f"\nNote: {n}")
        L.append("")
        L.append("![conversion: accuracy against time](eval-convert.png)")
        L.append("")
        for script, text in cv["layout_checks"].items():
            L.append(f"Layout agreement, `tools/bench/{script} 512`:")
            L.append("")
            L.append("```")
            L.append(text)
            L.append("```")
            L.append("")
    return "\n".join(L)


def write_doc(block):
    path = os.path.join(DOCS, "evaluation.md")
    begin, end = "<!-- eval:begin -->", "<!-- eval:end -->"
    text = open(path).read() if os.path.exists(path) else ""
    if begin in text and end in text:
        text = text[: text.index(begin) + len(begin)] + "\n" + block + "\n" + text[text.index(end):]
    else:
        text = text + f"\n{begin}\n{block}\n{end}\n"
    with open(path, "w") as f:
        f.write(text)


def realistic(mode, results):
    """The path-traced corpus (tools/eval/realistic/run.py, --small in quick mode): its figures are kept
    as they are (results.json, results.md under the target dir), summarised here."""
    cmd = [sys.executable, os.path.join(ROOT, "tools", "eval", "realistic", "run.py")] + (["--small"] if mode == "quick" else [])
    env = {**os.environ, "POMC_BIN": os.environ.get("POMC_BIN", POMC), "POMC_FIXTURES_BIN": os.environ.get("POMC_FIXTURES_BIN", FIX)}
    log("realistic corpus: " + " ".join(cmd[1:]))
    p = subprocess.run(cmd, env=env, capture_output=True, text=True)
    sys.stdout.write(p.stdout[-4000:])
    if p.returncode != 0:
        results["notes"].append(f"realistic corpus failed ({p.returncode}): {p.stderr.strip()[-300:]}")
        return
    verdicts = [line for line in p.stdout.splitlines() if line.startswith(("PASS ", "FAIL "))]
    where = next((line.split("results in ", 1)[1] for line in p.stdout.splitlines() if "results in " in line), "")
    results["realistic"] = {"pass": sum(v.startswith("PASS") for v in verdicts),
                            "fail": [v[5:] for v in verdicts if v.startswith("FAIL")], "results": where}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="small run (2 scenes, 1024 px, fewer views)")
    ap.add_argument("--full", action="store_true", help="large run (cube diagonals, 4 views per eye, more sweeps)")
    ap.add_argument("--work", default=None, help="work directory (default: a temporary one, removed)")
    ap.add_argument("--only", default="main,sweeps,convert,mesh",
                    help="stages to run (comma separated); `realistic` (the path-traced corpus, needs Blender's "
                         "bpy: tools/eval/realistic/run.py) runs only when named")
    ap.add_argument("--no-docs", action="store_true", help="do not write docs/")
    a = ap.parse_args()
    mode = "quick" if a.quick else "full" if a.full else "default"
    cfg = MODES[mode]
    work = a.work or os.path.join(os.environ.get("TMPDIR", "/tmp"), f"pomc-eval-{os.getpid()}")
    os.makedirs(work, exist_ok=True)
    t0 = time.perf_counter()
    results = {"mode": mode, "config": cfg, "machine": machine(), "notes": []}
    stages = a.only.split(",")
    prev_path = os.path.join(DOCS, "eval-results.json")
    if set(stages) != {"main", "sweeps", "convert", "mesh"} and os.path.exists(prev_path):
        # A partial re-run keeps the other stages' results from the last run of the same mode.
        with open(prev_path) as f:
            prev = json.load(f)
        if prev.get("mode") == mode:
            kept = {k: v for k, v in prev.items() if k not in ("machine", "seconds", "issues")}
            kept["notes"] = [n for n in prev.get("notes", []) if not n.startswith("Partial re-run")]
            kept["notes"].append(f"Partial re-run of stage(s) {', '.join(stages)} on {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}; "
                                 "the other figures are from the previous full run")
            results = {**kept, "machine": results["machine"]}
    has_mesh = mesh_render_supported()
    results["mesh_render"] = has_mesh
    if not has_mesh:
        results["notes"].append("`pomc render` has no `--method mesh` in this build: the layered-mesh system is "
                                "skipped (mesh figures below come from `pomc mesh` alone)")
    log(f"mode {mode}, work {work}, mesh render {'yes' if has_mesh else 'no'}")
    try:
        if "main" in stages:
            main_eval(cfg, work, has_mesh, results)
        if "sweeps" in stages:
            sweeps(cfg, work, has_mesh, results)
        if "convert" in stages:
            peers_convert(cfg, work, results)
        if "mesh" in stages:
            peers_mesh(cfg, work, results)
        if "realistic" in stages:
            realistic(mode, results)
    finally:
        if not a.work:
            shutil.rmtree(work, ignore_errors=True)
    results["seconds"] = time.perf_counter() - t0
    results["machine"]["loadavg_end"] = os.getloadavg()[0]
    results["issues"] = issues(results)
    for i in results["issues"]:
        log("ISSUE " + i)
    if not a.no_docs:
        with open(os.path.join(DOCS, "eval-results.json"), "w") as f:
            json.dump(results, f, indent=1)
        made = plots(results, mode)
        write_doc(report(results, mode, cfg))
        log("wrote docs/evaluation.md, docs/eval-results.json, " + ", ".join(os.path.relpath(p, ROOT) for p in made))
    log(f"done in {results['seconds']:.0f} s")


if __name__ == "__main__":
    main()
