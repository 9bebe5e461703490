#!/usr/bin/env bash
# Benchmark (not a test): blossomquad against Gmsh's built-in recombination on
# the geo/ fixtures at ~1e4 and ~1e5 triangles (BENCH_TARGETS="1e4 1e5 1e6" adds
# the 1e6 rows). Builds the release binary, then runs scripts/bench_vs_gmsh.py,
# which writes BENCHMARKS.md (see that script for what each row measures and the
# environment variables it takes).
set -euo pipefail
cd "$(dirname "$0")/.."

# shellcheck source=scripts/ensure_gmsh.sh
source scripts/ensure_gmsh.sh

cargo build --release --quiet
export BLOSSOMQUAD="${BLOSSOMQUAD:-${CARGO_TARGET_DIR:-target}/release/blossomquad}"
exec "$PYTHON" scripts/bench_vs_gmsh.py
