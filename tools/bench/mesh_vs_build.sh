#!/usr/bin/env bash
# Meshing every layer of a panorama against building it (issue 10: `pomc mesh PANO -o scene.glb` must
# take no longer than `pomc build` of the same panorama). Runs build and mesh in turn, RUNS times each,
# on the given RGB-D panoramas, and prints min / median wall seconds of both and the median ratio.
# Usage: tools/bench/mesh_vs_build.sh RUNS COLOUR DEPTH [BUILD OPTIONS...]
#   e.g. tools/bench/mesh_vs_build.sh 5 target/realistic-corpus/<hash>/room/colour.exr \
#          target/realistic-corpus/<hash>/room/depth.exr --convention blender --freedom-radius 0.9
set -euo pipefail
cd "$(dirname "$0")/../.."
runs=$1 colour=$2 depth=$3
shift 3
cargo build --release -q -p pomc-cli
pomc=${CARGO_TARGET_DIR:-target}/release/pomc
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
wall() { /usr/bin/time -f '%e' -o "$work/t" "$@" >/dev/null 2>&1; cat "$work/t"; }
builds=() meshes=()
for _ in $(seq "$runs"); do
  rm -rf "$work/pano"
  builds+=("$(wall "$pomc" build --colour "$colour" --depth "$depth" -o "$work/pano" --quiet "$@")")
  meshes+=("$(wall "$pomc" mesh "$work/pano" -o "$work/scene.glb" --quiet)")
done
python3 - "${builds[*]}" "${meshes[*]}" "$(cat /proc/loadavg)" <<'PY'
import statistics, sys
b, m = ([float(x) for x in a.split()] for a in sys.argv[1:3])
print(f"build: min {min(b):.2f} s, median {statistics.median(b):.2f} s")
print(f"mesh (all layers, .glb): min {min(m):.2f} s, median {statistics.median(m):.2f} s")
print(f"mesh / build (medians): {statistics.median(m) / statistics.median(b):.2f}; load average {sys.argv[3]}")
PY
