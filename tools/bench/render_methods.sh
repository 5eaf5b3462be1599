#!/usr/bin/env bash
# Speed and holes of `pomc render --method splat` vs `--method mesh` on the analytic room.
# Builds a WIDTH×WIDTH/2 (default 4096×2048) 2-layer POMC from the room fixture's RGB-D panorama
# (`pomc-fixtures rgbd`, then `pomc build --no-pack`), renders 960×540 perspective views from the
# centre and from the freedom sphere RUNS times per method (default 5), then the mesh method again
# with the quadtrees stored in the panorama (`pomc mesh --store`: decoded instead of rebuilt).
# Writes docs/render-bench.json (every run's `--json` report) and prints median stage times.
# Usage: tools/bench/render_methods.sh [WIDTH] [RUNS]
set -euo pipefail
cd "$(dirname "$0")/../.."
width=${1:-4096}
runs=${2:-5}
target=${CARGO_TARGET_DIR:-target}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

cargo build --release -q -p pomc-cli -p pomc-fixtures
pomc=$target/release/pomc
"$target/release/pomc-fixtures" rgbd "$work/in" "$width" >/dev/null
# The fixtures put the room's panorama centre 1.2 m above the world origin.
"$pomc" build --colour "$work/in/colour.png" --depth "$work/in/depth.exr" -o "$work/pano" --no-pack --quiet \
  --center 0,0,1.2
cp -r "$work/pano" "$work/stored"
layers=$("$pomc" info "$work/stored" --json | python3 -c 'import json,sys; print(len(json.load(sys.stdin)["layers"]))')
for k in $(seq 0 $((layers - 1))); do
  "$pomc" mesh "$work/stored" --layer "$k" --store --no-metric --quiet
done

# eye (world; the panorama centre is 1.2 m above the origin) and look-at, as in eval_render --bench.
views=(
  "0,0,1.2 2,0,0.4 centre->box"
  "0,0.5,1.2 2,0,0.4 (0,0.5,0)->box"
  "-0.35,-0.35,1.2 -1.4,1.5,0.65 (-0.35,-0.35,0)->sphere"
  "0,0,0.7 0,0,-0.8 (0,0,-0.5)->down"
)
results=()
for v in "${views[@]}"; do
  read -r eye at name <<< "$v"
  for method in splat mesh mesh-stored; do
    pano=$work/pano
    m=$method
    if [ "$method" = mesh-stored ]; then pano=$work/stored; m=mesh; fi
    for i in $(seq "$runs"); do
      "$pomc" render "$pano" -o "$work/view.png" --method "$m" --eye="$eye" --look-at="$at" --size 960x540 \
        --json > "$work/r.json"
      results+=("{\"view\": \"$name\", \"method\": \"$method\", \"run\": $i, \"report\": $(cat "$work/r.json")}")
    done
  done
done
# Camera paths: the four views RUNS times each from one read (and one meshing) of the layers; the
# per-frame time is what a viewer or a frame sequence pays once the panorama is loaded.
: > "$work/path.txt"
for i in $(seq "$runs"); do
  for v in "${views[@]}"; do
    read -r eye at name <<< "$v"
    echo "$eye $at" >> "$work/path.txt"
  done
done
paths=()
for method in splat mesh mesh-stored; do
  pano=$work/pano
  m=$method
  if [ "$method" = mesh-stored ]; then pano=$work/stored; m=mesh; fi
  "$pomc" render "$pano" -o "$work/frame-####.png" --method "$m" --size 960x540 --path "$work/path.txt" \
    --json > "$work/p.json"
  paths+=("{\"method\": \"$method\", \"report\": $(cat "$work/p.json")}")
done
{
  echo "{\"machine\": \"$(nproc) cores, $(uname -m)\", \"commit\": \"$(git rev-parse --short HEAD)\", \"width\": $width,"
  echo "\"layers\": $layers, \"size\": \"960x540\", \"runs\": [$(IFS=,; echo "${results[*]}")],"
  echo "\"paths\": [$(IFS=,; echo "${paths[*]}")]}"
} > docs/render-bench.json
python3 - <<'PY'
import json, statistics
d = json.load(open("docs/render-bench.json"))
rows = {}
for r in d["runs"]:
    rows.setdefault((r["view"], r["method"]), []).append(r["report"])
keys = ["read_s", "mesh_s", "splat_s", "raster_s", "compose_s", "resolve_s", "write_s", "total_s"]
print(f"{d['width']}x{d['width'] // 2}, {d['layers']} layers, 960x540, {d['machine']}, medians of {len(next(iter(rows.values())))} runs")
print("| view | method | " + " | ".join(keys) + " | holes (%) | triangles |")
print("|---|---|" + "---|" * (len(keys) + 2))
for (view, method), reps in rows.items():
    med = lambda k: statistics.median(r["stages"][k] for r in reps) if k in reps[0]["stages"] else None
    cells = [f"{med(k):.3f}" if med(k) is not None else "—" for k in keys]
    tris = reps[0].get("mesh", {}).get("triangles", "—")
    print(f"| {view} | {method} | " + " | ".join(cells) + f" | {100 * reps[0]['hole_ratio']:.4f} | {tris} |")
print()
print(f"Camera path ({len(d['paths'][0]['report']['frames'])} frames: the four views × runs), one process per method")
print("| method | read_s | mesh_s | frame median (s) | frame max (s) | render median, no write (s) | total_s | worst holes (%) |")
print("|---|---|---|---|---|---|---|---|")
for p in d["paths"]:
    r = p["report"]
    st = r["stages"]
    draw = sorted(f["stages"]["frame_s"] - f["stages"]["write_s"] for f in r["frames"])
    mesh = f"{st['mesh_s']:.3f}" if st.get("mesh_s") is not None else "—"
    print(f"| {p['method']} | {st['read_s']:.3f} | {mesh} | {st['frame_median_s']:.3f} | {st['frame_max_s']:.3f} | "
          f"{draw[len(draw) // 2]:.3f} | {st['total_s']:.3f} | {100 * r['max_hole_ratio']:.4f} |")
PY
