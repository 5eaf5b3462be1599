#!/usr/bin/env bash
# Side-by-side benchmark: `pomc convert` vs ffmpeg v360 on the same 8192×4096 equirect PNG, same run.
# Needs: ffmpeg and hyperfine (apt-get install ffmpeg hyperfine). Writes docs/benchmarks-convert.json.
# Usage: tools/bench/convert_vs_ffmpeg.sh [RUNS]
set -euo pipefail
cd "$(dirname "$0")/../.."
runs=${1:-5}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

cargo build --release -q -p pomc-cli
pomc=${CARGO_TARGET_DIR:-target}/release/pomc
# A detailed 8192×4096 input (ffmpeg's testsrc2 pattern), the same file for both tools.
ffmpeg -v error -f lavfi -i testsrc2=s=8192x4096 -frames:v 1 -y "$work/in.png"

threads=$(nproc)
hyperfine --warmup 1 --runs "$runs" --export-json docs/benchmarks-convert.json \
  -n "pomc convert (bilinear)" \
  "$pomc convert $work/in.png -o $work/pomc.png --to cube --face-size 2048 --interp bilinear --layout ffmpeg-c3x2 --quiet" \
  -n "ffmpeg v360 (linear)" \
  "ffmpeg -v error -threads $threads -i $work/in.png -vf v360=e:c3x2:interp=linear:w=6144:h=4096 -y $work/ffmpeg.png"

# Stage breakdown of pomc (decode / resample / encode / total, ms) from its own JSON report, 3 runs.
echo "pomc stages (ms): decode resample encode total"
for i in 1 2 3; do
  $pomc --json convert "$work/in.png" -o "$work/pomc.png" --to cube --face-size 2048 --interp bilinear \
    --layout ffmpeg-c3x2 > "$work/pomc.json"
  python3 -c 'import json,sys; t=json.load(open(sys.argv[1]))["timings_ms"]; print(t["decode"], t["resample"], t["encode"], t["total"])' "$work/pomc.json"
done
echo "machine: $(nproc) cores, $(lscpu | sed -n 's/^Model name: *//p' | head -1), load $(cut -d' ' -f1-3 /proc/loadavg)"
