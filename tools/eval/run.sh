#!/usr/bin/env bash
# The evaluation harness, one command: analytic scenes (pomc-fixtures) -> pomc build -> pomc mesh ->
# pomc render from a camera grid inside the freedom radius -> compared with exact ray-cast views, for
# the single-layer baseline, the layered splat and the layered mesh; sweeps of build and mesh
# parameters; peer comparisons (ffmpeg v360, py360convert, Delatin) in the same run. Writes
# docs/evaluation.md (the generated block), docs/eval-results.json and docs/eval-*.png.
#
# Usage: tools/eval/run.sh [--quick|--full] [--work DIR] [--only main,sweeps,convert,mesh] [--no-docs]
#   default: 4 scenes, ~10 min on 2 cores; --quick: 2 scenes at 1024 px, ~3 min; --full: more eyes,
#   views and sweep points (~1 h).
# Environment: CARGO_TARGET_DIR (default target/), EVAL_VENV (default target dir/eval-venv): the
# Python venv used when the system Python lacks numpy, matplotlib, PIL, py360convert or pydelatin.
set -euo pipefail
cd "$(dirname "$0")/../.."
export CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$PWD/target}"

echo "== building release binaries (pomc, pomc-fixtures, pomc-eval)"
cargo build --release -q -p pomc-cli -p pomc-fixtures

# Python: the system interpreter if it has everything, else a venv with what is missing.
py=python3
need_py() { "$1" -c 'import numpy, matplotlib, PIL' 2>/dev/null; }
if ! need_py "$py" || ! "$py" -c 'import py360convert, pydelatin' 2>/dev/null; then
  venv="${EVAL_VENV:-$CARGO_TARGET_DIR/eval-venv}"
  if [ ! -x "$venv/bin/python" ]; then
    echo "== creating Python venv $venv"
    python3 -m venv --system-site-packages "$venv"
  fi
  py="$venv/bin/python"
  "$py" -m pip install -q numpy matplotlib pillow || { echo "error: cannot install numpy/matplotlib/pillow" >&2; exit 2; }
  # Peers: a failure only skips that peer (reported in docs/evaluation.md).
  "$py" -c 'import py360convert' 2>/dev/null || "$py" -m pip install -q py360convert \
    || echo "warning: py360convert cannot be installed; its comparison will be skipped" >&2
  "$py" -c 'import pydelatin' 2>/dev/null || "$py" -m pip install -q pydelatin \
    || echo "warning: pydelatin cannot be installed; the Delatin comparison will be skipped" >&2
fi

# ffmpeg (v360 peer and the layout checks).
if ! command -v ffmpeg >/dev/null; then
  echo "== installing ffmpeg"
  if command -v apt-get >/dev/null; then
    sudo=""; [ "$(id -u)" -ne 0 ] && sudo="sudo"
    $sudo apt-get install -y -qq ffmpeg >/dev/null || echo "warning: ffmpeg cannot be installed; v360 skipped" >&2
  else
    echo "warning: no ffmpeg and no apt-get; the ffmpeg comparison will be skipped" >&2
  fi
fi

# The bench scripts called by the harness run `python3`: put the chosen interpreter first.
if [ "$py" != python3 ]; then
  export PATH="$(dirname "$py"):$PATH"
fi
exec "$py" tools/eval/eval.py "$@"
