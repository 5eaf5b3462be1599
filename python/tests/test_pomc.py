"""The Python package against the command line and independent readers (OpenEXR, Pillow)."""

import json
import os
import subprocess
import threading
from pathlib import Path

import numpy as np
import OpenEXR
import pytest
from PIL import Image

import pomc

ROOT = Path(__file__).resolve().parents[2]
FIXTURE = ROOT / "fixtures" / "data" / "room-rgbd"


def pomc_bin() -> str:
    found = os.environ.get("POMC_BIN")
    if found:
        return found
    for profile in ("release", "debug"):
        p = ROOT / "target" / profile / "pomc"
        if p.exists():
            return str(p)
    pytest.skip("no pomc binary: build it (cargo build -p pomc-cli) or set POMC_BIN")


def cli(*args: str) -> None:
    subprocess.run([pomc_bin(), "--quiet", *args], check=True)


def exr_channels(path: Path) -> dict:
    with OpenEXR.File(str(path), separate_channels=True) as f:
        return {name: np.asarray(ch.pixels) for name, ch in f.channels().items()}


def fixture_arrays():
    colour = np.asarray(Image.open(FIXTURE / "colour.png").convert("RGB"))
    depth = exr_channels(FIXTURE / "depth.exr")
    z = depth.get("Z", next(iter(depth.values())))
    return colour, z.astype(np.float32)


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    """The fixture built twice: by `pomc build` from the files, by `pomc.build` from arrays."""
    d = tmp_path_factory.mktemp("built")
    cli("build", "--colour", str(FIXTURE / "colour.png"), "--depth", str(FIXTURE / "depth.exr"), "-o", str(d / "cli"))
    colour, depth = fixture_arrays()
    pano = pomc.build(colour, depth)
    pano.save(d / "py")
    return d


def test_building_from_arrays_equals_the_command(built):
    a, b = pomc.open(built / "cli"), pomc.open(built / "py")
    assert len(a) == len(b) >= 2
    for la, lb in zip(a.layers, b.layers):
        assert (la.name, la.role, la.order) == (lb.name, lb.role, lb.order)
        assert la.colour.dtype == np.float32 and la.colour.shape == la.depth.shape + (3,)
        assert la.mask.dtype == np.bool_
        for x, y in ((la.colour, lb.colour), (la.depth, lb.depth), (la.mask, lb.mask)):
            assert np.array_equal(x, y, equal_nan=True)
    assert a.manifest_xml == b.manifest_xml


def test_rgba_colour_builds_as_its_rgb(built):
    colour, depth = fixture_arrays()
    rgba = np.concatenate([colour, np.full(colour.shape[:2] + (1,), 255, np.uint8)], axis=2)
    a, b = pomc.build(rgba, depth), pomc.open(built / "py")
    assert [la.name for la in a.layers] == [lb.name for lb in b.layers]
    for la, lb in zip(a.layers, b.layers):
        assert np.array_equal(la.colour, lb.colour, equal_nan=True)


def test_layers_are_the_files_read_by_openexr(built):
    pano = pomc.open(built / "py")
    background = pano.layers[0]
    z = exr_channels(built / "py" / f"{background.name}.exr")["Z"]
    inside = background.mask
    assert np.array_equal(z[inside], background.depth[inside])


def test_render_equals_the_command(built, tmp_path):
    pano = pomc.open(built / "py")
    eye, look = (0.15, -0.1, 0.05), (0.15, 1.0, 0.0)
    for method in ("splat", "mesh"):
        out = tmp_path / f"{method}.exr"
        cli(
            "render", str(built / "py"), "-o", str(out), "--method", method,
            "--eye", ",".join(map(str, eye)), "--look-at", ",".join(map(str, look)), "--size", "160x90",
        )
        truth = exr_channels(out)
        colour, depth, mask = pano.render(eye, look, size=(160, 90), method=method)
        assert colour.shape == (90, 160, 3) and depth.shape == (90, 160) and mask.shape == (90, 160)
        for c, name in enumerate("RGB"):
            assert np.array_equal(colour[..., c], truth[name]), f"{method} {name}"
        assert mask.mean() > 0.99


def test_stereo_cameras_equal_the_command(built, tmp_path):
    pano = pomc.open(built / "py")
    assert pomc.RENDER_OPTIONS["camera"] == "perspective" and pomc.RENDER_OPTIONS["ipd"] == 0.064
    cases = [
        (dict(camera="ods", size=(256, 256)), ["--camera", "ods", "--size", "256x256"]),
        (dict(camera="ods", size=(512, 128), stereo_layout="sbs", ipd=0.07, pole_merge=(50, 80),
              orientation="player"),
         ["--camera", "ods", "--size", "512x128", "--stereo-layout", "sbs", "--ipd", "0.07",
          "--pole-merge", "50,80", "--orientation", "player"]),
        (dict(camera="ods", size=(256, 256), no_pole_merge=True), ["--camera", "ods", "--size", "256x256",
                                                                   "--no-pole-merge"]),
        (dict(camera="vr180", size=(256, 128)), ["--camera", "vr180", "--size", "256x128"]),
        (dict(camera="cube", stereo=True, size=(96, 128)), ["--camera", "cube", "--stereo", "--size", "96x128"]),
    ]
    for method in ("splat", "mesh"):
        for kw, flags in cases:
            out = tmp_path / "cli.exr"
            cli("render", str(built / "py"), "-o", str(out), "--method", method, *flags)
            truth = exr_channels(out)
            colour, _, mask = pano.render(method=method, **kw)
            w, h = kw["size"]
            assert colour.shape == (h, w, 3), (kw, colour.shape)
            for c, name in enumerate("RGB"):
                assert np.array_equal(colour[..., c], truth[name]), f"{method} {kw} {name}"
            assert mask.mean() > 0.99
    with pytest.raises(pomc.PomcError, match="stereo.layout"):
        pano.render(camera="ods", stereo_layout="diagonal")


def test_save_colour_writes_what_the_command_writes(built, tmp_path):
    pano = pomc.open(built / "py")
    eye, look = (0.15, -0.1, 0.05), (0.15, 1.0, 0.0)
    cli(
        "render", str(built / "py"), "-o", str(tmp_path / "cli.png"),
        "--eye", ",".join(map(str, eye)), "--look-at", ",".join(map(str, look)), "--size", "160x90",
    )
    colour, _, _ = pano.render(eye, look, size=(160, 90))
    pomc.save_colour(tmp_path / "py.png", colour)
    pomc.save_colour(tmp_path / "py.exr", colour)
    assert np.array_equal(np.asarray(Image.open(tmp_path / "py.png")), np.asarray(Image.open(tmp_path / "cli.png")))
    exr = exr_channels(tmp_path / "py.exr")
    assert np.array_equal(exr["G"], colour[..., 1])
    with pytest.raises(pomc.PomcError):
        pomc.save_colour(tmp_path / "bad.png", colour[..., :2])


def test_validate_mesh_and_export(built, tmp_path):
    pano = pomc.open(built / "py")
    report = pano.validate()
    assert report.valid and report.errors == 0, report.issues
    meshes = pano.mesh()
    assert [m["layer"] for m in meshes] and all(m["triangles"].shape[1] == 3 for m in meshes)
    for m in meshes:
        n = m["vertices"].shape[0]
        assert m["uv"].shape == (n, 2) and m["triangles"].max() < n
        assert np.all((m["uv"] >= 0) & (m["uv"] <= 1))
    files = pano.export_mesh(tmp_path / "scene.glb")
    assert files[0].endswith("scene.glb") and os.path.getsize(files[0]) > 1000
    # In memory, not yet saved: validated through a temporary copy.
    colour, depth = fixture_arrays()
    assert pomc.build(colour, depth, freedom_radius=0.3).validate().valid


def test_failures_carry_stable_codes(tmp_path):
    with pytest.raises(pomc.PomcError) as e:
        pomc.open(tmp_path / "nothing-here")
    assert e.value.code == "PANORAMA_NOT_FOUND"
    colour, depth = fixture_arrays()
    with pytest.raises(pomc.PomcError) as e:
        pomc.build(colour, depth, freedom_radius=-1)
    assert e.value.code == "CLI_USAGE"
    with pytest.raises(pomc.PomcError) as e:
        pomc.build(colour, depth, no_such_option=1)
    assert e.value.code == "CLI_USAGE"
    with pytest.raises(pomc.PomcError) as e:
        pomc.build(colour, (depth * 1000).astype(np.uint16))
    assert e.value.code == "INPUT_DEPTH_SCALE_NEEDED"
    with pytest.raises(pomc.PomcError) as e:
        pomc.build(colour[:, :-2], depth)
    assert e.value.code == "INPUT_SIZE_MISMATCH"
    assert issubclass(pomc.PomcError, Exception)


def test_integer_depth_with_a_scale_is_metres():
    colour, depth = fixture_arrays()
    mm = np.where(np.isfinite(depth), np.round(depth * 1000), 0).astype(np.uint16)
    pano = pomc.build(colour, mm, depth_scale=0.001)
    assert pano.validate().valid


def test_rendering_releases_the_gil(built):
    pano = pomc.open(built / "py")
    pano.render((0.1, 0, 0), (0.1, 1, 0), size=(64, 36))  # warm the renderer cache
    done = threading.Event()
    ticks = 0

    def work():
        for _ in range(5):
            pano.render((0.1, 0, 0), (0.1, 1, 0), size=(640, 360))
        done.set()

    t = threading.Thread(target=work)
    t.start()
    while not done.is_set():
        ticks += 1
    t.join()
    # With the GIL held by the renders this thread could not have run meanwhile.
    assert ticks > 1000


def test_every_mesh_option_equals_the_command(built, tmp_path):
    pano = pomc.open(built / "py")
    cases = [
        ({}, []),
        ({"feature_angle": 30, "residual": 0.1, "normal_weighting": "angle"},
         ["--feature-angle", "30", "--residual", "0.1", "--normal-weighting", "angle"]),
        ({"uniform": 4}, ["--uniform", "4"]),
        ({"greedy": False, "max_error": 0.01, "max_angle": 0}, ["--no-greedy", "--max-error", "0.01", "--max-angle", "0"]),
        ({"simplify": False, "sky_radius": 50}, ["--no-simplify", "--sky-radius", "50"]),
    ]
    sizes = set()
    for k, (options, flags) in enumerate(cases):
        mine, theirs = tmp_path / f"py{k}.ply", tmp_path / f"cli{k}.ply"
        pano.export_mesh(mine, **options)
        cli("mesh", str(built / "py"), "-o", str(theirs), "--no-metric", *flags)
        assert mine.read_bytes() == theirs.read_bytes(), (options, flags)
        sizes.add(mine.stat().st_size)
    assert len(sizes) >= 4, "the options change the mesh"
    assert set(pomc.MESH_OPTIONS) >= {"feature_angle", "residual", "normal_weighting", "uniform", "greedy"}
    for bad in ({"uniform": 0}, {"normal_weighting": "volume"}, {"feature_angle": 200}, {"residual": -1}):
        with pytest.raises(pomc.PomcError) as e:
            pano.mesh(**bad)
        assert e.value.code == "CLI_USAGE", bad


def test_normals_in_and_max_pixels_are_the_command_options(tmp_path):
    colour, depth = fixture_arrays()
    normals = FIXTURE / "normals.exr"
    cli("build", "--colour", str(FIXTURE / "colour.png"), "--depth", str(FIXTURE / "depth.exr"),
        "--normals-in", str(normals), "--normals", "-o", str(tmp_path / "cli"))
    pano = pomc.build(colour, depth, normals_in=normals, normals=True)
    pano.save(tmp_path / "py")
    a, b = pomc.open(tmp_path / "cli"), pomc.open(tmp_path / "py")
    assert a.manifest_xml == b.manifest_xml
    for la, lb in zip(a.layers, b.layers):
        for x, y in ((la.colour, lb.colour), (la.depth, lb.depth), (la.mask, lb.mask)):
            assert np.array_equal(x, y, equal_nan=True)
    # The normals given are the ones stored (not re-estimated from depth).
    ch = exr_channels(tmp_path / "py" / f"{b.layers[0].name}.exr")
    assert "N.X" in ch
    plain = pomc.build(colour, depth, normals=True)
    plain.save(tmp_path / "plain")
    assert not np.array_equal(ch["N.X"], exr_channels(tmp_path / "plain" / f"{b.layers[0].name}.exr")["N.X"])
    h, w = depth.shape
    for call in (lambda: pomc.build(colour, depth, max_pixels=w * h - 1),
                 lambda: pomc.build_files(FIXTURE / "colour.png", FIXTURE / "depth.exr", tmp_path / "x", max_pixels=1000)):
        with pytest.raises(pomc.PomcError) as e:
            call()
        assert e.value.code == "INPUT_TOO_LARGE"
    assert pomc.build(colour, depth, max_pixels=w * h).validate().valid


def test_prepare_depth_equals_the_command(tmp_path):
    """Depth at a quarter of the colour's size, prepared by Python and by `pomc prepare`: the same
    array, on the colour's grid, and what `pomc build` layers from it."""
    depth = exr_channels(FIXTURE / "depth.exr")["Z"]
    h, w = depth.shape
    small = 1.0 / (1.0 / depth).reshape(h // 4, 4, w // 4, 4).mean(axis=(1, 3))
    path = tmp_path / "small.exr"
    OpenEXR.File({"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage},
                 {"Z": np.ascontiguousarray(small, np.float32)}).write(str(path))
    array, report = pomc.prepare_depth(FIXTURE / "colour.png", path)
    assert array.shape == (h, w) and array.dtype == np.float32
    assert report["resized"] and report["source_size"] == [w // 4, h // 4]
    cli("prepare", "--colour", str(FIXTURE / "colour.png"), "--depth", str(path), "-o", str(tmp_path / "p.exr"))
    np.testing.assert_array_equal(array, exr_channels(tmp_path / "p.exr")["Z"])
    within = np.mean(np.abs(array / depth - 1) < 0.08)
    assert within > 0.95, within
    summary = pomc.build_files(FIXTURE / "colour.png", path, tmp_path / "pano")
    assert summary["prepare"]["resized"] and len(summary["layers"]) >= 2
    # The same report as the command's, layer by layer.
    run = subprocess.run([pomc_bin(), "build", "--colour", str(FIXTURE / "colour.png"), "--depth", str(path),
                          "-o", str(tmp_path / "cli"), "--json"], check=True, capture_output=True, text=True)
    assert summary["layers"] == json.loads(run.stdout)["layers"] and summary["output"] == str(tmp_path / "pano")


def test_relative_depth_needs_its_scale(tmp_path):
    """An 8-bit nearness map: refused as metric depth with the fix, built with its range."""
    depth = exr_channels(FIXTURE / "depth.exr")["Z"]
    near = np.clip((8.0 - depth) / 7.5, 0, 1)
    path = tmp_path / "nearness.png"
    Image.fromarray(np.round(255 * near).astype(np.uint8), "L").save(path)
    with pytest.raises(pomc.PomcError) as e:
        pomc.prepare_depth(FIXTURE / "colour.png", path)
    assert e.value.code == "INPUT_DEPTH_8BIT" and "nearness" in str(e.value)
    array, report = pomc.prepare_depth(FIXTURE / "colour.png", path, depth_kind="nearness", depth_range=(0.5, 8.0))
    assert report["metric"]["from"] == "range"
    ok = np.abs(array - np.minimum(depth, 8.0)) < 0.03
    assert ok.mean() > 0.97, ok.mean()
    with pytest.raises(pomc.PomcError):
        pomc.prepare_depth(FIXTURE / "colour.png", path, depth_kind="nearness", depth_range=(3, 1))


def test_one_known_distance_gives_the_scale(tmp_path):
    """Depth known only up to scale (an estimator's float depth) made metric by one distance."""
    depth = exr_channels(FIXTURE / "depth.exr")["Z"]
    h, w = depth.shape
    y, x = h // 2, w // 2
    path = tmp_path / "scaled.exr"
    OpenEXR.File({"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage},
                 {"Z": (depth * 0.37).astype(np.float32)}).write(str(path))
    array, report = pomc.prepare_depth(FIXTURE / "colour.png", path, known_distance=(x, y, float(depth[y, x])))
    assert report["metric"]["from"] == "known-distance"
    fin = np.isfinite(depth)
    assert np.mean(np.abs(array[fin] / depth[fin] - 1) < 0.005) > 0.99
    with pytest.raises(pomc.PomcError) as e:
        pomc.prepare_depth(FIXTURE / "colour.png", path, known_distance=(x, y, 2.0), depth_scale=0.001)
    assert e.value.code == "INPUT_BAD_OPTION" and "--known-distance" in str(e.value)
    with pytest.raises(pomc.PomcError):
        pomc.prepare_depth(FIXTURE / "colour.png", path, known_distance=(x, y, -1))


def test_keywords_take_numpy_values_and_none_as_plain_ones():
    """NumPy scalars, arrays and None are what a script passes: the same build as plain values."""
    colour, depth = fixture_arrays()
    plain = pomc.build(colour, depth, normals=True, depth_bands=[2.0], fill_margin=3.0, jump=0.08)
    numpy = pomc.build(colour, depth, normals=np.True_, depth_bands=np.array([2.0]), fill_margin=np.float32(3.0),
                       jump=np.float64(0.08), depth_scale=None, preset=None, no_pack=0, depth_range=())
    assert plain.manifest_xml == numpy.manifest_xml
    with pytest.raises(pomc.PomcError) as e:
        pomc.build(colour, (depth * 1000).astype(np.uint16), depth_scale=None)
    assert e.value.code == "INPUT_DEPTH_SCALE_NEEDED"
    with pytest.raises(pomc.PomcError) as e:
        pomc.build(colour, depth, no_such_option=None)
    assert e.value.code == "CLI_USAGE" and "no_such_option" in str(e.value)


def test_scene_equals_the_command(tmp_path):
    """A 3D scene (the analytic room as OBJ, written by pomc-fixtures' generator through the CLI's
    twin): `pomc.scene` writes the same layers as `pomc scene`, and they validate."""
    obj = tmp_path / "room.obj"
    (tmp_path / "room.mtl").write_text("newmtl m0\nKd 0.6 0.6 0.55\n")
    # A closed box room 6 x 4 x 3 m (OBJ, +Y up) around the centre and one box inside it.
    verts, faces = [], []

    def box(lo, hi, inward):
        base = len(verts) + 1
        for i in range(8):
            verts.append(tuple(hi[k] if (i >> k) & 1 else lo[k] for k in range(3)))
        quads = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
        for a, b, c, d in quads:
            for t in ((a, b, c), (a, c, d)):
                t = (t[0], t[2], t[1]) if inward else t
                faces.append(tuple(base + i for i in t))

    box((-3, -1.2, -2), (3, 1.8, 2), True)
    box((1.0, -1.2, -0.4), (1.6, -0.4, 0.4), False)
    obj.write_text("mtllib room.mtl\nusemtl m0\n" + "".join(f"v {x} {y} {z}\n" for x, y, z in verts)
                   + "".join(f"f {a} {b} {c}\n" for a, b, c in faces))
    # Two "renders" from the centre (first and second hit along each ray), given as a list.
    renders = [tmp_path / "hit-0.exr", tmp_path / "hit-1.exr"]
    ramp = np.linspace(0.1, 0.9, 128, dtype=np.float32)
    pomc.save_colour(renders[0], np.stack([np.tile(ramp, (64, 1))] * 3, -1))
    pomc.save_colour(renders[1], np.full((64, 128, 3), 0.25, np.float32))
    report = pomc.scene(obj, tmp_path / "py", freedom_radius=0.4, width=128, samples=1, colour=renders)
    assert [l["role"] for l in report["layers"]] == ["background", "object"], report["layers"]
    assert 0.9 < report["occupancy"][0] < 1.0, "the floor under the box is left out"
    cli("scene", str(obj), "-o", str(tmp_path / "cli"), "--freedom-radius", "0.4", "--width", "128", "--samples", "1",
        "--colour", str(renders[0]), "--colour", str(renders[1]))
    for name in ("background.exr", "objects-1.exr"):
        a, b = exr_channels(tmp_path / "py" / name), exr_channels(tmp_path / "cli" / name)
        assert a.keys() == b.keys()
        for k in a:
            np.testing.assert_array_equal(a[k], b[k])
    assert pomc.open(tmp_path / "py").validate().valid
    box = exr_channels(tmp_path / "py" / "objects-1.exr")
    seen = box["R"][box["Z"] > 0]
    assert seen.size and seen.std() > 0.01, "the box the centre sees takes the ramp render, not its flat material"
    assert pomc.SCENE_OPTIONS["samples"] == 4.0 and pomc.SCENE_OPTIONS["mapping"] == "equirect"
    assert pomc.SCENE_OPTIONS["convention"] == "thesis" and "freedom_radius" not in pomc.SCENE_OPTIONS
    with pytest.raises(pomc.PomcError) as e:
        pomc.scene(tmp_path / "nothing.obj", tmp_path / "x")
    assert e.value.code == "SCENE_UNREADABLE"


def test_pack_and_unpack_equal_the_commands(built, tmp_path):
    """`pomc.pack` / `pomc.unpack` write the files `pomc pack` / `pomc unpack` write, byte for byte,
    and return the command's `--json` report (timings aside); unpacking restores full canvases."""
    src = built / "cli"
    py = pomc.pack(src, tmp_path / "py", padding=2)
    cli("pack", str(src), "-o", str(tmp_path / "cli"), "--padding", "2")
    names = sorted(p.name for p in (tmp_path / "cli").iterdir())
    assert names == sorted(p.name for p in (tmp_path / "py").iterdir())
    for name in names:
        assert (tmp_path / "py" / name).read_bytes() == (tmp_path / "cli" / name).read_bytes(), name
    out = subprocess.run([pomc_bin(), "--json", "pack", str(src), "-o", str(tmp_path / "json"), "--padding", "2"],
                         check=True, capture_output=True, text=True).stdout
    report = json.loads(out)
    assert py["layers"] == report["layers"] and set(py) == set(report) == {"layers", "output", "timings_s"}
    assert any(l["packed"] for l in py["layers"]), "the room's object layer is sparse"
    full = pomc.unpack(tmp_path / "py", tmp_path / "full")
    assert not any(l["packed"] for l in full["layers"])
    assert all(l["atlas"] == l["canvas"] for l in full["layers"])
    with pytest.raises(pomc.PomcError):
        pomc.pack(src, tmp_path / "bad", threshold=1.5)


def test_render_files_equal_the_command(built, tmp_path):
    """`pomc.render_files` writes the images `pomc render` writes, byte for byte, for one view and a
    camera path, and returns the command's `--json` report (timings aside); a bad path is
    RENDER_CAMERA_PATH."""
    src = built / "cli"
    cams = tmp_path / "cams.txt"
    cams.write_text("0,0,1.2 2,0,0.4\n0.1,0.2,1.2\n")

    def untimed(v):
        if isinstance(v, dict):
            return {k: untimed(x) for k, x in v.items() if not k.endswith("_s") and k != "output"}
        return [untimed(x) for x in v] if isinstance(v, list) else v

    for name, kw, flags in [
        ("view", dict(eye=(0.1, 0.0, 1.2), size=(96, 54), mask=tmp_path / "py-view-mask.png"),
         ["--eye", "0.1,0,1.2", "--size", "96x54", "--mask", str(tmp_path / "cli-view-mask.png")]),
        ("path-##", dict(path=cams, method="mesh", camera="equirect", size=(64, 32)),
         ["--path", str(cams), "--method", "mesh", "--camera", "equirect", "--size", "64x32"]),
    ]:
        py = pomc.render_files(src, tmp_path / f"py-{name}.png", **kw)
        out = subprocess.run([pomc_bin(), "--json", "render", str(src), "-o", str(tmp_path / f"cli-{name}.png"),
                              *flags], check=True, capture_output=True, text=True).stdout
        assert untimed(py) == untimed(json.loads(out)), name
    for suffix in ("view.png", "view-mask.png", "path-00.png", "path-01.png"):
        assert (tmp_path / f"py-{suffix}").read_bytes() == (tmp_path / f"cli-{suffix}").read_bytes(), suffix
    for bad in (dict(path=cams), dict(path=cams, eye=(0, 0, 1))):
        with pytest.raises(pomc.PomcError) as e:
            pomc.render_files(src, tmp_path / ("no-number.png" if "eye" not in bad else "f-#.png"), **bad)
        assert e.value.code == "RENDER_CAMERA_PATH", bad
