#!/usr/bin/env bash
# Benchmark and quality report of `pomc build` on the analytic room (exact multi-hit truth).
# Writes docs/build-bench.json: per-run wall time, per-stage times and peak RSS of `pomc build`
# on a WIDTH×WIDTH/2 RGB-D equirect (default 4096), and the quality figures of `eval-build`.
# Usage: tools/bench/build_room.sh [WIDTH] [RUNS]
set -euo pipefail
cd "$(dirname "$0")/../.."
width=${1:-4096}
runs=${2:-3}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

cargo build --release -q -p pomc-cli -p pomc-fixtures
pomc=${CARGO_TARGET_DIR:-target}/release/pomc
${CARGO_TARGET_DIR:-target}/release/pomc-fixtures rgbd "$work/in" "$width" >/dev/null

results=()
for i in $(seq "$runs"); do
  rm -rf "$work/out"
  /usr/bin/time -f '%e %M' -o "$work/time.txt" \
    "$pomc" build --colour "$work/in/colour.png" --depth "$work/in/depth.exr" -o "$work/out" --json > "$work/report.json"
  read -r wall rss_kb < "$work/time.txt"
  results+=("{\"run\": $i, \"wall_s\": $wall, \"peak_rss_mb\": $((rss_kb / 1024)), \"report\": $(cat "$work/report.json")}")
done
"$pomc" validate "$work/out" --json > "$work/validate.json"
eval=$(${CARGO_TARGET_DIR:-target}/release/pomc-fixtures eval-build "$width")
{
  echo "{\"machine\": \"$(nproc) cores, $(uname -m)\", \"commit\": \"$(git rev-parse --short HEAD)\", \"width\": $width,"
  echo "\"runs\": [$(IFS=,; echo "${results[*]}")],"
  echo "\"validate\": $(cat "$work/validate.json"),"
  echo "\"quality\": $eval}"
} > docs/build-bench.json
python3 - <<'PY'
import json
d = json.load(open("docs/build-bench.json"))
for r in d["runs"]:
    st = {k: round(v, 3) for k, v in r["report"]["stages"]}
    print(f"run {r['run']}: wall {r['wall_s']} s, peak {r['peak_rss_mb']} MB, build stages {st}, "
          f"read {r['report']['read_s']:.3f} s, write {r['report']['write_s']:.3f} s")
print("valid:", d["validate"]["valid"], "errors", d["validate"]["errors"], "warnings", d["validate"]["warnings"])
for q in d["quality"]:
    print(f"normals given={q['given_normals']}: accuracy {q['assignment_accuracy']:.7f}, fill median rel err "
          f"{q['fill_median_rel_error']:.2e}, p90 {q['fill_p90_rel_error']:.2e}, build {q['build_s']:.3f} s")
PY
