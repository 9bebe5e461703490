#!/usr/bin/env bash
# The whole test suite: installs Gmsh 4.15.2 with pip when it is missing (the
# end-to-end tests run Gmsh and its Python module), then `cargo test --release`.
# Extra arguments go to `cargo test` (e.g. `scripts/test.sh --test e2e recombine`).
set -euo pipefail
cd "$(dirname "$0")/.."

# shellcheck source=scripts/ensure_gmsh.sh
source scripts/ensure_gmsh.sh
echo "scripts/test.sh: using $(command -v gmsh) (Gmsh $(gmsh --version 2>&1))" >&2

cargo test --release "$@"

# The Python package (python/): built and installed by pip into a venv under target/, then
# its tests. Skipped only when arguments select part of the Rust suite.
if [ $# -eq 0 ]; then
    venv=target/py-venv
    if [ ! -x "$venv/bin/python" ]; then
        python3 -m venv "$venv"
    fi
    "$venv/bin/python" -m pip install -q --disable-pip-version-check numpy pytest meshio "gmsh==4.15.2"
    CARGO_TARGET_DIR="$PWD/target/python" "$venv/bin/python" -m pip install -q --disable-pip-version-check ./python
    PATH="$PWD/$venv/bin:$PATH" "$venv/bin/python" -m pytest -q python/tests
fi

# --- The README's Python examples -----------------------------------------------------
# Every ```python block of README.md and python/README.md, run verbatim in a venv made from
# scratch (target/readme-venv) with the package installed from ./python with the extras the
# text names (see tests/readme_python.py). Skipped, as above, when arguments select part of
# the Rust suite.
if [ $# -eq 0 ]; then
    python3 tests/readme_python.py --venv target/readme-venv
fi
# --- end of the README's Python examples ----------------------------------------------
