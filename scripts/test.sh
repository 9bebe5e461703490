#!/usr/bin/env bash
# The whole test suite: installs Gmsh 4.15.2 with pip when it is missing (the
# end-to-end tests run Gmsh and its Python module), then `cargo test --release`.
# Extra arguments go to `cargo test` (e.g. `scripts/test.sh --test e2e_recombine`).
set -euo pipefail
cd "$(dirname "$0")/.."

# shellcheck source=scripts/ensure_gmsh.sh
source scripts/ensure_gmsh.sh
echo "scripts/test.sh: using $(command -v gmsh) (Gmsh $(gmsh --version 2>&1))" >&2

cargo test --release "$@"
