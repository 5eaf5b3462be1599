#!/usr/bin/env bash
# Install what the tests need, then run them all: the workspace tests (including the OpenEXR C++ and
# Khronos glTF-Validator interoperability tests), the small path-traced corpus check, the Python
# package's tests and a bounded fuzzing run. Works on a fresh machine with Rust, Python 3.11 + pip,
# Node and gcc; `.ci/run` calls it after fmt and clippy.
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
POMC_BIN="$bin/pomc" POMC_FIXTURES_BIN="$bin/pomc-fixtures" python3 tools/eval/realistic/run.py --small --check

# The Python package (PyO3, built by maturin through pip) against the same command-line binary.
echo "== python package"
python3 -m pip install --quiet --disable-pip-version-check ./python
POMC_BIN="$bin/pomc" python3 -m pytest -q python/tests

# The fuzz targets for a bounded time (POMC_FUZZ_SECONDS each, default 60) from the committed corpus,
# on stable Rust (fuzz/run.sh installs cargo-fuzz if needed).
echo "== fuzzing"
fuzz/run.sh
