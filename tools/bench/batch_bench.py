"""Batch throughput: a plain sequential loop of `pomc build` against `pomc-batch` with 1 and 2
workers on N generated panoramas (W×W/2 equirect, room + sphere). Usage:
    python3 tools/bench/batch_bench.py POMC_BIN [N] [W]
Prints panoramas per minute for each and the scheduling overhead per item."""

import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import OpenEXR
from PIL import Image

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "python" / "tests"))
from test_batch import scene  # noqa: E402


def main():
    pomc_bin = sys.argv[1]
    n = int(sys.argv[2]) if len(sys.argv) > 2 else 20
    w = int(sys.argv[3]) if len(sys.argv) > 3 else 1024
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        rows = []
        for k in range(n):
            colour, depth = scene(k, w)
            Image.fromarray(colour).save(d / f"c{k}.png")
            OpenEXR.File({"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}, {"Z": depth}).write(str(d / f"d{k}.exr"))
            rows.append({"colour": f"c{k}.png", "depth": f"d{k}.exr", "name": f"p{k}"})
        (d / "items.jsonl").write_text("".join(json.dumps(r) + "\n" for r in rows))
        t = time.perf_counter()
        for k in range(n):
            subprocess.run([pomc_bin, "--quiet", "build", "--colour", str(d / f"c{k}.png"), "--depth", str(d / f"d{k}.exr"), "-o", str(d / "seq" / f"p{k}")], check=True)
        seq = time.perf_counter() - t
        print(f"sequential pomc build: {n} in {seq:.1f} s = {60 * n / seq:.1f}/min ({seq / n:.2f} s each)")
        for workers in (1, 2):
            report = d / f"r{workers}.json"
            subprocess.run([sys.executable, "-m", "pomc.batch", str(d / "items.jsonl"), "-o", str(d / f"b{workers}"), "--workers", str(workers), "--report", str(report), "--quiet"], check=True)
            r = json.loads(report.read_text())
            per_item = (r["wall_s"] - r["cluster_start_s"]) * workers / n - r["build_s"] / n
            print(
                f"pomc-batch --workers {workers}: {n} in {r['wall_s']:.1f} s (cluster start {r['cluster_start_s']:.1f} s) = "
                f"{r['panoramas_per_minute']:.1f}/min; build {r['build_s'] / n:.2f} s per item, overhead {per_item:.2f} s per item"
            )


if __name__ == "__main__":
    main()
