#!/usr/bin/env python3
"""Independent invariant checker for blossomquad outputs.

Usage: check_mesh.py INPUT.msh OUTPUT.msh [--allow-dropped-volumes] [--allow-triangles] [--refined=N]

INPUT is the triangle mesh given to blossomquad, OUTPUT its result. Both are read
with Gmsh's own reader (the `gmsh` Python module); nothing here uses blossomquad's
code. Checks (names as in the JSON report):

  loads             Gmsh opens OUTPUT without an `Error` message.
  entities          OUTPUT has the same entities as INPUT (dimensions 0-2, and 3
                    unless volumes may be dropped); for an MSH 2 OUTPUT of a 4.1
                    INPUT, the entities that carry elements.
  physical_groups   identical (dim, tag, name, entities).
  no_triangles      no triangle is left on any surface.
  faces_valid       every quad has 4 distinct nodes that exist.
  conformity        per surface, every edge is used by at most two faces.
  boundary          per surface, the edges used once are the input surface's
                    boundary edges, each either kept or split in two by exactly
                    one new node lying on the segment (parity repair); with
                    --refined=N (N uniform refinements), split into a chain of
                    2^N (2^(N+1) after a parity split) pieces whose new nodes lie
                    within a tenth of the segment's length of it (new curve nodes
                    follow the curve).
  curve_edges       every input line element (1D) survives, kept or split the
                    same way; every input segment inside a surface (embedded
                    curve) is still an edge used twice there.
  fixed_nodes       nodes on curves and points, and nodes on surface boundaries,
                    keep their tag and coordinates.
  node_tags         every input node tag is still present, except nodes
                    classified on a surface (removed by doublet collapse or
                    quad-vertex merge) or, with --allow-dropped-volumes, on a volume.
  area              planar surfaces (all nodes on one plane) keep their total
                    signed area to 1e-9 relative (quads counted as two triangles;
                    with --refined, new curve nodes follow curved curves: the area
                    may change by up to 0.1 L^2 per input boundary segment of
                    length L).
  orientation       every quad is oriented like the input triangles of its
                    surface: on a planar surface its normal agrees with the
                    input's average normal; on a curved surface with the normal
                    of the nearest input triangle.

Prints one JSON line and exits 0 when every check passes, 1 on any violation,
2 on usage errors or when INPUT cannot be read.
"""

import json


def _plain(o):
    """JSON fallback for numpy values (the gmsh module returns numpy arrays when numpy is installed)."""
    if hasattr(o, "tolist"):
        return o.tolist()
    if hasattr(o, "item"):
        return o.item()
    return str(o)


def _dumps(obj, **kw):
    return json.dumps(obj, default=_plain, **kw)


import math
import sys

try:
    import gmsh
except ImportError:  # pragma: no cover - reported as a usage problem
    print(_dumps({"ok": False, "error": "python module gmsh not found (pip install gmsh==4.15.2)"}))
    sys.exit(2)

TRIANGLE_TYPES = {2, 9, 20, 21, 22, 23, 24, 25}
QUAD_TYPES = {3, 10, 16, 36, 37, 38, 47, 48, 49, 50, 51}
VOLUME_TYPES = {4, 5, 6, 7, 11, 12, 13, 14, 17, 18, 19, 29, 30, 31, 92, 93}
MAX_REPORTED = 20


class Mesh:
    """The parts of a mesh the checks need, copied out of Gmsh's model."""

    def __init__(self):
        self.nodes = {}  # tag -> (x, y, z)
        self.node_dim = {}  # tag -> dimension of the classifying entity
        self.entities = set()
        self.physicals = []
        self.faces = {}  # surface tag -> list of (type, node tuple), duplicates removed
        self.lines = {}  # curve tag -> list of (a, b) corner segments
        self.volume_elements = 0
        self.with_elements = set()  # entities that carry elements
        self.msh2 = False
        self.errors = []


def _dedup(elements):
    seen = set()
    out = []
    for e in elements:
        key = tuple(sorted(e[1]))
        if key not in seen:
            seen.add(key)
            out.append(e)
    return out


def plain(values):
    """A list of Python numbers (the gmsh module returns numpy arrays when numpy
    is installed, lists otherwise)."""
    return values.tolist() if hasattr(values, "tolist") else list(values)


def is_msh2(path):
    """True when the file's $MeshFormat says version 2.x."""
    with open(path, "rb") as f:
        head = f.read(4096)
    at = head.find(b"$MeshFormat")
    return at >= 0 and head[at + len(b"$MeshFormat"):].lstrip().startswith(b"2")


def load(path):
    """Reads PATH with Gmsh; returns a Mesh (with .errors filled on failure)."""
    mesh = Mesh()
    gmsh.clear()
    gmsh.logger.start()
    try:
        gmsh.open(path)
    except Exception as exc:  # Gmsh raises on hard errors
        mesh.errors.append(str(exc))
    log = gmsh.logger.get()
    gmsh.logger.stop()
    mesh.errors += [line for line in log if line.startswith("Error")]
    if mesh.errors:
        return mesh
    for dim, tag in gmsh.model.getEntities():
        mesh.entities.add((dim, tag))
        tags, coords, _ = gmsh.model.mesh.getNodes(dim, tag, False, False)
        tags, coords = plain(tags), plain(coords)
        for i, t in enumerate(tags):
            t = int(t)
            mesh.nodes[t] = (coords[3 * i], coords[3 * i + 1], coords[3 * i + 2])
            mesh.node_dim.setdefault(t, dim)
            mesh.node_dim[t] = min(mesh.node_dim[t], dim)
        types, _, node_tags = gmsh.model.mesh.getElements(dim, tag)
        types, node_tags = plain(types), [plain(n) for n in node_tags]
        if len(types) > 0:
            mesh.with_elements.add((dim, tag))
        for etype, conn in zip(types, node_tags):
            _, edim, _, nnodes, _, ncorner = gmsh.model.mesh.getElementProperties(etype)
            conn = [int(n) for n in conn]
            elements = [tuple(conn[i:i + nnodes][:ncorner]) for i in range(0, len(conn), nnodes)]
            if dim == 2 and (etype in TRIANGLE_TYPES or etype in QUAD_TYPES):
                mesh.faces.setdefault(tag, []).extend((etype, e) for e in elements)
            elif dim == 1 and edim == 1:
                mesh.lines.setdefault(tag, []).extend((e[0], e[1]) for e in elements)
            if etype in VOLUME_TYPES:
                mesh.volume_elements += len(elements)
    mesh.msh2 = is_msh2(path)
    if mesh.msh2:
        # MSH 2 writes an element once per physical group of its entity and Gmsh's
        # reader keeps the copies: merge them (only there, so that a duplicated
        # element in a 4.1 file still shows up as a conformity violation).
        for tag in mesh.faces:
            mesh.faces[tag] = _dedup(mesh.faces[tag])
        for tag in mesh.lines:
            mesh.lines[tag] = [tuple(e) for _, e in _dedup([(1, l) for l in mesh.lines[tag]])]
    for dim, tag in gmsh.model.getPhysicalGroups():
        ents = sorted(int(e) for e in gmsh.model.getEntitiesForPhysicalGroup(dim, tag))
        mesh.physicals.append((dim, tag, gmsh.model.getPhysicalName(dim, tag), ents))
    mesh.physicals.sort()
    return mesh


def sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def norm(a):
    return math.sqrt(dot(a, a))


def polygon_normal(points):
    """Newell's normal: twice the vector area of the polygon (sum of fan triangles)."""
    n = (0.0, 0.0, 0.0)
    for i in range(1, len(points) - 1):
        c = cross(sub(points[i], points[0]), sub(points[i + 1], points[0]))
        n = (n[0] + c[0], n[1] + c[1], n[2] + c[2])
    return n


def edges_of(face):
    k = len(face)
    return [(face[i], face[(i + 1) % k]) for i in range(k)]


def key(a, b):
    return (a, b) if a < b else (b, a)


def edge_uses(faces):
    uses = {}
    for _, f in faces:
        for a, b in edges_of(f):
            uses[key(a, b)] = uses.get(key(a, b), 0) + 1
    return uses


def on_segment(p, a, b, tol):
    """True when p lies strictly between a and b on the segment ab (within tol * |ab|)."""
    ab = sub(b, a)
    length = norm(ab)
    if length == 0.0:
        return False
    t = dot(sub(p, a), ab) / (length * length)
    off = norm(cross(sub(p, a), ab)) / length
    return 0.0 < t < 1.0 and off <= tol * length


class Report:
    def __init__(self):
        self.checks = {}
        self.violations = []

    def check(self, name, ok, message=None):
        ok = bool(ok)
        self.checks[name] = self.checks.get(name, True) and ok
        if not ok and message is not None and len(self.violations) < MAX_REPORTED:
            self.violations.append(f"{name}: {message}")


def match_split(expected, actual, inp, out, tol, refined=0):
    """Matches expected edges (from INPUT) against actual edges (of OUTPUT).

    Each expected edge must be in `actual`, or be split into a chain (a, m1), (m1, m2),
    ..., (mk, b) of nodes absent from INPUT lying on the segment: k = 1 (parity repair)
    without refinement; with `refined` uniform refinements, k + 1 = 2^refined pieces
    (2^(refined + 1) after a parity split) and the nodes may lie off the chord by up to a
    tenth of the segment (new curve nodes follow the curve). Returns (missing, extra, splits) where splits maps an expected edge key
    to the tuple of its chain's inner nodes.
    """
    actual = set(actual)
    used = set()
    missing = []
    splits = {}
    by_node = {}
    for e in actual:
        by_node.setdefault(e[0], []).append(e)
        by_node.setdefault(e[1], []).append(e)
    # pieces per segment: 2 (parity split); 2^N after N refinements, 2^(N+1) when the
    # segment was also split for parity
    pieces = {2} if refined == 0 else {2 ** refined, 2 ** (refined + 1)}
    max_inner = max(pieces) - 1
    band = tol if refined == 0 else 0.1

    def chain(a, b):
        if a not in out.nodes or b not in out.nodes:
            return None
        pa, pb = out.nodes[a], out.nodes[b]
        stack = [[a]]
        while stack:
            path = stack.pop()
            for e in by_node.get(path[-1], []):
                m = e[1] if e[0] == path[-1] else e[0]
                if m == b and len(path) in pieces:
                    return tuple(path[1:])
                if m in inp.nodes or m not in out.nodes or m in path or len(path) > max_inner:
                    continue
                if on_segment(out.nodes[m], pa, pb, band):
                    stack.append(path + [m])
        return None

    for e in expected:
        if e in actual:
            used.add(e)
            continue
        a, b = e
        found = chain(a, b)
        if found is None:
            missing.append(e)
        else:
            splits[e] = found
            nodes = (a,) + found + (b,)
            for x, y in zip(nodes, nodes[1:]):
                used.add(key(x, y))
    extra = sorted(actual - used)
    return missing, extra, splits


def scale_of(mesh):
    if not mesh.nodes:
        return 1.0
    lo = [min(p[i] for p in mesh.nodes.values()) for i in range(3)]
    hi = [max(p[i] for p in mesh.nodes.values()) for i in range(3)]
    return max(norm(sub(hi, lo)), 1e-300)


class NearestTriangle:
    """Uniform grid over triangle centroids for nearest-centroid queries."""

    def __init__(self, centroids, normals):
        self.centroids = centroids
        self.normals = normals
        lo = [min(c[i] for c in centroids) for i in range(3)]
        hi = [max(c[i] for c in centroids) for i in range(3)]
        extent = max(hi[i] - lo[i] for i in range(3)) or 1.0
        self.cell = extent / max(1.0, len(centroids) ** (1.0 / 3.0))
        self.lo = lo
        self.grid = {}
        for i, c in enumerate(centroids):
            self.grid.setdefault(self._cell(c), []).append(i)

    def _cell(self, p):
        return tuple(int(math.floor((p[i] - self.lo[i]) / self.cell)) for i in range(3))

    def nearest(self, p):
        cx, cy, cz = self._cell(p)
        best, best_d = None, float("inf")
        r = 0
        while True:
            for i in range(cx - r, cx + r + 1):
                for j in range(cy - r, cy + r + 1):
                    for k in range(cz - r, cz + r + 1):
                        if max(abs(i - cx), abs(j - cy), abs(k - cz)) != r:
                            continue
                        for t in self.grid.get((i, j, k), ()):
                            d = norm(sub(self.centroids[t], p))
                            if d < best_d:
                                best, best_d = t, d
            # Any centroid outside the searched cube is at least r * cell away.
            if best is not None and best_d <= r * self.cell:
                return best
            r += 1
            if r > 10000:
                return best


def check(inp, out, allow_dropped_volumes, allow_triangles, refined=0):
    rep = Report()
    scale = scale_of(inp)

    # Entities and physical groups.
    max_dim = 2 if allow_dropped_volumes else 3
    # MSH 2 stores no entities, only elements' elementary tags: when OUTPUT is
    # MSH 2 and INPUT is not, compare the entities that carry elements.
    relaxed = out.msh2 and not inp.msh2
    ein = {e for e in (inp.with_elements if relaxed else inp.entities) if e[0] <= max_dim}
    eout = {e for e in (out.with_elements if relaxed else out.entities) if e[0] <= max_dim}
    rep.check("entities", ein == eout,
              f"missing {sorted(ein - eout)[:5]}, extra {sorted(eout - ein)[:5]}")
    pin = [p for p in inp.physicals if p[0] <= max_dim and
           (not relaxed or any((p[0], e) in inp.with_elements for e in p[3]))]
    pout = [p for p in out.physicals if p[0] <= max_dim]
    rep.check("physical_groups", pin == pout, f"input {pin[:4]} output {pout[:4]}")
    if allow_dropped_volumes:
        rep.check("volumes_dropped", out.volume_elements == 0,
                  f"{out.volume_elements} volume elements left")

    # Fixed nodes: curve/point nodes and surface-boundary nodes keep tag and coordinates.
    fixed = {t for t, d in inp.node_dim.items() if d <= 1}
    for faces in inp.faces.values():
        for (a, b), n in edge_uses(faces).items():
            if n == 1:
                fixed.add(a)
                fixed.add(b)
    moved = 0
    for t in sorted(fixed):
        p = inp.nodes[t]
        q = out.nodes.get(t)
        if q is None or norm(sub(p, q)) > 1e-12 * scale:
            moved += 1
            rep.check("fixed_nodes", False, f"node {t} {p} -> {q}")
    rep.check("fixed_nodes", moved == 0)

    # Node tags: only surface (or dropped volume) nodes may disappear.
    removable = {2, 3} if allow_dropped_volumes else {2}
    lost = [t for t in inp.nodes if t not in out.nodes and inp.node_dim[t] not in removable]
    rep.check("node_tags", not lost, f"{len(lost)} non-surface nodes removed, e.g. {lost[:5]}")

    # Protected segments: every input line element, kept or split.
    all_splits = {}
    for curve, segs in inp.lines.items():
        expected = {key(a, b) for a, b in segs}
        actual = {key(a, b) for a, b in out.lines.get(curve, [])}
        missing, extra, splits = match_split(expected, actual, inp, out, 1e-6, refined)
        all_splits.update(splits)
        rep.check("curve_edges", not missing and not extra,
                  f"curve {curve}: {len(missing)} segments missing (e.g. {missing[:3]}), "
                  f"{len(extra)} unexpected (e.g. {extra[:3]})")

    line_segments = {key(a, b) for segs in inp.lines.values() for a, b in segs}
    quads = 0
    tris_left = 0
    for surface, in_faces in sorted(inp.faces.items()):
        out_faces = out.faces.get(surface, [])
        # Faces.
        for etype, f in out_faces:
            if etype in TRIANGLE_TYPES:
                tris_left += 1
            else:
                quads += 1
            ok = len(set(f)) == len(f) and all(n in out.nodes for n in f)
            rep.check("faces_valid", ok, f"surface {surface}: bad face {f}")
        # Conformity and boundary.
        uses_out = edge_uses(out_faces)
        over = [e for e, n in uses_out.items() if n > 2]
        rep.check("conformity", not over, f"surface {surface}: {len(over)} edges in 3+ faces, e.g. {over[:3]}")
        uses_in = edge_uses(in_faces)
        bnd_in = {e for e, n in uses_in.items() if n == 1}
        bnd_out = {e for e, n in uses_out.items() if n == 1}
        missing, extra, splits = match_split(bnd_in, bnd_out, inp, out, 1e-6, refined)
        rep.check("boundary", not missing and not extra,
                  f"surface {surface}: {len(missing)} input boundary edges lost (e.g. {missing[:3]}), "
                  f"{len(extra)} new boundary edges (e.g. {extra[:3]})")
        # A split must be the same in the surface and in its curve's line elements.
        for e in bnd_in & line_segments:
            if splits.get(e) != all_splits.get(e):
                rep.check("boundary", False,
                          f"surface {surface}: edge {e} split by node {splits.get(e)}, "
                          f"its line element by {all_splits.get(e)}")
        # Embedded segments stay edges used twice.
        for segs in inp.lines.values():
            for a, b in segs:
                e = key(a, b)
                if uses_in.get(e) == 2:
                    nodes = (a,) + all_splits.get(e, ()) + (b,)
                    pieces = [key(x, y) for x, y in zip(nodes, nodes[1:])]
                    ok = all(uses_out.get(p) == 2 for p in pieces)
                    rep.check("curve_edges", ok, f"surface {surface}: embedded segment {e} lost")
        check_geometry(rep, surface, in_faces, out_faces, inp, out, scale, refined, bnd_in)
    for surface in out.faces:
        rep.check("entities", surface in inp.faces or any(e == (2, surface) for e in inp.entities),
                  f"faces on unknown surface {surface}")
    if not allow_triangles:
        rep.check("no_triangles", tris_left == 0, f"{tris_left} triangles left")
    return rep, quads, tris_left


def check_geometry(rep, surface, in_faces, out_faces, inp, out, scale, refined, bnd_in):
    """Area (planar surfaces) and orientation checks for one surface. After refinement the
    area may change by what the boundary's new nodes add or cut: at most a tenth of the
    segment's length off each input boundary segment (see match_split), so at most
    0.1 |ab|^2 per segment."""
    tol = 1e-9
    in_pts = [[inp.nodes[n] for n in f] for _, f in in_faces]
    normals = [polygon_normal(p) for p in in_pts]
    total = (0.0, 0.0, 0.0)
    for n in normals:
        total = (total[0] + n[0], total[1] + n[1], total[2] + n[2])
    surface_nodes = {n for _, f in in_faces for n in f}
    planar = False
    if norm(total) > 0.0:
        axis = tuple(c / norm(total) for c in total)
        origin = inp.nodes[next(iter(surface_nodes))]
        planar = all(abs(dot(sub(inp.nodes[n], origin), axis)) <= tol * scale for n in surface_nodes)
    out_pts = []
    for _, f in out_faces:
        if all(n in out.nodes for n in f):
            out_pts.append([out.nodes[n] for n in f])
    if planar:
        area_in = sum(dot(n, axis) for n in normals) / 2.0
        area_out = sum(dot(polygon_normal(p), axis) for p in out_pts) / 2.0
        rel = abs(area_out - area_in) / max(abs(area_in), 1e-300)
        allowed = 1e-9
        if refined:
            bulge = sum(0.1 * norm(sub(inp.nodes[a], inp.nodes[b])) ** 2 for a, b in bnd_in)
            allowed += bulge / max(abs(area_in), 1e-300)
        rep.check("area", rel <= allowed, f"surface {surface}: area {area_in!r} -> {area_out!r} (rel {rel:.3e})")
        flipped = sum(1 for p in out_pts if dot(polygon_normal(p), axis) <= 0.0)
    else:
        centroids = [tuple(sum(c[i] for c in p) / len(p) for i in range(3)) for p in in_pts]
        finder = NearestTriangle(centroids, normals)
        flipped = 0
        for p in out_pts:
            c = tuple(sum(q[i] for q in p) / len(p) for i in range(3))
            t = finder.nearest(c)
            if t is None or dot(polygon_normal(p), normals[t]) <= 0.0:
                flipped += 1
    rep.check("orientation", flipped == 0,
              f"surface {surface} ({'planar' if planar else 'curved'}): {flipped} faces flipped or degenerate")


def main(argv):
    args = [a for a in argv[1:] if not a.startswith("--")]
    flags = {a for a in argv[1:] if a.startswith("--") and not a.startswith("--refined=")}
    refined = [a.split("=", 1)[1] for a in argv[1:] if a.startswith("--refined=")]
    if refined and not refined[-1].isdigit():
        print(__doc__.splitlines()[2], file=sys.stderr)
        return 2
    refined = int(refined[-1]) if refined else 0
    unknown = flags - {"--allow-dropped-volumes", "--allow-triangles"}
    if len(args) != 2 or unknown:
        print(__doc__.splitlines()[2], file=sys.stderr)
        return 2
    gmsh.initialize(["check_mesh"], readConfigFiles=False)
    gmsh.option.setNumber("General.Terminal", 0)
    inp = load(args[0])
    if inp.errors:
        print(_dumps({"ok": False, "input": args[0], "error": "cannot read input", "messages": inp.errors[:5]}))
        return 2
    out = load(args[1])
    if out.errors:
        print(_dumps({"ok": False, "input": args[0], "output": args[1],
                          "checks": {"loads": False}, "violations": [f"loads: {m}" for m in out.errors[:5]]}))
        return 1
    rep, quads, tris = check(inp, out, "--allow-dropped-volumes" in flags, "--allow-triangles" in flags, refined)
    rep.checks["loads"] = True
    ok = all(rep.checks.values())
    print(_dumps({
        "ok": ok,
        "input": args[0],
        "output": args[1],
        "surfaces": len(inp.faces),
        "quads": quads,
        "triangles_left": tris,
        "input_nodes": len(inp.nodes),
        "output_nodes": len(out.nodes),
        "checks": rep.checks,
        "violations": rep.violations,
    }, sort_keys=False))
    gmsh.finalize()
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv))
