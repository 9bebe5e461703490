#!/usr/bin/env bash
# Benchmark (not a test): the paper's Table I (section 8.1, square with a hole) for
# blossomquad at h, 2h + one uniform refinement and 4h + two (`--refine N`), next to
# Gmsh's blossom from the CAD at h and Gmsh's blossom full-quad (which meshes coarser,
# recombines and subdivides). Every row is measured by `blossomquad quality` with the
# size field of the triangle mesh at h. Prints a Markdown table.
# Usage: scripts/table1.sh [SIZE]   (SIZE = the .geo's size parameter for h;
#                                    default 0.850435 = sqrt(72324 / 1e5), 99,362 triangles as in the paper)
set -euo pipefail
cd "$(dirname "$0")/.."
# shellcheck source=scripts/ensure_gmsh.sh
source scripts/ensure_gmsh.sh
cargo build --release --quiet
bin="${CARGO_TARGET_DIR:-target}/release/blossomquad"
size=${1:-0.850435}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
geo=geo/square_hole.geo

row() { # label h_algo quads.msh seconds
    "$bin" quality "$3" --reference "$work/h.msh" --json | "$PYTHON" -c '
import json, sys
t = json.load(sys.stdin)["total"]
print("| %s | %s | %.3f | %.3f | %.1f | %d | %d | %.1f %% | %s s |" % (sys.argv[1], sys.argv[2],
      t["eta_worst"], t["eta_mean"], t["d4_percent"], t["d_min"], t["d_max"], t["tau_percent"], sys.argv[3]))
' "$1" "$2" "$4"
}
timed() { # command...: runs the command, prints its wall time in seconds
    local s e
    s=$(date +%s.%N); "$@" >/dev/null 2>&1; e=$(date +%s.%N)
    "$PYTHON" -c "print('%.2f' % ($e - $s))"
}

for k in 1 2 4; do
    s=$("$PYTHON" -c "print(repr($size * $k))")
    gmsh -2 "$geo" -setnumber size "$s" -format msh41 -bin -o "$work/t$k.msh" >/dev/null
done
cp "$work/t1.msh" "$work/h.msh"
echo "| algorithm | h_algo | η_w | η̄ | d4 % | d_min | d_max | τ | time |"
echo "|---|---|---|---|---|---|---|---|---|"
t=$(timed gmsh -2 "$geo" -setnumber size "$size" -setnumber Mesh.RecombineAll 1 \
    -setnumber Mesh.RecombinationAlgorithm 1 -format msh41 -bin -o "$work/g1.msh")
row "Gmsh $GMSH_VERSION blossom from CAD (whole run)" h "$work/g1.msh" "$t"
t=$(timed gmsh -2 "$geo" -setnumber size "$size" -setnumber Mesh.RecombineAll 1 \
    -setnumber Mesh.RecombinationAlgorithm 3 -format msh41 -bin -o "$work/g3.msh")
row "Gmsh $GMSH_VERSION blossom full-quad from CAD (whole run)" "2h, subdivided" "$work/g3.msh" "$t"
for n in 0 1 2; do
    k=$((1 << n))
    t=$(timed "$bin" "$work/t$k.msh" -o "$work/q$n.msh" --refine "$n" --quiet)
    label=$([ "$n" = 0 ] && echo h || echo "${k}h, refined $n×")
    row "blossomquad --refine $n" "$label" "$work/q$n.msh" "$t"
done
