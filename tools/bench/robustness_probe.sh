#!/usr/bin/env bash
# Robustness of `pomc build` to anti-aliased and noisy depth (docs/build.md, "Robustness"): the room
# RGB-D at 2·W×W, box-filtered 2×2 to W×W/2 (colour and depth: an anti-aliased render), and the exact
# W×W/2 depth with 0.2 % multiplicative Gaussian noise (seed 1); each built with `pomc build` and
# rendered 960×540 from four eyes near the freedom radius. Prints the layers and the holes per view.
# Usage: tools/bench/robustness_probe.sh [W] (default 2048). Needs: pip install numpy pillow OpenEXR
set -euo pipefail
cd "$(dirname "$0")/../.."
w=${1:-2048}
target=${CARGO_TARGET_DIR:-target}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cargo build --release -q -p pomc-cli -p pomc-fixtures
pomc=$target/release/pomc
"$target/release/pomc-fixtures" rgbd "$work/fine" $((2 * w)) >/dev/null
"$target/release/pomc-fixtures" rgbd "$work/exact" "$w" >/dev/null
python3 - "$work" "$w" <<'PY'
import sys
import numpy as np
import OpenEXR
from PIL import Image
work, w = sys.argv[1], int(sys.argv[2])
h = w // 2
hdr = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
z = OpenEXR.File(f"{work}/fine/depth.exr").channels()["Z"].pixels.astype(np.float64)
OpenEXR.File(hdr, {"Z": z.reshape(h, 2, w, 2).mean(axis=(1, 3)).astype(np.float32)}).write(f"{work}/aa-depth.exr")
c = np.asarray(Image.open(f"{work}/fine/colour.png").convert("RGB")).astype(np.float64)
Image.fromarray(c.reshape(h, 2, w, 2, 3).mean(axis=(1, 3)).round().astype(np.uint8)).save(f"{work}/aa-colour.png")
z = OpenEXR.File(f"{work}/exact/depth.exr").channels()["Z"].pixels
noisy = z * (1 + 0.002 * np.random.default_rng(1).standard_normal(z.shape))
OpenEXR.File(hdr, {"Z": noisy.astype(np.float32)}).write(f"{work}/noisy-depth.exr")
PY
for case in "exact $work/exact/colour.png $work/exact/depth.exr" \
  "anti-aliased $work/aa-colour.png $work/aa-depth.exr" \
  "noisy $work/exact/colour.png $work/noisy-depth.exr"; do
  read -r name colour depth <<< "$case"
  "$pomc" build --colour "$colour" --depth "$depth" -o "$work/$name" --center 0,0,1.2 --json \
    | python3 -c "import json,sys; d=json.load(sys.stdin); print('$name: mixed pixels', d['mixed_pixels'], 'layers', [(l['name'], l['own_pixels']) for l in d['layers']])"
  holes=""
  for v in "0,0.5,1.2 2,0,0.4" "-0.35,-0.35,1.2 -1.4,1.5,0.65" "0.5,0,1.2 3,1,0.4" "0,-0.5,1.2 2,0,0.4"; do
    read -r eye at <<< "$v"
    holes="$holes $("$pomc" render "$work/$name" -o "$work/view.png" --eye="$eye" --look-at="$at" --json \
      | python3 -c 'import json,sys; print(json.load(sys.stdin)["holes"])')"
  done
  echo "  holes in the 4 views:$holes"
done
