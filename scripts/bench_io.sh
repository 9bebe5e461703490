#!/usr/bin/env bash
# MSH I/O benchmark: generates a ~1e6-triangle rectangle mesh with Gmsh (MSH 4.1 ASCII and
# binary, plus MSH 2.2 ASCII and binary), then times blossomquad's read + write next to
# `gmsh IN.msh -0 -o OUT.msh` on the same files, in one run.
# Usage: scripts/bench_io.sh [WORKDIR]   (default: target/bench-io; meshes are reused)
set -euo pipefail
cd "$(dirname "$0")/.."
dir="${1:-${CARGO_TARGET_DIR:-target}/bench-io}"
mkdir -p "$dir"
geo="$dir/rect.geo"
cat > "$geo" <<'GEO'
// 2 x 1 rectangle, ~1e6 triangles
Point(1) = {0, 0, 0}; Point(2) = {2, 0, 0}; Point(3) = {2, 1, 0}; Point(4) = {0, 1, 0};
Line(1) = {1, 2}; Line(2) = {2, 3}; Line(3) = {3, 4}; Line(4) = {4, 1};
Curve Loop(1) = {1, 2, 3, 4}; Plane Surface(1) = {1};
Physical Surface("domain") = {1};
Physical Curve("boundary") = {1, 2, 3, 4};
Mesh.MeshSizeMax = 0.00205;
Mesh.MeshSizeMin = 0.00205;
Mesh.Algorithm = 5;
GEO
if [ ! -s "$dir/rect41.msh" ]; then
  gmsh "$geo" -2 -format msh41 -o "$dir/rect41.msh" > "$dir/gmsh-mesh.log"
fi
[ -s "$dir/rect41b.msh" ] || gmsh "$dir/rect41.msh" -0 -format msh41 -bin -o "$dir/rect41b.msh" > /dev/null
[ -s "$dir/rect22.msh" ] || gmsh "$dir/rect41.msh" -0 -format msh22 -o "$dir/rect22.msh" > /dev/null
[ -s "$dir/rect22b.msh" ] || gmsh "$dir/rect41.msh" -0 -format msh22 -bin -o "$dir/rect22b.msh" > /dev/null
cargo run --release --quiet --example io_bench -- \
  "$dir/rect41.msh" "$dir/rect41b.msh" "$dir/rect22.msh" "$dir/rect22b.msh"
