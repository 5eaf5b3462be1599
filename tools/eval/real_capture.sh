#!/bin/bash
# Build, validate and render a real RGB-D capture as docs/build.md's "Real captures" tables do:
# eye 0.3 m out along ±x and ±y, looking outwards, 640 × 360, 90°, splat and mesh; prints each
# view's hole ratio. Data stay under target/ (third-party images are never committed).
# usage: tools/eval/real_capture.sh NAME TAG BIN COLOUR DEPTH SCALE [extra build args...]
set -u
NAME=$1; TAG=$2; BIN=$(realpath "$3"); C=$(realpath "$4"); D=$(realpath "$5"); S=$6; shift 6; EXTRA=("$@")
O=$(cd "$(dirname "$0")/../.." && pwd)/target/real/runs/$NAME/$TAG; rm -rf "$O"; mkdir -p "$O"
cd "$O" || exit 2
"$BIN" prepare --colour "$C" --depth "$D" --depth-scale "$S" "${EXTRA[@]}" -o prepared.exr --json > prepare.json 2> prepare.err
"$BIN" build --colour "$C" --depth "$D" --depth-scale "$S" "${EXTRA[@]}" -o pano --json > build.json 2> build.err || exit 1
"$BIN" validate pano --json > validate.json 2> validate.err; echo "validate rc=$?" >> validate.err
"$BIN" info pano --json > info.json 2> info.err
for v in px:0.3,0,0:1.3,0,0 nx:-0.3,0,0:-1.3,0,0 py:0,0.3,0:0,1.3,0 ny:0,-0.3,0:0,-1.3,0; do
  IFS=: read -r n e l <<< "$v"
  for m in splat mesh; do
    "$BIN" render pano -o "$n-$m.png" --json --eye "$e" --look-at "$l" --size 640x360 --fov 90 --method $m \
      --mask "$n-$m-mask.png" > "render-$n-$m.json" 2> "render-$n-$m.err"
  done
done
python3 - <<'PY'
import glob, json
v = json.load(open("validate.json"))
print(f"layers {len(json.load(open('info.json'))['layers'])}, validate {v['errors']} E / {v['warnings']} W")
for f in sorted(glob.glob("render-*.json")):
    print(f"{f[7:-5]:10s} holes {100 * json.load(open(f))['hole_ratio']:.3f} %")
PY
