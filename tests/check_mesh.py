#!/usr/bin/env python3
"""Independent invariant checker for blossomquad outputs.

Usage: check_mesh.py INPUT.msh OUTPUT.msh [--allow-dropped-volumes] [--allow-triangles] [--refined=N] [--no-quad-validity] [--tag-map=FILE]

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
  shared_edges      an input boundary edge shared by several surfaces is kept, or split
                    by the same node, in all of them (the surfaces stay conforming
                    whether or not line elements mark the curve).
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
                    input's average normal; on a curved surface with the sum of
                    the input surface's area-weighted normals at its nodes (the
                    normal GUIDE.md's validity is measured about; faces with no input
                    node, e.g. a fallback split's centre quad, use the normals of the
                    input faces nearest to each of their nodes). (The input triangle
                    nearest a face's centroid is ill-defined on a thin tube: a quad
                    across it has its centroid on the axis, as near to the far wall
                    as to its own.)

  quad_valid        every output quad is valid, measured in 3D against the surface
                    normal of the input triangles it came from (those whose nodes are
                    all among the quad's, else those sharing an edge or a node with
                    it, else the nearest; where no one normal stands for the quad, each
                    corner about its own, see OwnSide): its four corners strictly between 0 and
                    180 degrees (positive sine about that normal), its normal agrees
                    with that normal (oriented like the input), and no edge has zero
                    length; and Gmsh's own minSJ of the element (its scaled Jacobian
                    about the element's own normal, getElementQualities) is positive.
                    Each bad quad is reported with its surface, element tag,
                    corner node tags and what is wrong. The JSON also gives
                    quad_eta_min (the worst quad quality eta, paper eq. 3, from the 3D
                    corner angles), how many quads have eta < 0.1, and quad_min_sj
                    (Gmsh's smallest minSJ). Skipped with
                    --no-quad-validity (e.g. for raw matchings before optimization).
  periodic          when INPUT has $Periodic links (read from the files' own text, as
                    Gmsh's reader fills in missing pairs): each slave entity keeps its link
                    (same master, same affine transform); every OUTPUT node on a slave
                    entity has a master node; each pair matches through the affine
                    transform within 1e-6 of the model size; input pairs whose slave
                    node survives are unchanged; and when the input's slave surface
                    faces are images of the master's, so are the output's.

  numbering         with --tag-map=FILE (the map `blossomquad --tag-map FILE` writes, for
                    an output numbered 1..N): OUTPUT's node tags are exactly 1..N and its
                    element tags 1..M; the map's kept input nodes are numbered 1..K in
                    their input order (K kept of them), the new nodes K+1..N after them,
                    and likewise the kept input elements 1..K'; except that the nodes no
                    element of a physical group uses (no element at all, without groups)
                    come last (still in input order among themselves); every output tag
                    the map names exists (a dropped volume's nodes, and the nodes the
                    input repair below leaves in no element, which Gmsh does not show,
                    excepted). OUTPUT is then read back into the input's numbering
                    through the map (new nodes and elements above every input tag), so
                    every check above compares tags with INPUT as without renumbering.

Every check compares OUTPUT with the surfaces the tool works on: INPUT's triangles that
repeat another's three nodes on the same surface (zero-area pockets, such as Gmsh writes
at a degenerate apex or seam) are first removed as the tool's own input repair removes
them (`drop_repeated_triangles` below).

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
        self.mid = {}  # sorted corner pair -> mid-edge node of a second-order element's edge
        self.volume_elements = 0
        self.with_elements = set()  # entities that carry elements
        self.msh2 = False
        self.errors = []
        self.face_tags = {}  # (surface tag, sorted node tuple) -> element tag
        self.periodic = {}  # (dim, tag) -> (master tag, [(slave node, master node)], affine or [])
        self.entity_nodes = {}  # (dim, tag) -> node tags classified on that entity
        self.element_tags = set()  # every element tag
        self.physical_nodes = None  # nodes of the physical groups' elements (None: no group)
        self.min_sj = {}  # (surface tag, quad element tag) -> Gmsh's minSJ of the element
        self.element_nodes = set()  # nodes of any element
        self.orphaned = set()  # nodes only triangles removed by the input repair used


def drop_repeated_triangles(faces):
    """The tool's first repair of an input surface (`recombine::drop_repeated_triangles`),
    on its faces [(type, nodes)] in file order: of the 3-node triangles on the same three
    nodes, a set with as many running one way as the other is removed whole (a zero-area
    pocket), except that one copy is put back where it fills the hole that leaves (each of
    its edges then has at most two triangles, run in opposite directions, and one at least
    is shared with a remaining triangle; sets in file order); any other set keeps its first
    copy running the way of the majority. Returns the faces kept, in order, and those
    removed."""
    def sign(t):
        k = t.index(min(t))
        return 1 if t[(k + 1) % 3] < t[(k + 2) % 3] else -1

    def oriented(n, g):
        return n if g > 0 else (n[0], n[2], n[1])

    sets = {}
    for i, (etype, f) in enumerate(faces):
        if etype == 2 and len(set(f)) == 3:
            sets.setdefault(tuple(sorted(f)), []).append(i)
    runs = [idx for idx in sets.values() if len(idx) > 1]
    if not runs:
        return faces, []
    removed, cancelled = set(), []
    for idx in runs:
        net = sum(sign(faces[i][1]) for i in idx)
        keep = next((i for i in idx if sign(faces[i][1]) == (1 if net > 0 else -1)), None) if net else None
        removed.update(i for i in idx if i != keep)
        if net == 0:
            cancelled.append(idx)
    cancelled.sort(key=lambda idx: idx[0])
    uses = {}  # undirected edge of a cancelled set -> directed uses by remaining triangles
    for idx in cancelled:
        n = tuple(sorted(faces[idx[0]][1]))
        for k in range(3):
            uses.setdefault(key(n[k], n[(k + 1) % 3]), [])
    for i, (etype, f) in enumerate(faces):
        if i in removed or etype != 2 or len(set(f)) != 3:
            continue
        for k in range(3):
            a, b = f[k], f[(k + 1) % 3]
            if key(a, b) in uses:
                uses[key(a, b)].append((a, b))

    def fits(n, g):
        t, shared = oriented(n, g), 0
        for k in range(3):
            a, b = t[k], t[(k + 1) % 3]
            u = uses.get(key(a, b), [])
            if not u:
                continue
            if len(u) == 1 and u[0] == (b, a):
                shared += 1
            else:
                return False
        return shared > 0

    for idx in cancelled:
        n = tuple(sorted(faces[idx[0]][1]))
        first = sign(faces[idx[0]][1])
        g = next((g for g in (first, -first) if fits(n, g)), None)
        k = next((i for i in idx if g is not None and sign(faces[i][1]) == g), None)
        if k is not None:
            removed.discard(k)
            t = oriented(n, g)
            for m in range(3):
                a, b = t[m], t[(m + 1) % 3]
                uses[key(a, b)].append((a, b))
    return ([e for i, e in enumerate(faces) if i not in removed],
            [e for i, e in enumerate(faces) if i in removed])


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


def read_periodic_section(path):
    """The $Periodic links of an ASCII MSH 2.2 or 4.1 file (or any MSH 2 file, whose
    $Periodic section is text), read from the file itself: Gmsh's reader rebuilds
    missing node pairs and moves slave nodes onto their masters' images, so its API
    cannot tell whether the file is complete. {(dim, tag): (master, [(slave, master)],
    affine)}; None for a binary MSH 4 file."""
    with open(path, "rb") as f:
        data = f.read()
    at = data.find(b"$MeshFormat")
    header = data[at:at + 64].split(b"\n")[1].split() if at >= 0 else []
    if len(header) >= 2 and not header[0].startswith(b"2") and header[1] != b"0":
        return None
    start = data.find(b"\n$Periodic")
    links = {}
    if start < 0:
        return links
    end = data.find(b"$EndPeriodic", start)
    lines = [l.strip() for l in data[start:end].decode("ascii", "replace").split("\n")[2:] if l.strip()]
    i = 1
    while i < len(lines):
        dim, tag, master = (int(x) for x in lines[i].split()[:3])
        i += 1
        affine = []
        first = lines[i].split()
        if first[0] == "Affine":  # MSH 2.2
            affine = [float(x) for x in first[1:]]
            i += 1
        elif len(first) > 1 or not header or not header[0].startswith(b"2"):  # MSH 4.1: count, values
            affine = [float(x) for x in first[1:]]
            i += 1
        count = int(lines[i])
        pairs = [tuple(int(x) for x in lines[i + 1 + k].split()[:2]) for k in range(count)]
        i += 1 + count
        links[(dim, tag)] = (master, pairs, affine)
    return links


def load(path, repair=False):
    """Reads PATH with Gmsh; returns a Mesh (with .errors filled on failure). With
    `repair`, the faces are those the tool works on (`drop_repeated_triangles`)."""
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
        mesh.entity_nodes[(dim, tag)] = [int(t) for t in tags]
        types, elem_tags, node_tags = gmsh.model.mesh.getElements(dim, tag)
        types, node_tags = plain(types), [plain(n) for n in node_tags]
        elem_tags = [plain(e) for e in elem_tags]
        if dim == 2:
            for etype, etags in zip(types, elem_tags):
                if etype in QUAD_TYPES and len(etags) > 0:
                    sj = plain(gmsh.model.mesh.getElementQualities(etags, "minSJ"))
                    for t, q in zip(etags, sj):
                        mesh.min_sj[(tag, int(t))] = float(q)
        if len(types) > 0:
            mesh.with_elements.add((dim, tag))
        for etags in elem_tags:
            mesh.element_tags.update(int(t) for t in etags)
        for conn in node_tags:
            mesh.element_nodes.update(int(n) for n in conn)
        for etype, conn, etags in zip(types, node_tags, elem_tags):
            _, edim, _, nnodes, _, ncorner = gmsh.model.mesh.getElementProperties(etype)
            conn = [int(n) for n in conn]
            elements = [tuple(conn[i:i + nnodes][:ncorner]) for i in range(0, len(conn), nnodes)]
            if nnodes > ncorner and ncorner in (2, 3, 4):
                # Gmsh's order: the corners, then the mid-edge nodes of edges 0-1, 1-2, ...
                for i in range(0, len(conn), nnodes):
                    e = conn[i:i + nnodes]
                    ring = ncorner if ncorner > 2 else 1
                    for k in range(ring):
                        mesh.mid.setdefault(key(e[k], e[(k + 1) % ncorner]), e[ncorner + k])
            if dim == 2:
                for e, t in zip(elements, etags):
                    mesh.face_tags.setdefault((tag, tuple(sorted(e))), int(t))
            if dim == 2 and (etype in TRIANGLE_TYPES or etype in QUAD_TYPES):
                mesh.faces.setdefault(tag, []).extend((etype, e) for e in elements)
            elif dim == 1 and edim == 1:
                mesh.lines.setdefault(tag, []).extend((e[0], e[1]) for e in elements)
            if etype in VOLUME_TYPES:
                mesh.volume_elements += len(elements)
    links = read_periodic_section(path)
    if links is None:  # binary MSH 4.1: ask Gmsh (which may fill in missing pairs itself)
        links = {}
        for dim, tag in gmsh.model.getEntities():
            try:
                master, snodes, mnodes, affine = gmsh.model.mesh.getPeriodicNodes(dim, tag)
            except Exception:  # no periodic information for this entity
                continue
            if int(master) != tag and len(snodes) > 0:
                pairs = [(int(a), int(b)) for a, b in zip(plain(snodes), plain(mnodes))]
                links[(dim, tag)] = (int(master), pairs, [float(x) for x in plain(affine)])
    mesh.periodic = links
    mesh.msh2 = is_msh2(path)
    if repair:
        # the tool's first repair of its input: triangles repeating another's three nodes
        # on the same surface; the nodes only those used are then in no element, and Gmsh
        # shows no such node of the output
        removed_nodes = set()
        for tag in mesh.faces:
            mesh.faces[tag], removed = drop_repeated_triangles(mesh.faces[tag])
            removed_nodes.update(n for _, f in removed for n in f)
        if removed_nodes:
            kept = {n for faces in mesh.faces.values() for _, f in faces for n in f}
            kept.update(n for segs in mesh.lines.values() for seg in segs for n in seg)
            mesh.orphaned = removed_nodes - kept
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
        mesh.physical_nodes = mesh.physical_nodes or set()
        for e in ents:
            for conn in gmsh.model.mesh.getElements(dim, e)[2]:
                mesh.physical_nodes.update(int(n) for n in plain(conn))
    mesh.physicals.sort()
    return mesh


def check_numbering(rep, out, tag_map, inp=None, allow_dropped_volumes=False):
    """The `numbering` check (see the module doc) on OUTPUT as read."""
    ntags = sorted(out.nodes)
    rep.check("numbering", ntags == list(range(1, len(ntags) + 1)),
              f"node tags are not 1..{len(ntags)}: {ntags[:3]} ... {ntags[-3:]}")
    etags = sorted(out.element_tags)
    rep.check("numbering", etags == list(range(1, len(etags) + 1)),
              f"element tags are not 1..{len(etags)}: {etags[:3]} ... {etags[-3:]}")
    # nodes no physical group's element uses come after the others (when there are groups)
    used = out.physical_nodes if out.physical_nodes is not None else out.element_nodes
    unused = {t for t in out.nodes if t not in used}
    if unused:
        rep.check("numbering", min(unused) > len(out.nodes) - len(unused),
                  f"a node outside every physical group comes before a node inside one: {sorted(unused)[:5]}")
    for kind, pairs, present, last in (("node", tag_map["nodes"], out.nodes, unused),
                                       ("element", tag_map["elements"], out.element_tags, set())):
        olds = [a for a, _ in pairs]
        rep.check("numbering", olds == sorted(set(olds)), f"the {kind} map is not ascending by input tag")
        # a dropped volume's nodes stay in the file, but Gmsh shows none used by no element
        gone = {a for a, _ in pairs if kind == "node" and allow_dropped_volumes and inp is not None
                and inp.node_dim.get(a) == 3}
        # nodes the input repair left in no element: in the file, but Gmsh shows none
        gone |= {a for a, _ in pairs if kind == "node" and inp is not None and a in inp.orphaned}
        for group in (False, True):
            news = [b for a, b in pairs if (b in last) == group and a not in gone]
            start = 1 if not group else len(present) - len(last) + 1
            if group and not news:
                continue
            rep.check("numbering", news == sorted(news) and (group or news == list(range(1, len(news) + 1))),
                      f"kept input {kind}s are not numbered {start}.. in input order: {pairs[:3]} ...")
        missing = [b for a, b in pairs if b not in present and a not in gone]
        rep.check("numbering", not missing, f"the map names {kind}s not in the output: {missing[:5]}")


def relabel(out, tag_map, inp):
    """OUTPUT in the input's numbering: tags of kept nodes and elements mapped back
    through `tag_map`, the others moved above every input tag."""
    nmax = max(inp.nodes, default=0)
    emax = max([t for t in inp.face_tags.values()] + [0])
    emax = max(emax, max(inp.element_tags, default=0))
    back = {b: a for a, b in tag_map["nodes"]}
    eback = {b: a for a, b in tag_map["elements"]}
    n = lambda t: back.get(t, nmax + t)  # noqa: E731
    e = lambda t: eback.get(t, emax + t)  # noqa: E731
    out.nodes = {n(t): p for t, p in out.nodes.items()}
    out.node_dim = {n(t): d for t, d in out.node_dim.items()}
    out.entity_nodes = {k: [n(t) for t in v] for k, v in out.entity_nodes.items()}
    out.faces = {k: [(et, tuple(n(t) for t in f)) for et, f in v] for k, v in out.faces.items()}
    out.lines = {k: [(n(a), n(b)) for a, b in v] for k, v in out.lines.items()}
    out.face_tags = {(s, tuple(sorted(n(t) for t in f))): e(t) for (s, f), t in out.face_tags.items()}
    out.element_tags = {e(t) for t in out.element_tags}
    out.periodic = {k: (m, [(n(a), n(b)) for a, b in pairs], aff)
                    for k, (m, pairs, aff) in out.periodic.items()}


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
    ..., (mk, b) of nodes absent from INPUT lying on the segment (one of them may be the input's own
    mid-edge node of that second-order edge, on the curve): k = 1 (parity repair)
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
                own_mid = inp.mid.get(key(a, b)) == m
                if (m in inp.nodes and not own_mid) or m not in out.nodes or m in path \
                        or len(path) > max_inner:
                    continue
                # the input's own mid-edge node lies on the curve, off the chord by the
                # edge's bulge: fixed_nodes holds it to its input coordinates
                if own_mid or on_segment(out.nodes[m], pa, pb, band):
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


def ring(cx, cy, cz, r):
    """The grid cells at Chebyshev distance r from cell (cx, cy, cz)."""
    for x in range(cx - r, cx + r + 1):
        for y in range(cy - r, cy + r + 1):
            for z in range(cz - r, cz + r + 1):
                if max(abs(x - cx), abs(y - cy), abs(z - cz)) == r:
                    yield (x, y, z)


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
            for cell in ring(cx, cy, cz, r):
                for t in self.grid.get(cell, ()):
                    d = norm(sub(self.centroids[t], p))
                    if d < best_d:
                        best, best_d = t, d
            # Any centroid outside the searched cube is at least r * cell away.
            if best is not None and best_d <= r * self.cell:
                return best
            r += 1
            if r > 10000:
                return best


def closest_on_triangle(p, a, b, c):
    """The point of triangle abc nearest to p (by its Voronoi regions)."""
    ab, ac, ap = sub(b, a), sub(c, a), sub(p, a)
    d1, d2 = dot(ab, ap), dot(ac, ap)
    if d1 <= 0.0 and d2 <= 0.0:
        return a
    bp = sub(p, b)
    d3, d4 = dot(ab, bp), dot(ac, bp)
    if d3 >= 0.0 and d4 <= d3:
        return b
    vc = d1 * d4 - d3 * d2
    if vc <= 0.0 and d1 >= 0.0 and d3 <= 0.0:
        v = d1 / (d1 - d3)
        return add(a, tuple(x * v for x in ab))
    cp = sub(p, c)
    d5, d6 = dot(ab, cp), dot(ac, cp)
    if d6 >= 0.0 and d5 <= d6:
        return c
    vb = d5 * d2 - d1 * d6
    if vb <= 0.0 and d2 >= 0.0 and d6 <= 0.0:
        w = d2 / (d2 - d6)
        return add(a, tuple(x * w for x in ac))
    va = d3 * d6 - d5 * d4
    if va <= 0.0 and (d4 - d3) >= 0.0 and (d5 - d6) >= 0.0:
        w = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        return add(b, tuple(x * w for x in sub(c, b)))
    # inside: p moved onto the plane (not rebuilt from barycentric coordinates, whose
    # rounding a far corner of a sliver multiplies)
    n = cross(ab, ac)
    nn = dot(n, n)
    if not nn > 0.0:
        den = 1.0 / (va + vb + vc)
        v, w = vb * den, vc * den
        return add(a, add(tuple(x * v for x in ab), tuple(x * w for x in ac)))
    return sub(p, tuple(x * (dot(n, ap) / nn) for x in n))


# A face turning this far from its node's normal (cosine of 90 degrees) makes the node
# wrapped (OwnSide), as in GUIDE.md's validity.
WRAP_COS = 0.0

# Faces at a quad's nodes turning this far from the mean of those it came from (cosine of
# 60 degrees) lie on several sides of a sharp turn of the surface (check_quads).
TURN_COS = 0.5


class OwnSide:
    """Where one input surface wraps round a node, and the normal of its own side there.

    A node is wrapped when one of the surface's faces at it turns 90 degrees or more from
    the node's area-weighted normal (a fold, or a pin meshed coarser than its radius, a
    few triangles round): that normal stands for no side of the surface. A corner at such
    a node is measured on its own side: about the mean unit normal of the input faces
    there that the quad holds (all their nodes among its own), else about the input faces
    nearest to a point inside it, a quarter of the way along its two edges (where the
    surface folds over itself several faces lie at that point, and only those the quad
    holds say which side it is on); the nearest faces are found through a grid of
    cells, by true distance (ties within 1e-9 of the model's size all count). A quad with
    a corner at a wrapped node, with no input node of the surface at all, or where a face
    at one of its nodes turns 60 degrees or more from the mean of the faces it came from,
    has its other corners measured as GUIDE.md's validity measures them: about the node's
    area-weighted normal at an input node, about the faces nearest to the point inside the
    corner at a node the run added (the faces the quad lies on there; the node itself, at
    the midpoint of an input edge, is as near to the faces on both sides of that edge)."""

    def __init__(self, in_faces, inp, scale):
        # each face's points and twice its vector area, and the area-weighted normal at
        # each node (unit)
        self.faces = []
        at_node = {}
        nodes_of = []
        # each node's faces (indices into self.faces)
        self.faces_at = {}
        for _, f in in_faces:
            if not all(n in inp.nodes for n in f):
                continue
            pts = [inp.nodes[n] for n in f]
            n = polygon_normal(pts)
            for t in f:
                at_node[t] = add(at_node.get(t, (0.0, 0.0, 0.0)), n)
                self.faces_at.setdefault(t, []).append(len(self.faces))
            self.faces.append((pts, n))
            nodes_of.append(f)
        self.nodes_of = nodes_of
        self.at_node = {t: unit(m) for t, m in at_node.items()}
        self.wrapped = set()
        for (_, n), f in zip(self.faces, nodes_of):
            if norm(n) == 0.0:
                continue
            for t in f:
                m = self.at_node[t]
                if norm(m) > 0.0 and dot(n, m) <= WRAP_COS * norm(n):
                    self.wrapped.add(t)
        self.tie = 1e-9 * scale
        # a uniform grid of cells about the mean face size, each face in every cell its
        # bounding box meets
        self.grid = {}
        if self.faces:
            size = sum(max(norm(sub(q, pts[0])) for q in pts) for pts, _ in self.faces) / len(self.faces)
            self.cell = max(size, 1e-12 * scale)
            for i, (pts, _) in enumerate(self.faces):
                lo = self._cell([min(q[j] for q in pts) for j in range(3)])
                hi = self._cell([max(q[j] for q in pts) for j in range(3)])
                for x in range(lo[0], hi[0] + 1):
                    for y in range(lo[1], hi[1] + 1):
                        for z in range(lo[2], hi[2] + 1):
                            self.grid.setdefault((x, y, z), []).append(i)

    def _cell(self, p):
        return tuple(int(math.floor(p[j] / self.cell)) for j in range(3))

    def corner(self, node, p, a, b, face):
        """The unit normal the corner at `node` (at p, edges a and b) of output face `face`
        (its node tags) is measured about in a face with a wrapped node. At a wrapped node:
        the mean unit normal of the input faces there whose nodes are all among the face's
        (those it holds), else the input faces nearest to a point inside the corner."""
        if node in self.wrapped:
            held = [i for i in self.faces_at.get(node, ()) if all(t in face for t in self.nodes_of[i])]
            if held:
                total = (0.0, 0.0, 0.0)
                for i in held:
                    total = add(total, unit(self.faces[i][1]))
                return unit(total)
            return self.normal(p, a, b)
        m = self.at_node.get(node, (0.0, 0.0, 0.0))
        if norm(m) > 0.0:
            return m
        # a node the run added: the faces the quad lies on at the corner
        return self.normal(p, a, b)

    def normal(self, p, a, b):
        """The unit normal of the corner at p with edges a and b (to its neighbours)."""
        return self.nearest(add(p, tuple(0.25 * (x + y) for x, y in zip(a, b))))

    def nearest(self, c):
        """The unit summed normal of the input faces nearest to point c."""
        if not self.faces:
            return (0.0, 0.0, 0.0)
        dist = {}
        cx, cy, cz = self._cell(c)
        r = 0
        while True:
            for cell in ring(cx, cy, cz, r):
                for i in self.grid.get(cell, ()):
                    if i not in dist:
                        pts = self.faces[i][0]
                        dist[i] = min(norm(sub(c, closest_on_triangle(c, pts[0], pts[j], pts[j + 1])))
                                      for j in range(1, len(pts) - 1))
            best = min(dist.values(), default=math.inf)
            # a face in no searched cell is at least r cells away
            if best + self.tie <= r * self.cell or len(dist) == len(self.faces):
                break
            r += 1
        total = (0.0, 0.0, 0.0)
        for i, d in dist.items():
            if d <= best + self.tie:
                total = add(total, self.faces[i][1])
        return unit(total)


def check(inp, out, allow_dropped_volumes, allow_triangles, refined=0, no_quad_validity=False):
    rep = Report()
    rep.quad_stats = QuadStats()
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
    shared_splits = {}  # input boundary edge -> {surface: inner nodes of its output chain}
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
        for e in bnd_in:
            if e not in missing:
                shared_splits.setdefault(e, {})[surface] = splits.get(e, ())
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
                    # the chain of a split runs from the lower tag (match_split)
                    nodes = (e[0],) + all_splits.get(e, ()) + (e[1],)
                    pieces = [key(x, y) for x, y in zip(nodes, nodes[1:])]
                    ok = all(uses_out.get(p) == 2 for p in pieces)
                    rep.check("curve_edges", ok, f"surface {surface}: embedded segment {e} lost")
        own = OwnSide(in_faces, inp, scale)
        check_geometry(rep, surface, in_faces, out_faces, inp, out, scale, refined, bnd_in, own)
        if not no_quad_validity:
            check_quads(rep, surface, in_faces, out_faces, inp, out, scale, rep.quad_stats, own)
    check_periodic(rep, inp, out, scale)
    # Surfaces sharing an input boundary edge must still share it, split the same way.
    mismatched = [(e, chains) for e, chains in sorted(shared_splits.items())
                  if len(chains) > 1 and len(set(chains.values())) > 1]
    for e, chains in mismatched[:3]:
        rep.check("shared_edges", False,
                  f"edge {e} shared by surfaces {sorted(chains)} is split differently: "
                  + ", ".join(f"surface {t}: {list(c) or 'kept'}" for t, c in sorted(chains.items())))
    rep.check("shared_edges", not mismatched,
              f"{len(mismatched)} edges shared by several surfaces no longer match")
    for surface in out.faces:
        rep.check("entities", surface in inp.faces or any(e == (2, surface) for e in inp.entities),
                  f"faces on unknown surface {surface}")
    if not allow_triangles:
        rep.check("no_triangles", tris_left == 0, f"{tris_left} triangles left")
    return rep, quads, tris_left


def check_geometry(rep, surface, in_faces, out_faces, inp, out, scale, refined, bnd_in, own):
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
        flipped = 0
        for _, f in out_faces:
            if not all(n in out.nodes for n in f):
                continue
            p = [out.nodes[n] for n in f]
            ref = (0.0, 0.0, 0.0)
            k = len(f)
            # a wrapped node's normal stands for no side: each corner on its own (OwnSide)
            wrapped = any(t in own.wrapped for t in f)
            for i, t in enumerate(f):
                if wrapped:
                    ref = add(ref, own.corner(t, p[i], sub(p[(i + 1) % k], p[i]), sub(p[i - 1], p[i]), f))
                else:
                    # the area-weighted input normal at the node (OwnSide)
                    ref = add(ref, own.at_node.get(t, (0.0, 0.0, 0.0)))
            if norm(ref) == 0.0:
                # no input node: the input faces nearest to each of its nodes (by true
                # distance), as a node the run added is measured
                for q in p:
                    ref = add(ref, own.nearest(q))
            if dot(polygon_normal(p), ref) <= 0.0:
                flipped += 1
    rep.check("orientation", flipped == 0,
              f"surface {surface} ({'planar' if planar else 'curved'}): {flipped} faces flipped or degenerate")


def unit(v):
    n = norm(v)
    return (v[0] / n, v[1] / n, v[2] / n) if n > 0.0 else (0.0, 0.0, 0.0)


def add(a, b):
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


class QuadStats:
    """Per-quad validity figures over the whole output (for the JSON report)."""

    def __init__(self):
        self.checked = 0
        self.bad = 0
        self.eta_min = None
        self.below_01 = 0
        self.sj_min = None  # Gmsh's smallest minSJ over the quads


# Corners whose sine (measured against the surface normal) is at most this are flat,
# reflex or degenerate (eta = 0).
SIN_TOL = 1e-9


def check_quads(rep, surface, in_faces, out_faces, inp, out, scale, stats, own):
    """Validity of every output quad of one surface, measured in 3D against the surface
    normal of the input: each of the four corners strictly between 0 and 180 degrees
    (positive sine about the reference normal), the quad oriented like the input faces
    (its normal agrees with the reference normal), no zero-length edge. The reference
    normal is the mean unit normal of the input faces (triangles or quads) the quad came
    from: those whose nodes are all among the quad's, else those sharing an edge (two
    nodes) with it, else a node, else the input face with the nearest centroid. Also
    computes the quad quality eta (paper eq. 3) from the 3D corner angles."""
    in_normals = []
    by_node = {}
    for i, (_, f) in enumerate(in_faces):
        if not all(n in inp.nodes for n in f):
            in_normals.append((0.0, 0.0, 0.0))
            continue
        in_normals.append(unit(polygon_normal([inp.nodes[n] for n in f])))
        for n in f:
            by_node.setdefault(n, []).append(i)
    finder = None
    zero = 1e-12 * scale
    for etype, f in out_faces:
        if etype not in QUAD_TYPES or len(f) != 4 or len(set(f)) != 4 or not all(n in out.nodes for n in f):
            continue  # faces_valid reports these
        stats.checked += 1
        pts = [out.nodes[n] for n in f]
        # reference normal
        shared = {}
        for n in f:
            for i in by_node.get(n, ()):
                shared[i] = shared.get(i, 0) + 1
        ref = (0.0, 0.0, 0.0)
        # a quad with no input node of the surface has no faces it came from
        by_corners = not shared
        for need in ("all", 2, 1):
            for i, c in shared.items():
                k = len(in_faces[i][1])
                if (need == "all" and c == k) or (need != "all" and c >= need):
                    ref = add(ref, in_normals[i])
            if norm(ref) > 0.0:
                # faces at the quad's nodes turning 60 degrees or more from the mean of
                # those it came from lie on several sides of a sharp turn of the surface:
                # no one normal stands for the quad
                mean = unit(ref)
                by_corners = any(dot(in_normals[i], mean) <= TURN_COS for i in shared)
                break
        if norm(ref) == 0.0:
            if finder is None:
                cents = [tuple(sum(inp.nodes[n][j] for n in g) / len(g) for j in range(3))
                         if all(n in inp.nodes for n in g) else (0.0, 0.0, 0.0) for _, g in in_faces]
                finder = NearestTriangle(cents, in_normals) if cents else None
            if finder is not None:
                c = tuple(sum(p[j] for p in pts) / 4.0 for j in range(3))
                t = finder.nearest(c)
                if t is not None:
                    ref = in_normals[t]
        ref = unit(ref)
        problems = []
        for i in range(4):
            if norm(sub(pts[(i + 1) % 4], pts[i])) <= zero:
                problems.append(f"zero-length edge {f[i]}-{f[(i + 1) % 4]}")
        # at a wrapped node, or where the faces the quad came from turn sharply, they lie on
        # several sides of the surface: each corner is measured on its own (OwnSide)
        corner_ref = [ref] * 4
        if (by_corners or any(n in own.wrapped for n in f)) and not problems:
            corner_ref = [own.corner(f[i], pts[i], sub(pts[(i + 1) % 4], pts[i]), sub(pts[i - 1], pts[i]), f)
                          for i in range(4)]
            ref = unit(tuple(sum(c[j] for c in corner_ref) for j in range(3)))
        if dot(polygon_normal(pts), ref) <= 0.0:
            problems.append("inverted (normal opposite to the input triangles')")
        worst = 0.0
        for i in range(4):
            e1 = sub(pts[(i + 1) % 4], pts[i])
            e2 = sub(pts[i - 1], pts[i])
            l1, l2 = norm(e1), norm(e2)
            if l1 <= zero or l2 <= zero:
                worst = math.inf
                continue
            sine = dot(cross(e1, e2), corner_ref[i]) / (l1 * l2)
            if sine <= SIN_TOL:
                angle = math.degrees(math.acos(max(-1.0, min(1.0, dot(e1, e2) / (l1 * l2)))))
                kind = "reflex" if sine < -SIN_TOL else "flat"
                problems.append(f"{kind} corner at node {f[i]} "
                                f"({angle:.4g} deg in 3D, sine {sine:.3g} about the surface normal)")
                worst = math.inf
            else:
                alpha = math.acos(max(-1.0, min(1.0, dot(e1, e2) / (l1 * l2))))
                worst = max(worst, abs(math.pi / 2 - alpha))
        tag = out.face_tags.get((surface, tuple(sorted(f))), "?")
        sj = out.min_sj.get((surface, tag))
        if sj is not None:
            stats.sj_min = sj if stats.sj_min is None else min(stats.sj_min, sj)
            if not sj > 0.0:
                problems.append(f"Gmsh's minSJ {sj:.3g} is not positive (the element folds "
                                "about its own normal)")
        eta = max(0.0, 1.0 - 2.0 / math.pi * worst) if worst != math.inf else 0.0
        stats.eta_min = eta if stats.eta_min is None else min(stats.eta_min, eta)
        if eta < 0.1:
            stats.below_01 += 1
        if problems:
            stats.bad += 1
            rep.check("quad_valid", False,
                      f"surface {surface} element {tag} nodes {list(f)}: " + "; ".join(problems))
    rep.check("quad_valid", True)


def apply_affine(affine, p):
    return tuple(affine[4 * r] * p[0] + affine[4 * r + 1] * p[1] + affine[4 * r + 2] * p[2] + affine[4 * r + 3]
                 for r in range(3))


def periodic_faces_match(mesh, surface, master, node_map):
    """(images that are master faces, slave faces) of `surface` mapped through node_map."""
    master_faces = {tuple(sorted(f)) for _, f in mesh.faces.get(master, [])}
    slave_faces = mesh.faces.get(surface, [])
    hits = 0
    for _, f in slave_faces:
        image = [node_map.get(n) for n in f]
        if None not in image and tuple(sorted(image)) in master_faces:
            hits += 1
    return hits, len(slave_faces)


def check_periodic(rep, inp, out, scale):
    """The input's $Periodic links are kept complete: every slave entity still has its
    master and affine transform; every output node classified on a slave entity has a
    master node; every (slave, master) pair maps through the affine transform within
    1e-6 of the model size; input pairs whose slave node survives are unchanged; and
    when the input's slave surface faces are images of the master's, so are the output's."""
    if not inp.periodic:
        return
    tol = 1e-6 * scale
    in_map = {}
    out_map = {}
    for (dim, tag), (_, pairs, _) in inp.periodic.items():
        in_map.update(pairs)
    for (dim, tag), (_, pairs, _) in out.periodic.items():
        out_map.update(pairs)
    for (dim, tag), (master, pairs, affine) in sorted(inp.periodic.items()):
        name = ["point", "curve", "surface", "volume"][dim]
        link = out.periodic.get((dim, tag))
        if link is None:
            if (dim, tag) in out.entities and out.entity_nodes.get((dim, tag)):
                rep.check("periodic", False, f"{name} {tag}: periodic link to {name} {master} lost")
            continue
        omaster, opairs, oaffine = link
        if omaster != master:
            rep.check("periodic", False, f"{name} {tag}: master {master} became {omaster}")
            continue
        if affine and oaffine and any(abs(a - b) > 1e-9 * max(1.0, abs(a)) for a, b in zip(affine, oaffine)):
            rep.check("periodic", False, f"{name} {tag}: affine transform changed")
        paired = dict(opairs)
        missing = [n for n in out.entity_nodes.get((dim, tag), []) if n not in paired]
        rep.check("periodic", not missing,
                  f"{name} {tag}: {len(missing)} nodes without a master node (e.g. {missing[:5]})")
        absent = [(a, b) for a, b in opairs if a not in out.nodes or b not in out.nodes]
        rep.check("periodic", not absent, f"{name} {tag}: pairs naming missing nodes (e.g. {absent[:3]})")
        changed = [(a, b, paired.get(a)) for a, b in pairs if a in out.nodes and paired.get(a) != b]
        rep.check("periodic", not changed,
                  f"{name} {tag}: input pairs (slave, master, now) changed or dropped (e.g. {changed[:3]})")
        if oaffine and len(oaffine) >= 12:
            off = []
            for a, b in opairs:
                if a in out.nodes and b in out.nodes:
                    d = norm(sub(apply_affine(oaffine, out.nodes[b]), out.nodes[a]))
                    if d > tol:
                        off.append((a, b, d))
            rep.check("periodic", not off,
                      f"{name} {tag}: {len(off)} node pairs do not match through the affine transform "
                      f"(e.g. slave, master, distance {off[:3]})")
        if dim == 2:
            hits_in, n_in = periodic_faces_match(inp, tag, master, in_map)
            if n_in > 0 and hits_in == n_in:
                hits, n = periodic_faces_match(out, tag, master, out_map)
                rep.check("periodic", hits == n and n > 0,
                          f"surface {tag}: {n - hits} of its {n} faces are not images of master surface "
                          f"{master}'s faces (the input's were)")
    rep.check("periodic", True)


def main(argv):
    args = [a for a in argv[1:] if not a.startswith("--")]
    flags = {a for a in argv[1:] if a.startswith("--") and not a.startswith(("--refined=", "--tag-map="))}
    refined = [a.split("=", 1)[1] for a in argv[1:] if a.startswith("--refined=")]
    maps = [a.split("=", 1)[1] for a in argv[1:] if a.startswith("--tag-map=")]
    if refined and not refined[-1].isdigit():
        print(__doc__.splitlines()[2], file=sys.stderr)
        return 2
    refined = int(refined[-1]) if refined else 0
    unknown = flags - {"--allow-dropped-volumes", "--allow-triangles", "--no-quad-validity"}
    if len(args) != 2 or unknown:
        print(__doc__.splitlines()[2], file=sys.stderr)
        return 2
    gmsh.initialize(["check_mesh"], readConfigFiles=False)
    gmsh.option.setNumber("General.Terminal", 0)
    inp = load(args[0], repair=True)
    if inp.errors:
        print(_dumps({"ok": False, "input": args[0], "error": "cannot read input", "messages": inp.errors[:5]}))
        return 2
    out = load(args[1])
    if out.errors:
        print(_dumps({"ok": False, "input": args[0], "output": args[1],
                          "checks": {"loads": False}, "violations": [f"loads: {m}" for m in out.errors[:5]]}))
        return 1
    numbering = Report()
    if maps:
        with open(maps[-1]) as f:
            tag_map = json.load(f)
        check_numbering(numbering, out, tag_map, inp, "--allow-dropped-volumes" in flags)
        relabel(out, tag_map, inp)
    rep, quads, tris = check(inp, out, "--allow-dropped-volumes" in flags, "--allow-triangles" in flags, refined,
                             "--no-quad-validity" in flags)
    rep.checks["loads"] = True
    if maps:
        rep.checks["numbering"] = numbering.checks.get("numbering", True)
        rep.violations = numbering.violations + rep.violations
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
        "quads_checked": rep.quad_stats.checked,
        "bad_quads": rep.quad_stats.bad,
        "quad_eta_min": rep.quad_stats.eta_min,
        "quads_eta_below_0.1": rep.quad_stats.below_01,
        "quad_min_sj": rep.quad_stats.sj_min,
        "periodic_links": len(inp.periodic),
        "checks": rep.checks,
        "violations": rep.violations,
    }, sort_keys=False))
    gmsh.finalize()
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv))
