#!/usr/bin/env bash
# Runs one cargo-fuzz target for a given time on one core.
#
#   scripts/fuzz.sh TARGET SECONDS [extra libFuzzer options...]
#
# TARGET is `read` (the MSH reader on arbitrary bytes) or `pipeline` (read → recombine →
# optimize, each Ok result checked by recombine::check_invariants and a per-quad validity
# check). The seeds in fuzz/corpus/TARGET/seed-* are the starting corpus; new inputs
# libFuzzer keeps land beside them (ignored by git). Findings are written to
# fuzz/artifacts/TARGET/. libFuzzer prints the execution count on its last line
# (`#N DONE ...`). Needs a nightly toolchain and cargo-fuzz (`cargo install cargo-fuzz`).
# Built with debug assertions (integer overflow panics) and without a sanitizer (safe Rust:
# speed matters more than ASan here).
# Set FUZZ_INVARIANTS_ONLY=1 to assert only check_invariants in the pipeline target.
set -euo pipefail
if [ $# -lt 2 ]; then
    echo "usage: $0 TARGET SECONDS [libFuzzer options...]" >&2
    exit 2
fi
target=$1
seconds=$2
shift 2
cd "$(dirname "$0")/.."
# one core: the recombination's parallel loops run on one thread
export RAYON_NUM_THREADS=1
exec cargo +nightly fuzz run --release --debug-assertions --sanitizer none "$target" "fuzz/corpus/$target" -- \
    -max_total_time="$seconds" -max_len=65536 -timeout=30 -rss_limit_mb=2048 \
    -print_final_stats=1 "$@"
