#!/usr/bin/env bash
# Check `--layout ffmpeg-c3x2` against real ffmpeg (v360) on the same equirect picture.
# Needs ffmpeg and python3 with numpy. Prints per-face mean absolute difference (0-255 scale) and the
# share of pixels differing by more than 32, for ours vs ffmpeg and, as a control, for the canonical
# layout vs ffmpeg (which must NOT match).
# Usage: tools/bench/check_ffmpeg_layout.sh [EQUIRECT_WIDTH]
set -euo pipefail
cd "$(dirname "$0")/../.."
w=${1:-2048}
h=$((w / 2)); n=$((w / 4))
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cargo build --release -q -p pomc-cli
pomc=${CARGO_TARGET_DIR:-target}/release/pomc

ffmpeg -v error -f lavfi -i "testsrc2=s=${w}x${h}" -frames:v 1 -y "$work/e.png"
for interp in near linear; do
  ffmpeg -v error -i "$work/e.png" -vf "v360=e:c3x2:interp=$interp:w=$((3 * n)):h=$((2 * n))" -y "$work/ff_$interp.png"
done
$pomc -q convert "$work/e.png" -o "$work/ours_near.png" --to cube --face-size $n --interp nearest --layout ffmpeg-c3x2
$pomc -q convert "$work/e.png" -o "$work/ours_linear.png" --to cube --face-size $n --interp bilinear --layout ffmpeg-c3x2
$pomc -q convert "$work/e.png" -o "$work/canon.png" --to cube --face-size $n --interp nearest --layout canonical
# And back: ffmpeg's cube to equirect with both tools.
ffmpeg -v error -i "$work/ff_linear.png" -vf "v360=c3x2:e:interp=linear:w=$w:h=$h" -y "$work/ff_back.png"
$pomc -q convert "$work/ff_linear.png" -o "$work/ours_back.png" --to equirect --width $w --interp bilinear --in-layout ffmpeg-c3x2
for f in ff_back ours_back; do
  ffmpeg -v error -i "$work/$f.png" -f rawvideo -pix_fmt rgb24 -y "$work/$f.rgb"
done
for f in ff_near ff_linear ours_near ours_linear canon; do
  ffmpeg -v error -i "$work/$f.png" -f rawvideo -pix_fmt rgb24 -y "$work/$f.rgb"
done

python3 - "$work" "$n" <<'PY'
import sys, numpy as np
work, n = sys.argv[1], int(sys.argv[2])
load = lambda f: np.fromfile(f"{work}/{f}.rgb", np.uint8).reshape(2 * n, 3 * n, 3).astype(np.int16)
names = ["right", "left", "up", "down", "front", "back"]
def report(a, b, label):
    d = np.abs(load(a) - load(b))
    faces = []
    for k in range(6):
        r, c = divmod(k, 3)
        f = d[r * n:(r + 1) * n, c * n:(c + 1) * n]
        faces.append(f"{names[k]} {f.mean():.2f}/{(f.max(axis=2) > 32).mean() * 100:.1f}%")
    print(f"{label:34} mean {d.mean():6.2f}  >32: {(d.max(axis=2) > 32).mean() * 100:5.1f}%   " + ", ".join(faces))
report("ours_near", "ff_near", "ffmpeg-c3x2 nearest vs ffmpeg near")
report("ours_linear", "ff_linear", "ffmpeg-c3x2 bilinear vs ffmpeg linear")
report("canon", "ff_near", "control: canonical vs ffmpeg near")
a = np.fromfile(f"{work}/ff_back.rgb", np.uint8).reshape(2 * n, 4 * n, 3).astype(np.int16)
b = np.fromfile(f"{work}/ours_back.rgb", np.uint8).reshape(2 * n, 4 * n, 3).astype(np.int16)
d = np.abs(a - b)
print(f"{'cube->equirect, bilinear vs linear':34} mean {d.mean():6.2f}  >32: {(d.max(axis=2) > 32).mean() * 100:5.1f}%")
PY
