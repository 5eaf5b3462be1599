#!/usr/bin/env bash
# pomc mesh vs Delatin on the room background (6×N² cube map): triangles and time at equal 3D p99 error.
# Usage: tools/bench/mesh_vs_delatin.sh [N]   (default 1024). Needs: pip install pydelatin numpy matplotlib
# pomc rows: "pomc" (quadtree, --no-simplify), "pomc-collapse" (quadtree + collapses, --no-greedy) and
# "pomc-simplify" (the default: greedy insertion on clean faces + collapses); Delatin rows: "delatin" (its
# six face meshes, unstitched) and "delatin+strips" (closed with pomc's strips between faces). Columns:
# name,max_error,triangles,p99_rel,max_rel,seconds,face_triangles,mesh_seconds; pomc's seconds are the
# best of POMC_MESH_REPEAT runs (default 3) of the whole mesh_layer (mesh_seconds without sampling the
# layer into lattices), Delatin's the sum of its six faces (each best of 3).
set -euo pipefail
cd "$(dirname "$0")/../.."
N="${1:-1024}"
OUT="${OUT:-target/bench-mesh}"
mkdir -p "$OUT"
POMC_MESH_N="$N" cargo test --release -q -p pomc --test it mesh_figures::sweep_max_error -- --ignored --nocapture \
  | grep '^CSV ' | sed 's/^CSV //' > "$OUT/pomc.csv"
python3 tools/bench/mesh_vs_delatin.py "$N" | grep '^CSV ' | sed 's/^CSV //' > "$OUT/delatin.csv"
python3 tools/bench/plot_mesh.py "$OUT/pomc.csv" "$OUT/delatin.csv" "$OUT/mesh_vs_delatin.png"
cat "$OUT/pomc.csv" "$OUT/delatin.csv"
