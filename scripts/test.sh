#!/usr/bin/env bash
# The whole test suite: installs Gmsh 4.15.2 with pip when it is missing (the
# end-to-end tests run Gmsh and its Python module), then `cargo test --release`, then the
# Python package's tests (scikit-fem's solver round trips among them) and DOLFINx's
# (python/tests/test_dolfinx.py, in a venv of its own on a Python >= 3.12).
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
    "$venv/bin/python" -m pip install -q --disable-pip-version-check numpy pytest meshio scikit-fem "gmsh==4.15.2"
    CARGO_TARGET_DIR="$PWD/target/python" "$venv/bin/python" -m pip install -q --disable-pip-version-check ./python
    PATH="$PWD/$venv/bin:$PATH" "$venv/bin/python" -m pytest -q -rs python/tests \
        --ignore=python/tests/test_dolfinx.py

    # DOLFINx reading and solving on the output (python/tests/test_dolfinx.py): its wheel,
    # dolfinx-solver-real, needs Python >= 3.12, so it gets a venv of its own. Without such
    # a Python (or when the install fails) the tests are skipped, saying why; under CI
    # (CI=true) that is a failure.
    solver_skip() {
        echo "scripts/test.sh: DOLFINx tests skipped: $1" >&2
        if [ "${CI:-}" = "true" ]; then
            echo "scripts/test.sh: CI must run them: failing" >&2
            exit 1
        fi
    }
    py312=""
    for py in "${BLOSSOMQUAD_PYTHON312:-}" python3.14 python3.13 python3.12 \
        "$(pyenv root 2>/dev/null || echo "$HOME/.pyenv")"/versions/3.1[2-9]*/bin/python3; do
        if [ -n "$py" ] && command -v "$py" >/dev/null 2>&1 &&
            "$py" -c 'import sys; sys.exit(sys.version_info < (3, 12))' 2>/dev/null; then
            py312=$(command -v "$py")
            break
        fi
    done
    if [ -z "$py312" ]; then
        solver_skip "no Python >= 3.12 found (set BLOSSOMQUAD_PYTHON312 to one)"
    else
        dvenv=target/dolfinx-venv
        if [ ! -x "$dvenv/bin/python" ]; then
            "$py312" -m venv "$dvenv"
        fi
        if "$dvenv/bin/python" -m pip install -q --disable-pip-version-check dolfinx-solver-real \
            numpy pytest meshio scikit-fem "gmsh==4.15.2" &&
            CARGO_TARGET_DIR="$PWD/target/python" "$dvenv/bin/python" -m pip install -q \
                --disable-pip-version-check ./python; then
            LD_LIBRARY_PATH="$PWD/$dvenv/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}" \
                PATH="$PWD/$dvenv/bin:$PATH" "$dvenv/bin/python" -m pytest -q -rs \
                python/tests/test_dolfinx.py
        else
            solver_skip "pip could not install dolfinx-solver-real into $dvenv (Python $py312)"
        fi
    fi
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
