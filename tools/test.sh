#!/usr/bin/env bash
# Install what the tests need, then run them all: the workspace tests (including the OpenEXR C++ and
# Khronos glTF-Validator interoperability tests), the small path-traced corpus check, the viewer in
# headless Chromium, the Python package's tests and a bounded fuzzing run. Works on a fresh machine
# with Rust, Python 3.11 + pip, Node and gcc (and apt for Chromium); `.ci/run` calls it after fmt
# and clippy.
set -euo pipefail
cd "$(dirname "$0")/.."

echo "== installing test dependencies"
python3 -m pip install --quiet --disable-pip-version-check -r tools/requirements-test.txt
# Khronos glTF-Validator for the .glb export tests.
gltf_dir="${TMPDIR:-/tmp}/pomc-gltf-validator"
mkdir -p "$gltf_dir"
(cd "$gltf_dir" && [ -d node_modules/gltf-validator ] || npm install --silent --no-audit --no-fund gltf-validator >/dev/null)
export POMC_GLTF_VALIDATOR="$gltf_dir/node_modules"

echo "== cargo test --workspace"
cargo test --workspace

# The realistic corpus, small: path-traced scenes rendered by Blender Cycles (bpy from PyPI, in a venv
# under target/), built, meshed, validated and rendered from displaced eyes against the Blender truth.
# The binaries are the test profile's (already compiled by the tests above; wall times are not gated).
echo "== realistic corpus (small)"
cargo build -q --profile test -p pomc-cli -p pomc-fixtures
bin="${CARGO_TARGET_DIR:-target}/debug"
POMC_BIN="$bin/pomc" POMC_FIXTURES_BIN="$bin/pomc-fixtures" python3 tools/eval/realistic/run.py --small --check \
  --work target/realistic-ci

# The viewer (`pomc view`) in a real browser: Debian's chromium driven by puppeteer-core, each site
# exported and served from a plain static server, frames compared with `pomc render --method mesh`
# on the bundled room and the path-traced corpus just built.
echo "== viewer in headless Chromium"
if ! command -v chromium >/dev/null; then
  sudo=""; [ "$(id -u)" -ne 0 ] && sudo=sudo
  $sudo apt-get update -qq && DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq chromium >/dev/null
fi
(cd tools/viewer-test && npm ci --silent --no-audit --no-fund >/dev/null)
room_pomc="$(mktemp -d)/room-pomc"
"$bin/pomc" build --colour fixtures/data/room-rgbd/colour.png --depth fixtures/data/room-rgbd/depth.exr \
  -o "$room_pomc" --quiet
POMC_BIN="$bin/pomc" node tools/viewer-test/run.mjs --check --report target/viewer-report.json \
  fixtures/data/room-cube "$room_pomc" target/realistic-ci/*/{room,outdoor,extreme}/pano

# The Python package (PyO3, built by maturin through pip) against the same command-line binary.
echo "== python package"
python3 -m pip install --quiet --disable-pip-version-check ./python
POMC_BIN="$bin/pomc" python3 -m pytest -q python/tests

# The fuzz targets for a bounded time (POMC_FUZZ_SECONDS each, default 60) from the committed corpus,
# on stable Rust (fuzz/run.sh installs cargo-fuzz if needed).
echo "== fuzzing"
fuzz/run.sh
