#!/usr/bin/env bash
# Run every fuzz target for a bounded time from the committed corpus (corpus.tar.gz) and the seeds.
# Works on stable Rust: RUSTC_BOOTSTRAP lets cargo-fuzz pass its -Z flags, and no sanitizer is
# needed for Rust code (panics, aborts, out-of-memory and timeouts are what libFuzzer catches here).
#   POMC_FUZZ_SECONDS  time per target (default 60)
#   POMC_FUZZ_UPDATE=1 merge what this run found back into corpus.tar.gz (minimised)
set -euo pipefail
cd "$(dirname "$0")"
secs="${POMC_FUZZ_SECONDS:-60}"
export RUSTC_BOOTSTRAP=1

if ! cargo fuzz --version >/dev/null 2>&1; then
    echo "== installing cargo-fuzz"
    cargo install --quiet --locked cargo-fuzz --version 0.13.2
fi

work="${CARGO_TARGET_DIR:-target}/fuzz-work"
rm -rf "$work" && mkdir -p "$work"
tar xzf corpus.tar.gz -C "$work"
targets=(manifest layer_exr prepare)
cargo fuzz build --sanitizer none
for t in "${targets[@]}"; do
    echo "== fuzz $t for ${secs}s"
    mkdir -p "$work/new/$t"
    # -rss_limit_mb: an input that makes the reader allocate past 2 GB is a finding (issue 12).
    cargo fuzz run --sanitizer none "$t" "$work/new/$t" "$work/corpus/$t" "seeds/$t" -- \
        -max_total_time="$secs" -rss_limit_mb=2048 -timeout=10 -print_final_stats=1 2>"$work/$t.log" || {
        tail -60 "$work/$t.log"
        echo "fuzz target $t failed: the input is in fuzz/artifacts/$t/" >&2
        exit 1
    }
    grep -E "DONE|stat::number_of_executed_units|stat::peak_rss_mb" "$work/$t.log" || true
done

if [ "${POMC_FUZZ_UPDATE:-0}" = 1 ]; then
    for t in "${targets[@]}"; do
        mkdir -p "$work/min/corpus/$t"
        cargo fuzz run --sanitizer none "$t" "$work/min/corpus/$t" "$work/corpus/$t" "$work/new/$t" -- -merge=1 \
            2>/dev/null
    done
    tar czf corpus.tar.gz -C "$work/min" corpus
    echo "corpus.tar.gz updated"
fi
