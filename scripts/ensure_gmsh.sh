# Sourced by scripts/test.sh and scripts/bench_vs_gmsh.sh: makes sure Gmsh 4.15.2
# is usable (the `gmsh` executable on PATH and the `gmsh` Python module),
# installing it with pip when it is missing. Exports PATH.

GMSH_VERSION=4.15.2
PYTHON=${PYTHON:-python3}

have_gmsh() {
    command -v gmsh >/dev/null 2>&1 &&
        gmsh --version >/dev/null 2>&1 &&
        "$PYTHON" -c 'import gmsh' >/dev/null 2>&1
}

# pip puts the `gmsh` launcher in the user base's bin (~/.local/bin) or in the
# interpreter's scripts directory (pyenv, venv); pyenv also needs its shims
# rehashed. Put all of them on PATH.
add_pip_bins_to_path() {
    local user_bin scripts_bin
    user_bin="$("$PYTHON" -m site --user-base 2>/dev/null)/bin" || true
    scripts_bin="$("$PYTHON" -c 'import sysconfig; print(sysconfig.get_path("scripts"))' 2>/dev/null)" || true
    for dir in "$user_bin" "$scripts_bin"; do
        if [ -n "$dir" ] && [ -d "$dir" ]; then
            PATH="$dir:$PATH"
        fi
    done
    if command -v pyenv >/dev/null 2>&1; then
        pyenv rehash >/dev/null 2>&1 || true
    fi
    export PATH
}

if ! have_gmsh; then
    add_pip_bins_to_path
fi
if ! have_gmsh; then
    echo "${0##*/}: installing gmsh==$GMSH_VERSION with pip" >&2
    "$PYTHON" -m pip install --quiet "gmsh==$GMSH_VERSION" ||
        "$PYTHON" -m pip install --quiet --user "gmsh==$GMSH_VERSION" ||
        "$PYTHON" -m pip install --quiet --user --break-system-packages "gmsh==$GMSH_VERSION"
    add_pip_bins_to_path
fi
if ! have_gmsh; then
    echo "${0##*/}: gmsh $GMSH_VERSION is not usable after installing it:" \
        "need \`gmsh\` on PATH and \`$PYTHON -c 'import gmsh'\` to work" >&2
    exit 1
fi
