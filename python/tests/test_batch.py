"""pomc-batch on a 2-worker LocalCluster: 20 generated panoramas, one with a missing depth file
and one with a corrupt colour file."""

import json
import math
import subprocess
import sys

import numpy as np
import OpenEXR
import pytest
from PIL import Image

import pomc
from pomc import batch


def scene(k: int, w: int = 128):
    """A room (a box around the centre) with a sphere in it, varied by k: colour and ray depth."""
    h = w // 2
    v, u = np.meshgrid((np.arange(h) + 0.5) / h, (np.arange(w) + 0.5) / w, indexing="ij")
    phi, theta = 2 * np.pi * u, np.pi * v
    d = np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)], -1)
    half = np.array([2.0 + 0.1 * k, 1.5, 1.2])
    box = np.min(half / np.maximum(np.abs(d), 1e-9), axis=-1)
    c = np.array([1.0, 0.3 * math.sin(k), -0.2])
    b = d @ c
    disc = b * b - (c @ c - 0.3 ** 2)
    sphere = np.where(disc > 0, b - np.sqrt(np.maximum(disc, 0)), np.inf)
    depth = np.minimum(box, np.where(sphere > 0, sphere, np.inf)).astype(np.float32)
    rgb = (0.5 + 0.5 * np.sin(8 * d + k)) * 255
    return rgb.astype(np.uint8), depth


def write_item(d, k):
    colour, depth = scene(k)
    cp, dp = d / f"c{k:02}.png", d / f"d{k:02}.exr"
    Image.fromarray(colour).save(cp)
    OpenEXR.File({"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}, {"Z": depth}).write(str(dp))
    return {"colour": cp.name, "depth": dp.name, "name": f"pano{k:02}"}


@pytest.fixture(scope="module")
def items(tmp_path_factory):
    d = tmp_path_factory.mktemp("items")
    rows = [write_item(d, k) for k in range(20)]
    (d / "d03.exr").unlink()  # missing depth
    (d / "c07.png").write_bytes(b"\x89PNG\r\n\x1a\n this is not a PNG")  # corrupt colour
    rows[11]["freedom_radius"] = 0.3  # a per-item option
    path = d / "items.jsonl"
    path.write_text("".join(json.dumps(r) + "\n" for r in rows))
    return path


def test_a_batch_builds_records_failures_and_resumes(items, tmp_path):
    out, report = tmp_path / "out", tmp_path / "report.json"
    argv = [str(items), "-o", str(out), "--workers", "2", "--report", str(report), "--quiet"]
    assert batch.main(argv) == 1
    r = json.loads(report.read_text())
    assert r["counts"] == {"ok": 18, "skipped": 0, "failed": 2}
    failed = {i["name"]: i for i in r["items"] if i["status"] == "failed"}
    assert set(failed) == {"pano03", "pano07"}
    assert failed["pano03"]["code"] == "LAYER_NOT_FOUND" and "d03.exr" in failed["pano03"]["message"]
    assert failed["pano07"]["code"] == "INPUT_UNREADABLE"
    for i in r["items"]:
        if i["status"] == "ok":
            assert i["layers"] >= 2 and i["seconds"] > 0
            assert pomc.open(out / i["name"]).validate().valid
    assert "0.3" in pomc.open(out / "pano11").manifest_xml
    assert not (out / "pano03").exists()
    # A rerun skips what is done and retries the failures.
    assert batch.main(argv) == 1
    r = json.loads(report.read_text())
    assert r["counts"] == {"ok": 0, "skipped": 18, "failed": 2}


def test_the_module_runs_as_a_command(items, tmp_path):
    done = subprocess.run(
        [sys.executable, "-m", "pomc.batch", str(items), "-o", str(tmp_path / "o"), "--workers", "1", "--quiet",
         "--depth-scale", "1"],
        capture_output=True, text=True,
    )
    assert done.returncode == 1, done.stderr
    assert "failed pano03: error[LAYER_NOT_FOUND]" in done.stderr


def test_names_that_leave_the_output_are_refused(tmp_path):
    items = tmp_path / "items.jsonl"
    items.write_text(json.dumps({"colour": "c.png", "depth": "d.exr", "name": "../escape"}) + "\n")
    with pytest.raises(SystemExit) as e:
        batch.main([str(items), "-o", str(tmp_path / "out"), "--quiet"])
    assert e.value.code == 2
