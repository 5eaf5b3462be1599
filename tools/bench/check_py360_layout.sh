#!/usr/bin/env bash
# Check `--layout py360-horizon` against py360convert (pip install py360convert; needs ffmpeg for PNG I/O).
# A 16-bit equirect storing (column, row) per pixel goes through both tools with nearest sampling; prints
# the largest column/row disagreement per face (pole rows excluded for columns).
# Usage: tools/bench/check_py360_layout.sh [EQUIRECT_WIDTH]
set -euo pipefail
cd "$(dirname "$0")/../.."
w=${1:-512}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cargo build --release -q -p pomc-cli
python3 - "$work" "$w" "$(realpath "${CARGO_TARGET_DIR:-target}")/release/pomc" <<'PY'
import subprocess, sys
import numpy as np, py360convert
work, w, pomc = sys.argv[1], int(sys.argv[2]), sys.argv[3]
h, n = w // 2, w // 4
img = np.zeros((h, w, 3), np.uint16)
img[:, :, 0] = np.arange(w)[None, :]
img[:, :, 1] = np.arange(h)[:, None]
img.astype(">u2").tofile(f"{work}/e.raw")
run = lambda *a: subprocess.run(list(a), check=True)
run("ffmpeg", "-v", "error", "-f", "rawvideo", "-pix_fmt", "rgb48be", "-s", f"{w}x{h}", "-i", f"{work}/e.raw", "-y", f"{work}/e.png")
run(pomc, "-q", "convert", f"{work}/e.png", "-o", f"{work}/ours.png", "--to", "cube", "--face-size", str(n),
    "--interp", "nearest", "--layout", "py360-horizon")
run("ffmpeg", "-v", "error", "-i", f"{work}/ours.png", "-f", "rawvideo", "-pix_fmt", "rgb48be", "-y", f"{work}/ours.raw")
ours = np.fromfile(f"{work}/ours.raw", ">u2").reshape(n, 6 * n, 3).astype(int)
ref = py360convert.e2c(img.astype(np.float64), face_w=n, mode="nearest", cube_format="horizon").astype(int)
dc = np.abs(ref[:, :, 0] - ours[:, :, 0]); dc = np.minimum(dc, w - dc)
dr = np.abs(ref[:, :, 1] - ours[:, :, 1])
for k, name in enumerate("FRBLUD"):
    s = slice(k * n, (k + 1) * n)
    inner = (ref[:, s, 1] > 0) & (ref[:, s, 1] < h - 1)
    print(f"{name}: max column diff {dc[:, s][inner].max()}, max row diff {dr[:, s].max()}, "
          f"exact {((dc[:, s] == 0) & (dr[:, s] == 0)).mean() * 100:.1f}%")
PY
