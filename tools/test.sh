#!/usr/bin/env bash
# Install what the tests need, then run them all: the workspace tests (including the OpenEXR C++ and
# Khronos glTF-Validator interoperability tests), the small path-traced corpus check, the viewer in
# headless Chromium, the Python package's tests and a bounded fuzzing run. Works on a fresh machine
# with Rust, Python 3.11 + pip, Node and gcc (and apt for Chromium); `.ci/run` calls it after fmt
# and clippy. Python packages go to a venv under the target directory, never the system's. Each
# part runs even when one before it failed; the last line is `tests: N passed, N failed`.
set -uo pipefail
cd "$(dirname "$0")/.."
target="${CARGO_TARGET_DIR:-target}"
case "$target" in /*) ;; *) target="$PWD/$target" ;; esac
bin="$target/debug"
passed=0
failed=()

# Run one part (a name, then a function); its failure is counted, not fatal.
part() {
  local name="$1"
  shift
  echo "== $name"
  # Not inside `if`: there errexit would be ignored and a part would go on past its first failure.
  (set -e; "$@")
  if [ $? -eq 0 ]; then
    passed=$((passed + 1))
  else
    echo "FAIL: $name"
    failed+=("$name")
  fi
}

install() {
  venv="$target/test-venv"
  [ -x "$venv/bin/python" ] || python3 -m venv "$venv"
  "$venv/bin/python" -m pip install --quiet --disable-pip-version-check -r tools/requirements-test.txt
  # Khronos glTF-Validator for the .glb export tests.
  gltf_dir="${TMPDIR:-/tmp}/pomc-gltf-validator"
  mkdir -p "$gltf_dir"
  (cd "$gltf_dir" && [ -d node_modules/gltf-validator ] || npm install --silent --no-audit --no-fund gltf-validator >/dev/null)
}

cargo_tests() {
  cargo test --workspace
}

# The realistic corpus, small: path-traced scenes rendered by Blender Cycles (bpy from PyPI, in a venv
# under target/), built, meshed, validated and rendered from displaced eyes against the Blender truth.
# The binaries are the test profile's (already compiled by the tests above; wall times are not gated).
realistic() {
  cargo build -q --profile test -p pomc-cli -p pomc-fixtures
  POMC_BIN="$bin/pomc" POMC_FIXTURES_BIN="$bin/pomc-fixtures" python3 tools/eval/realistic/run.py --small --check \
    --work "$target/realistic-ci"
}

# The viewer (`pomc view`) in a real browser: Debian's chromium driven by puppeteer-core, each site
# exported and served from a plain static server, frames compared with `pomc render --method mesh`
# on the bundled room and the path-traced corpus just built.
viewer() {
  if ! command -v chromium >/dev/null; then
    sudo=""; [ "$(id -u)" -ne 0 ] && sudo=sudo
    $sudo apt-get update -qq && DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq chromium >/dev/null
  fi
  (cd tools/viewer-test && npm ci --silent --no-audit --no-fund >/dev/null)
  cargo build -q --profile test -p pomc-cli
  room_pomc="$(mktemp -d)/room-pomc"
  "$bin/pomc" build --colour fixtures/data/room-rgbd/colour.png --depth fixtures/data/room-rgbd/depth.exr \
    -o "$room_pomc" --quiet
  POMC_BIN="$bin/pomc" node tools/viewer-test/run.mjs --check --report "$target/viewer-report.json" \
    fixtures/data/room-cube "$room_pomc" "$target"/realistic-ci/*/{room,outdoor,extreme}/pano
}

# The Python package (PyO3, built by maturin through pip) against the same command-line binary.
python_package() {
  python3 -m pip install --quiet --disable-pip-version-check ./python
  cargo build -q --profile test -p pomc-cli
  POMC_BIN="$bin/pomc" python3 -m pytest -q python/tests
}

# The fuzz targets for a bounded time (POMC_FUZZ_SECONDS each, default 60) from the committed corpus,
# on stable Rust (fuzz/run.sh installs cargo-fuzz if needed).
fuzzing() {
  fuzz/run.sh
}

part "installing test dependencies" install
# Everything after this uses the venv's python3 and the validator just installed.
export PATH="$target/test-venv/bin:$PATH"
export POMC_GLTF_VALIDATOR="${TMPDIR:-/tmp}/pomc-gltf-validator/node_modules"
part "cargo test --workspace" cargo_tests
part "realistic corpus (small)" realistic
part "viewer in headless Chromium" viewer
part "python package" python_package
part "fuzzing" fuzzing

echo "tests: $passed passed, ${#failed[@]} failed${failed[*]:+ (${failed[*]})}"
[ "${#failed[@]}" -eq 0 ]
