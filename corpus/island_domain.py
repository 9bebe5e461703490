#!/usr/bin/env python3
"""Ocean-like planar domain with many small polygonal islands (paper section 8.4).

A rectangle holding about 60 random, non-overlapping polygonal islands of 5 to 11
vertices each (star-shaped about a centre, so simple; random radii give short edges
and sharp corners), meshed with triangles by Gmsh (`gmsh -2` equivalent) under a
distance-based size field: small near the islands, large far from them.

Usage:
  island_domain.py OUT.msh [--size S] [--seed N] [--islands K] [--min-radius R]
             [--format 41|22] [--binary]

`--size` scales every target size; the triangle count grows like 1 / size^2:
  --size 1      about 1.3e4 triangles
  --size 0.31   about 1.1e5 triangles
The same seed gives the same geometry at every size. MSH 4.1 ASCII by default.
Physical groups: the water surface ("water", 1), the outer boundary ("coast", 1) and
every island boundary ("islands", 2), so MSH 2.2 output keeps its line elements.
"""

import argparse
import math
import random
import sys

try:
    import gmsh
except ImportError:
    print("the gmsh Python module is needed (pip install gmsh)", file=sys.stderr)
    sys.exit(2)

WIDTH = 10.0
HEIGHT = 6.0


def make_islands(rng, count, min_radius):
    """Up to `count` islands: lists of (x, y) vertices, counter-clockwise."""
    islands = []
    discs = []  # (cx, cy, r) bounding discs, kept apart
    tries = 0
    while len(islands) < count and tries < 200 * count:
        tries += 1
        r = rng.uniform(0.12, 0.32)
        margin = 0.15
        cx = rng.uniform(r + margin, WIDTH - r - margin)
        cy = rng.uniform(r + margin, HEIGHT - r - margin)
        if any(math.hypot(cx - x, cy - y) < r + s + margin for x, y, s in discs):
            continue
        n = rng.randint(5, 11)
        # random angles, sorted, every gap below pi (star-shaped about the centre, so
        # the polygon is simple); some gaps are small (short edges), radii vary (sharp
        # corners)
        angles = sorted(rng.uniform(0.0, 2.0 * math.pi) for _ in range(n))
        gaps = [(angles[(k + 1) % n] - angles[k]) % (2.0 * math.pi) for k in range(n)]
        if min(gaps) < 0.05 or max(gaps) > 0.8 * math.pi:
            continue
        pts = []
        for a in angles:
            rad = r * rng.uniform(min_radius, 1.0)
            pts.append((cx + rad * math.cos(a), cy + rad * math.sin(a)))
        discs.append((cx, cy, r))
        islands.append(pts)
    return islands


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("out", help="output .msh path")
    ap.add_argument("--size", type=float, default=1.0, help="size factor (1: ~1e4 triangles)")
    ap.add_argument("--seed", type=int, default=11, help="random seed of the geometry")
    ap.add_argument("--islands", type=int, default=60, help="number of islands")
    ap.add_argument(
        "--min-radius",
        type=float,
        default=0.35,
        help="smallest vertex radius relative to the island's (lower: sharper corners; 0.15 "
        "gives the hostile variant that found most optimizer defects)",
    )
    ap.add_argument("--format", choices=["41", "22"], default="41", help="MSH version")
    ap.add_argument("--binary", action="store_true", help="binary MSH")
    args = ap.parse_args()
    if not (args.size > 0.0 and math.isfinite(args.size)):
        print("--size must be a positive number", file=sys.stderr)
        return 2

    rng = random.Random(args.seed)
    if not 0.05 <= args.min_radius <= 1.0:
        print("--min-radius must be between 0.05 and 1", file=sys.stderr)
        return 2
    islands = make_islands(rng, args.islands, args.min_radius)

    gmsh.initialize(["-noenv"])
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("islands")
        geo = gmsh.model.geo
        corners = [(0, 0), (WIDTH, 0), (WIDTH, HEIGHT), (0, HEIGHT)]
        outer_pts = [geo.addPoint(x, y, 0) for x, y in corners]
        outer_lines = [geo.addLine(outer_pts[k], outer_pts[(k + 1) % 4]) for k in range(4)]
        loops = [geo.addCurveLoop(outer_lines)]
        island_lines = []
        for pts in islands:
            tags = [geo.addPoint(x, y, 0) for x, y in pts]
            lines = [geo.addLine(tags[k], tags[(k + 1) % len(tags)]) for k in range(len(tags))]
            island_lines.extend(lines)
            loops.append(geo.addCurveLoop(lines))
        surface = geo.addPlaneSurface(loops)
        geo.synchronize()
        gmsh.model.addPhysicalGroup(2, [surface], 1, "water")
        gmsh.model.addPhysicalGroup(1, outer_lines, 1, "coast")
        gmsh.model.addPhysicalGroup(1, island_lines, 2, "islands")

        s = args.size
        field = gmsh.model.mesh.field
        dist = field.add("Distance")
        field.setNumbers(dist, "CurvesList", island_lines)
        field.setNumber(dist, "Sampling", 40)
        thr = field.add("Threshold")
        field.setNumber(thr, "InField", dist)
        field.setNumber(thr, "SizeMin", 0.07 * s)
        field.setNumber(thr, "SizeMax", 0.35 * s)
        field.setNumber(thr, "DistMin", 0.05)
        field.setNumber(thr, "DistMax", 1.2)
        field.setAsBackgroundMesh(thr)
        gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 0)
        gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)
        gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)
        gmsh.model.mesh.generate(2)
        gmsh.option.setNumber("Mesh.MshFileVersion", 4.1 if args.format == "41" else 2.2)
        gmsh.option.setNumber("Mesh.Binary", 1 if args.binary else 0)
        gmsh.write(args.out)
        types, tags, _ = gmsh.model.mesh.getElements(2)
        triangles = sum(len(t) for ty, t in zip(types, tags) if ty == 2)
        print(f"{len(islands)} islands, {triangles} triangles -> {args.out}")
    finally:
        gmsh.finalize()
    return 0


if __name__ == "__main__":
    sys.exit(main())
