"""Layer EXR read and write, pomc against OpenEXR's C++ library (its Python binding), same files,
same run, interleaved.

  python3 tools/bench/exr_vs_openexr.py PANO_DIR [RUNS]

Both decode or encode every EXR file of the panorama, files in parallel, OpenEXR with one thread
per core. pomc: `pomc::layer_io::read_exr` / `write_exr` timed in process by the `exr_io` example
(`cargo build --release --example exr_io`; $EXR_IO names another binary), so the files are decoded
to planar f32 exactly as `pomc` reads layers. OpenEXR: `OpenEXR.File(f)` and
`OpenEXR.File(header, channels).write(f)` (same channels, same ZIP compression). Also `pomc.open`
(manifest, layers decoded and unpacked to full canvases) when the pomc package is installed.
Prints min / median seconds of RUNS (default 5) and OpenEXR / pomc (above 1: pomc faster).
"""

import os
import statistics
import sys
import tempfile
import time

from concurrent.futures import ThreadPoolExecutor
import subprocess

import OpenEXR

try:
    import pomc
except ImportError:
    pomc = None

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))


def timed(f):
    t = time.perf_counter()
    f()
    return time.perf_counter() - t


def main():
    pano_dir = sys.argv[1]
    runs = int(sys.argv[2]) if len(sys.argv) > 2 else 5
    OpenEXR.set_global_thread_count(os.cpu_count() or 1)
    files = sorted(os.path.join(pano_dir, f) for f in os.listdir(pano_dir) if f.endswith(".exr"))
    if not files:
        sys.exit(f"{pano_dir}: no EXR files")
    decoded = {f: OpenEXR.File(f) for f in files}
    sizes = sum(os.path.getsize(f) for f in files)
    print(f"{pano_dir}: {len(files)} EXR files, {sizes / 1e6:.1f} MB, OpenEXR threads {os.cpu_count()}, "
          f"load {os.getloadavg()[0]:.2f}")
    exr_io = os.environ.get("EXR_IO") or os.path.join(
        os.environ.get("CARGO_TARGET_DIR", os.path.join(ROOT, "target")), "release", "examples", "exr_io")
    out_dir = tempfile.TemporaryDirectory()
    out = out_dir.name
    pool = ThreadPoolExecutor(len(files))

    def pomc_io(mode):
        return float(subprocess.run([exr_io, mode, *files], check=True, capture_output=True, text=True).stdout)

    def read_openexr():
        list(pool.map(lambda f: OpenEXR.File(f).channels(), files))

    def write_openexr():
        def one(f):
            part = decoded[f].parts[0]
            OpenEXR.File(part.header, part.channels).write(os.path.join(out, os.path.basename(f)))
        list(pool.map(one, files))

    times = {k: [] for k in ("pomc read", "OpenEXR read", "pomc write", "OpenEXR write")}
    if pomc is not None:
        times["pomc.open"] = []
    for _ in range(runs):
        times["pomc read"].append(pomc_io("read"))
        times["OpenEXR read"].append(timed(read_openexr))
        times["pomc write"].append(pomc_io("write"))
        times["OpenEXR write"].append(timed(write_openexr))
        if pomc is not None:
            times["pomc.open"].append(timed(lambda: pomc.open(pano_dir)))
    for k, v in times.items():
        print(f"{k:14s} min {min(v):.3f} s  median {statistics.median(v):.3f} s")
    for what in ("read", "write"):
        p, o = times[f"pomc {what}"], times[f"OpenEXR {what}"]
        print(f"{what}: OpenEXR / pomc = {min(o) / min(p):.2f}x (min), "
              f"{statistics.median(o) / statistics.median(p):.2f}x (median)")
    print(f"load after {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
