"""Seeded random CAD shapes shared by corpus models (see corpus/README.md).

Each function builds its geometry in the current Gmsh model with the OpenCASCADE
kernel, from a seeded random generator, so a model file fixes the seed and every run
builds the same shape.
"""

import math
import random

import gmsh


def polygon(occ, rng, cx, cy, r, k):
    """A star-shaped polygon of k vertices about (cx, cy) with radii in [0.45 r, r]: a
    plane surface tag."""
    step = 2 * math.pi / k
    base = rng.uniform(0, 2 * math.pi)
    angles = [base + step * (i + rng.uniform(-0.3, 0.3)) for i in range(k)]
    pts = [occ.addPoint(cx + r * rng.uniform(0.45, 1.0) * math.cos(a),
                        cy + r * rng.uniform(0.45, 1.0) * math.sin(a), 0) for a in angles]
    lines = [occ.addLine(pts[i], pts[(i + 1) % k]) for i in range(k)]
    return occ.addPlaneSurface([occ.addCurveLoop(lines)])


def plate_with_holes(seed, holes=3, rectangles=3, width=4.0, height=2.5):
    """A flat plate with `holes` random polygonal holes (4 to 7 vertices), fragmented by
    `rectangles` random rectangles; returns the surface tags."""
    rng = random.Random(seed)
    occ = gmsh.model.occ
    plate = occ.addRectangle(0, 0, 0, width, height)
    placed = []
    cut = []
    while len(cut) < holes:
        r = rng.uniform(0.25, 0.5)
        cx, cy = rng.uniform(r + 0.1, width - r - 0.1), rng.uniform(r + 0.1, height - r - 0.1)
        if all(math.hypot(cx - x, cy - y) > r + q + 0.1 for x, y, q in placed):
            placed.append((cx, cy, r))
            cut.append((2, polygon(occ, rng, cx, cy, r, rng.randint(4, 7))))
    rest, _ = occ.cut([(2, plate)], cut)
    tools = []
    for _ in range(rectangles):
        w, h = rng.uniform(0.6, 2.0), rng.uniform(0.4, 1.4)
        x, y = rng.uniform(0, width - w), rng.uniform(0, height - h)
        tools.append((2, occ.addRectangle(x, y, 0, w, h)))
    out = occ.fragment(rest, tools)[0] if tools else rest
    occ.synchronize()
    # keep only the faces covering the plate (drop rectangle parts inside holes)
    keep = []
    for dim, tag in out:
        x, y, _ = occ.getCenterOfMass(dim, tag)
        inside = False
        for cx, cy, r in placed:
            if math.hypot(x - cx, y - cy) < 0.45 * r:
                inside = True
        if inside:
            occ.remove([(dim, tag)], recursive=True)
        else:
            keep.append(tag)
    occ.synchronize()
    return keep


def filleted_box(seed, edges=5):
    """A box of random proportions with `edges` of its twelve edges, chosen at random,
    filleted with one random radius; returns the surface tags."""
    rng = random.Random(seed)
    occ = gmsh.model.occ
    dx, dy, dz = rng.uniform(1, 3), rng.uniform(0.8, 2), rng.uniform(0.5, 1.5)
    box = occ.addBox(0, 0, 0, dx, dy, dz)
    occ.synchronize()
    curves = [t for _, t in gmsh.model.getBoundary([(3, box)], combined=False, oriented=False, recursive=False)]
    curves = sorted({abs(c) for _, c in gmsh.model.getBoundary(
        [(2, s) for s in curves], combined=False, oriented=False)})
    chosen = rng.sample(curves, edges)
    radius = rng.uniform(0.08, 0.3) * min(dx, dy, dz)
    occ.fillet([box], chosen, [radius])
    occ.synchronize()
    return [t for _, t in gmsh.model.getEntities(2)]


def cylinders(seed, count=3):
    """`count` cylinders of random radius, height and axis tilt fused with a base slab;
    returns the surface tags."""
    rng = random.Random(seed)
    occ = gmsh.model.occ
    parts = []
    for i in range(count):
        r = rng.uniform(0.2, 0.6)
        h = rng.uniform(0.3, 2.5)
        tilt = rng.uniform(-0.3, 0.3)
        parts.append((3, occ.addCylinder(1.5 * i, 0, 0, tilt, 0, h, r)))
    slab = occ.addBox(-0.8, -0.8, -0.2, 1.5 * count + 0.1, 1.6, 0.2)
    occ.fuse([(3, slab)], parts)
    occ.synchronize()
    return [t for _, t in gmsh.model.getEntities(2)]


def thin_pins(seed, count=6):
    """A slab with `count` thin cylindrical pins (radius 0.02 to 0.08, random height and
    tilt) fused on it; returns the surface tags."""
    rng = random.Random(seed)
    occ = gmsh.model.occ
    pins = []
    for i in range(count):
        r = rng.uniform(0.02, 0.08)
        h = rng.uniform(0.5, 2.0)
        pins.append((3, occ.addCylinder(0.4 * i + 0.2, rng.uniform(0.2, 0.8), 0,
                                        rng.uniform(-0.3, 0.3), rng.uniform(-0.3, 0.3), h, r)))
    slab = occ.addBox(0, 0, -0.2, 0.4 * count, 1, 0.2)
    occ.fuse([(3, slab)], pins)
    occ.synchronize()
    return [t for _, t in gmsh.model.getEntities(2)]


def island_domain(seed, size, coast_ratio=6.0, count=60, width=200.0, height=120.0):
    """The ocean-like island domain: a `width` x `height` rectangle with `count` random
    non-overlapping polygonal islands of 5 to 11 vertices (some with a very short edge),
    meshed with a distance-based size field: `size / coast_ratio` at the coasts, `size`
    in open sea. Returns the sea's surface tag."""
    rng = random.Random(seed)
    islands = []  # (cx, cy, r)
    tries = 0
    while len(islands) < count and tries < 100000:
        tries += 1
        r = rng.uniform(1.5, 6.0)
        cx, cy = rng.uniform(r + 2, width - r - 2), rng.uniform(r + 2, height - r - 2)
        if all(math.hypot(cx - x, cy - y) > r + q + 1.0 for x, y, q in islands):
            islands.append((cx, cy, r))
    geo = gmsh.model.geo
    corners = [geo.addPoint(0, 0, 0), geo.addPoint(width, 0, 0), geo.addPoint(width, height, 0),
               geo.addPoint(0, height, 0)]
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
    field.setNumber(thr, "SizeMin", size / coast_ratio)
    field.setNumber(thr, "SizeMax", size)
    field.setNumber(thr, "DistMin", 0.5)
    field.setNumber(thr, "DistMax", 8 * size)
    field.setAsBackgroundMesh(thr)
    gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)
    gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 0)
    gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)
    return sea


def periodic_prism(seed, holes=3, height=0.6):
    """A prism: a plate with `holes` random polygonal holes (`plate_with_holes` without the
    fragmenting rectangles) extruded by `height`, its top face periodic with its bottom
    face (a translation along z, set with gmsh.model.mesh.setPeriodic); returns the
    surface tags."""
    faces = plate_with_holes(seed, holes=holes, rectangles=0, width=3.0, height=2.0)
    occ = gmsh.model.occ
    occ.extrude([(2, f) for f in faces], 0, 0, height)
    occ.synchronize()
    eps = 1e-3
    bottom = [t for _, t in gmsh.model.getEntitiesInBoundingBox(-eps, -eps, -eps, 3 + eps, 2 + eps, eps, 2)]
    top = [t for _, t in gmsh.model.getEntitiesInBoundingBox(-eps, -eps, height - eps, 3 + eps, 2 + eps,
                                                              height + eps, 2)]
    affine = [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, height, 0, 0, 0, 1]
    gmsh.model.mesh.setPeriodic(2, top, bottom, affine)
    return [t for _, t in gmsh.model.getEntities(2)]
