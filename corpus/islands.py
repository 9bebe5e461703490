"""Ocean-like island domain (the paper's section 8.4 use): a planar rectangle with about
60 random non-overlapping polygonal islands of 5 to 11 vertices, some with very short
edges and sharp corners, meshed with a distance-based size field (fine near the coasts).

    python3 corpus/islands.py SIZE OUTPUT.msh [Option.Name=VALUE ...]

SIZE is the open-sea mesh size: 12 gives about 1e4 triangles, 2.2 about 1e5. The islands
come from a seeded RNG (seed 11), so every run builds the same domain.
"""

import math
import random

import gmsh

import _model

size, output, tmp = _model.start("islands")
rng = random.Random(11)
W, H = 200.0, 120.0
islands = []  # (cx, cy, r)
tries = 0
while len(islands) < 60 and tries < 100000:
    tries += 1
    r = rng.uniform(1.5, 6.0)
    cx, cy = rng.uniform(r + 2, W - r - 2), rng.uniform(r + 2, H - r - 2)
    if all(math.hypot(cx - x, cy - y) > r + q + 1.0 for x, y, q in islands):
        islands.append((cx, cy, r))

geo = gmsh.model.geo
corners = [geo.addPoint(0, 0, 0), geo.addPoint(W, 0, 0), geo.addPoint(W, H, 0), geo.addPoint(0, H, 0)]
outer = [geo.addLine(corners[i], corners[(i + 1) % 4]) for i in range(4)]
loops = [geo.addCurveLoop(outer)]
coast = []
for cx, cy, r in islands:
    k = rng.randint(5, 11)
    # jittered even angles: sorted, every gap below pi, so the polygon is simple
    step = 2 * math.pi / k
    base = rng.uniform(0, 2 * math.pi)
    angles = [base + step * (i + rng.uniform(-0.3, 0.3)) for i in range(k)]
    radii = [r * rng.uniform(0.35, 1.0) for _ in angles]
    if rng.random() < 0.4:  # a deliberately tiny edge next to long ones
        j = rng.randrange(k)
        angles.insert(j + 1, angles[j] + 0.004)
        radii.insert(j + 1, radii[j] * 1.002)
    pts = [geo.addPoint(cx + q * math.cos(a), cy + q * math.sin(a), 0) for a, q in zip(angles, radii)]
    lines = [geo.addLine(pts[i], pts[(i + 1) % len(pts)]) for i in range(len(pts))]
    coast += lines
    loops.append(geo.addCurveLoop(lines))
sea = geo.addPlaneSurface(loops)
geo.synchronize()

field = gmsh.model.mesh.field
dist = field.add("Distance")
field.setNumbers(dist, "CurvesList", coast)
field.setNumber(dist, "Sampling", 20)
thr = field.add("Threshold")
field.setNumber(thr, "InField", dist)
field.setNumber(thr, "SizeMin", size / 6)
field.setNumber(thr, "SizeMax", size)
field.setNumber(thr, "DistMin", 0.5)
field.setNumber(thr, "DistMax", 8 * size)
field.setAsBackgroundMesh(thr)
gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)
gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 0)
gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)
gmsh.model.addPhysicalGroup(2, [sea], name="ocean")
_model.finish(output, tmp)
