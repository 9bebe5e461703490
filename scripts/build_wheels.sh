#!/usr/bin/env bash
# Builds the Python package (python/) for release into target/wheels/: the Linux x86_64
# wheel (manylinux2014, abi3: one wheel for every CPython >= 3.9) and the sdist. maturin
# and zig (which links against manylinux2014's old glibc) come from pip, in a venv under
# target/. The Rust build goes to target/python, the directory scripts/test.sh builds the
# package in, so a run after the test suite recompiles little. Other platforms' wheels
# come from .github/workflows/release.yml.
set -euo pipefail
cd "$(dirname "$0")/.."

venv=target/build-venv
if [ ! -x "$venv/bin/python" ]; then
    python3 -m venv "$venv"
fi
"$venv/bin/python" -m pip install -q --disable-pip-version-check "maturin>=1.5,<2" ziglang

out="$PWD/target/wheels"
rm -rf "$out"
mkdir -p "$out"
export CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$PWD/target/python}"
export PATH="$PWD/$venv/bin:$PATH"
(
    cd python
    maturin build --release --zig --compatibility manylinux2014 --out "$out"
    maturin sdist --out "$out"
)
ls -l "$out"
