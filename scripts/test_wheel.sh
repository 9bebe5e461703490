#!/usr/bin/env bash
# The Python package as a user installs it: builds the release wheel and sdist
# (scripts/build_wheels.sh), installs the wheel into a fresh venv (target/wheel-venv)
# with no Rust toolchain on PATH, checks that the module comes from the wheel, and runs
# the package's tests on it (python/tests, less the DOLFINx ones, which scripts/test.sh
# runs in a venv of their own). Also checks that the sdist holds what the build needs and
# nothing of the repository's tests, corpus or scripts.
set -euo pipefail
cd "$(dirname "$0")/.."

bash scripts/build_wheels.sh
wheel=$(ls target/wheels/blossomquad-*-manylinux*.whl)
sdist=$(ls target/wheels/blossomquad-*.tar.gz)

# the sdist: licences and sources in, the repository's test data and tools out
listing=$(tar tzf "$sdist")
for needed in LICENSE-MIT LICENSE-APACHE pyproject.toml Cargo.lock python/src/lib.rs \
    blossomquad/gmsh_gui.py src/lib.rs; do
    if ! grep -q "^blossomquad-[^/]*/$needed\$" <<<"$listing"; then
        echo "scripts/test_wheel.sh: $sdist lacks $needed" >&2
        exit 1
    fi
done
if grep -E "^blossomquad-[^/]*/(tests|corpus|scripts|fuzz|geo|examples|python/tests|target)/" \
    <<<"$listing"; then
    echo "scripts/test_wheel.sh: $sdist holds the files above, which the build does not need" >&2
    exit 1
fi

# a PATH without cargo, rustc or rustup
no_rust=$(tr ':' '\n' <<<"$PATH" | grep -v -e '/\.cargo/bin$' -e '/\.rustup' | paste -sd: -)
venv=target/wheel-venv
rm -rf "$venv"
PATH="$no_rust" python3 -m venv "$venv"
export PATH="$PWD/$venv/bin:$no_rust"
if command -v cargo >/dev/null 2>&1 || command -v rustc >/dev/null 2>&1; then
    echo "scripts/test_wheel.sh: a Rust toolchain is still on PATH ($(command -v cargo rustc))" >&2
    exit 1
fi
python -m pip install -q --disable-pip-version-check "$wheel" numpy pytest meshio scikit-fem \
    "gmsh==4.15.2"
origin=$(cd /tmp && python -c 'import blossomquad; print(blossomquad.__file__)')
case "$origin" in
    "$PWD/$venv/"*) ;;
    *)
        echo "scripts/test_wheel.sh: blossomquad imported from $origin, not the wheel" >&2
        exit 1
        ;;
esac
python -m pytest -q -rs python/tests --ignore=python/tests/test_dolfinx.py
