"""`pomc build` speed and peak memory, two binaries side by side (issue 33's inputs).

  python3 tools/bench/build_speed.py [--runs 5] [--input NAME=COLOUR,DEPTH ...] BIN [BIN ...]

Without --input: the analytic room and sky scenes at 4096×2048 (written once by `pomc-fixtures rgbd`
under target/bench-build/, $POMC_FIXTURES_BIN or target/release/pomc-fixtures). Each run is the whole
process (`/usr/bin/time`: wall and peak RSS), the binaries interleaved run by run; prints min / median
wall, peak RSS and the median of each `--json` stage, and the machine's load before and after.
"""

import argparse
import json
import os
import statistics
import subprocess
import tempfile

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
TARGET = os.environ.get("CARGO_TARGET_DIR", os.path.join(ROOT, "target"))


def fixtures(width):
    fix = os.environ.get("POMC_FIXTURES_BIN") or os.path.join(TARGET, "release", "pomc-fixtures")
    out = {}
    for scene in ("room", "sky"):
        d = os.path.join(TARGET, "bench-build", f"{scene}-{width}")
        if not os.path.exists(os.path.join(d, "depth.exr")):
            subprocess.run([fix, "rgbd", d, str(width), "equirect", scene], check=True, capture_output=True)
        out[f"analytic {scene} {width}"] = (os.path.join(d, "colour.png"), os.path.join(d, "depth.exr"))
    return out


def run(binary, colour, depth):
    with tempfile.TemporaryDirectory() as tmp:
        t = os.path.join(tmp, "time.txt")
        p = subprocess.run(["/usr/bin/time", "-f", "%e %M", "-o", t, binary, "build", "--colour", colour,
                            "--depth", depth, "-o", os.path.join(tmp, "out"), "--json"],
                           check=True, capture_output=True, text=True)
        wall, rss = open(t).read().split()
        report = json.loads(p.stdout)
    stages = dict(report["stages"])
    stages["read"], stages["write"] = report.get("read_s", 0.0), report.get("write_s", 0.0)
    return float(wall), int(rss) / 1024, stages


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("bins", nargs="+")
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--width", type=int, default=4096)
    ap.add_argument("--input", action="append", default=[], help="NAME=COLOUR,DEPTH")
    o = ap.parse_args()
    inputs = dict((i.split("=", 1)[0], tuple(i.split("=", 1)[1].split(","))) for i in o.input) or fixtures(o.width)
    print(f"load before {os.getloadavg()[0]:.2f}, {os.cpu_count()} cores, {o.runs} runs, binaries interleaved")
    for name, (colour, depth) in inputs.items():
        res = {b: [] for b in o.bins}
        for _ in range(o.runs):
            for b in o.bins:
                res[b].append(run(b, colour, depth))
        print(f"\n## {name}")
        for b, rs in res.items():
            walls = [r[0] for r in rs]
            stages = {k: statistics.median(r[2][k] for r in rs) for k in rs[0][2]}
            print(f"{os.path.basename(b):16s} wall min {min(walls):.2f} s median {statistics.median(walls):.2f} s, "
                  f"peak {max(r[1] for r in rs):.0f} MiB | " + ", ".join(f"{k} {v:.2f}" for k, v in stages.items()))
    print(f"\nload after {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
