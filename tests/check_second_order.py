#!/usr/bin/env python3
"""Independent checker for blossomquad's second-order outputs (6-node triangles in,
9-node or 8-node quads out).

Usage: check_second_order.py INPUT.msh OUTPUT.msh [--incomplete] [--sphere R] [--tag-map=FILE]

Both files are read with Gmsh's own reader (the `gmsh` Python module); nothing here
uses blossomquad's code. Prints one JSON object; exits 0 when every check holds.

  loads          Gmsh opens OUTPUT without an `Error` message.
  types          surfaces hold only 9-node quads (type 10; 8-node, type 16, with
                 --incomplete), curves only 3-node lines (type 8); no triangle left.
  min_sj         Gmsh's `minSJ` (getElementQualities) > 0 for every surface element.
  fixed_nodes    every input node on a curve or a point, and every input mid-edge node
                 still in OUTPUT, keeps its coordinates exactly.
  boundary_mid_nodes
                 every input mid-edge node of a 3-node line or of a 6-node triangle's
                 boundary edge (used by one triangle of its surface) is in OUTPUT with
                 its tag and coordinates: kept on its edge, or the middle corner of
                 the chain the edge was split into.
  new_tags       every node tag not in INPUT is above INPUT's largest node tag.
  curve_nodes    every node of an OUTPUT 3-node line lies on INPUT's chain of 3-node
                 lines of that curve (distance <= 1e-9 of the model's size).
  physical       physical groups (dim, tag, name, entities) identical.
  input_quads    every 9- or 8-node quad of INPUT (Gmsh's transfinite, layered or
                 recombined faces) whose corners kept their coordinates is in OUTPUT
                 with the same tag, corners and mid-edge nodes (and face node, when both
                 are 9-node quads).
  numbering      with --tag-map=FILE (the map `blossomquad --tag-map FILE` writes):
                 OUTPUT's node tags are 1..N and its element tags 1..M, and the kept input
                 nodes and elements are numbered 1..K in their input order (nodes no
                 physical group's element uses last, when there are groups). OUTPUT's tags
                 are then mapped back to INPUT's (new ones above every input tag) for the
                 checks that compare tags.
  sphere         with --sphere R (a sphere of radius R about the origin): the largest
                 |r - R| of OUTPUT's new or moved nodes is at most 1.5 times INPUT's
                 own interpolation error (|r - R| sampled over its quadratic
                 triangles); also reported: the same measure for the straight
                 midpoints of OUTPUT's edges (what flat placement would give).
"""

import json
import math
import sys

import gmsh


def nodes_by_tag():
    tags, coords, _ = gmsh.model.mesh.getNodes()
    return {int(t): tuple(float(c) for c in coords[3 * i:3 * i + 3]) for i, t in enumerate(tags)}


def elements(dim):
    """[(entity, type, [tags], [[nodes]])] for every entity of `dim`."""
    out = []
    for _, ent in gmsh.model.getEntities(dim):
        types, etags, enodes = gmsh.model.mesh.getElements(dim, ent)
        for t, tg, nd in zip(types, etags, enodes):
            _, _, _, k, _, _ = gmsh.model.mesh.getElementProperties(t)
            out.append((ent, int(t), [int(x) for x in tg],
                        [[int(x) for x in nd[i * k:(i + 1) * k]] for i in range(len(tg))]))
    return out


def physical():
    groups = []
    for dim, tag in gmsh.model.getPhysicalGroups():
        groups.append((dim, tag, gmsh.model.getPhysicalName(dim, tag),
                       sorted(int(e) for e in gmsh.model.getEntitiesForPhysicalGroup(dim, tag))))
    return sorted(groups)


def sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def norm(a):
    return math.sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2])


def line3(a, b, m, xi):
    wa, wb, wm = 0.5 * xi * (xi - 1), 0.5 * xi * (xi + 1), 1 - xi * xi
    return tuple(wa * a[k] + wb * b[k] + wm * m[k] for k in range(3))


def dist_to_line3(p, a, b, m):
    best = min((norm(sub(line3(a, b, m, -1 + 2 * i / 64), p)), -1 + 2 * i / 64) for i in range(65))
    lo, hi = max(-1.0, best[1] - 2 / 64), min(1.0, best[1] + 2 / 64)
    for _ in range(80):  # golden-section search around the best sample
        g = 0.381966
        x1, x2 = lo + g * (hi - lo), hi - g * (hi - lo)
        if norm(sub(line3(a, b, m, x1), p)) < norm(sub(line3(a, b, m, x2), p)):
            hi = x2
        else:
            lo = x1
    return min(best[0], norm(sub(line3(a, b, m, 0.5 * (lo + hi)), p)))


def tri6(x, l0, l1, l2):
    w = (l0 * (2 * l0 - 1), l1 * (2 * l1 - 1), l2 * (2 * l2 - 1), 4 * l0 * l1, 4 * l1 * l2, 4 * l2 * l0)
    return tuple(sum(w[i] * x[i][k] for i in range(6)) for k in range(3))


def main(argv):
    if len(argv) < 3:
        print(__doc__, file=sys.stderr)
        return 2
    inp, outp = argv[1], argv[2]
    incomplete = "--incomplete" in argv
    radius = float(argv[argv.index("--sphere") + 1]) if "--sphere" in argv else None
    checks = {}  # name -> bool
    info = {}
    gmsh.initialize()
    gmsh.option.setNumber("General.Terminal", 0)

    gmsh.open(inp)
    in_nodes = nodes_by_tag()
    in_max = max(in_nodes)
    in_phys = physical()
    in_fixed = set()
    for dim in (0, 1):
        for _, ent in gmsh.model.getEntities(dim):
            tags, _, _ = gmsh.model.mesh.getNodes(dim, ent)
            in_fixed.update(int(t) for t in tags)
    in_mid = set()
    curves = {}
    tris = []
    for ent, t, _, nodes in elements(1):
        if t == 8:
            for n in nodes:
                in_mid.add(n[2])
                curves.setdefault(ent, []).append(tuple(in_nodes[k] for k in n))
    in_quads = {}
    boundary_mid = {n[2] for _, t, _, nodes in elements(1) if t == 8 for n in nodes}
    for ent, t, tags, nodes in elements(2):
        if t == 9:
            uses = {}
            for n in nodes:
                in_mid.update(n[3:])
                tris.append([in_nodes[k] for k in n])
                for k in range(3):
                    e = tuple(sorted((n[k], n[(k + 1) % 3])))
                    uses.setdefault(e, []).append(n[3 + k])
            boundary_mid.update(m[0] for m in uses.values() if len(m) == 1)
        if t in (10, 16):
            for tag, n in zip(tags, nodes):
                in_mid.update(n[4:])
                in_quads[tag] = n
    in_emax = max([int(t) for tg in gmsh.model.mesh.getElements()[1] for t in tg] + [0])
    lo = [min(c[k] for c in in_nodes.values()) for k in range(3)]
    hi = [max(c[k] for c in in_nodes.values()) for k in range(3)]
    size = norm(sub(hi, lo))

    gmsh.clear()
    gmsh.logger.start()
    gmsh.open(outp)
    log = gmsh.logger.get()
    gmsh.logger.stop()
    checks["loads"] = not any("Error" in line for line in log)
    out_nodes = nodes_by_tag()
    want = 16 if incomplete else 10
    surf = elements(2)
    lines = elements(1)
    bad_types = sorted({t for _, t, _, _ in surf if t != want} | {t for _, t, _, _ in lines if t != 8})
    checks["types"] = not bad_types and any(tg for _, _, tg, _ in surf)
    info["bad_types"] = bad_types
    info["quads"] = sum(len(tg) for _, t, tg, _ in surf if t == want)
    info["lines"] = sum(len(tg) for _, t, tg, _ in lines if t == 8)

    all_tags = [tag for _, _, tg, _ in surf for tag in tg]
    sj = [float(v) for v in gmsh.model.mesh.getElementQualities(all_tags, "minSJ")] if all_tags else []
    info["min_sj"] = min(sj) if sj else None
    info["mean_sj"] = sum(sj) / len(sj) if sj else None
    info["sj_not_positive"] = [all_tags[i] for i, v in enumerate(sj) if not v > 0][:10]
    checks["min_sj"] = bool(sj) and min(sj) > 0

    maps = [a.split("=", 1)[1] for a in argv if a.startswith("--tag-map=")]
    if maps:
        with open(maps[-1]) as f:
            tag_map = json.load(f)
        etags = sorted({t for _, _, tg, _ in surf + lines for t in tg}
                       | {int(t) for d in (0, 3) for _, e in gmsh.model.getEntities(d)
                          for tg in gmsh.model.mesh.getElements(d, e)[1] for t in tg})
        ok = sorted(out_nodes) == list(range(1, len(out_nodes) + 1))
        ok = ok and etags == list(range(1, len(etags) + 1))
        used = set()
        for d, g in gmsh.model.getPhysicalGroups():
            for ent in gmsh.model.getEntitiesForPhysicalGroup(d, g):
                for conn in gmsh.model.mesh.getElements(d, ent)[2]:
                    used.update(int(x) for x in conn)
        last = {t for t in out_nodes if used and t not in used}
        ok = ok and (not last or min(last) > len(out_nodes) - len(last))
        for kind in ("nodes", "elements"):
            pairs = tag_map[kind]
            first = [b for _, b in pairs if kind == "elements" or b not in last]
            ok = ok and first == list(range(1, len(first) + 1))
            rest = [b for _, b in pairs if kind == "nodes" and b in last]
            ok = ok and rest == sorted(rest)
            ok = ok and [a for a, _ in pairs] == sorted({a for a, _ in pairs})
        checks["numbering"] = ok
        back = {b: a for a, b in tag_map["nodes"]}
        eback = {b: a for a, b in tag_map["elements"]}
        n = lambda t: back.get(t, in_max + t)  # noqa: E731
        e = lambda t: eback.get(t, in_emax + t)  # noqa: E731
        out_nodes = {n(t): p for t, p in out_nodes.items()}
        surf = [(ent, t, [e(x) for x in tg], [[n(k) for k in nd] for nd in nds]) for ent, t, tg, nds in surf]
        lines = [(ent, t, [e(x) for x in tg], [[n(k) for k in nd] for nd in nds]) for ent, t, tg, nds in lines]

    moved = [t for t in (in_fixed | in_mid) if t in out_nodes and out_nodes[t] != in_nodes[t]]
    missing_fixed = [t for t in in_fixed if t not in out_nodes and t not in in_mid]
    info["fixed_moved"] = sorted(moved)[:10]
    info["fixed_missing"] = sorted(missing_fixed)[:10]
    info["kept_mid_nodes"] = sum(1 for t in in_mid if t in out_nodes)
    checks["fixed_nodes"] = not moved and not missing_fixed

    lost = sorted(t for t in boundary_mid if out_nodes.get(t) != in_nodes[t])
    info["boundary_mid_lost"] = lost[:10]
    checks["boundary_mid_nodes"] = not lost

    new = [t for t in out_nodes if t not in in_nodes]
    info["new_nodes"] = len(new)
    checks["new_tags"] = all(t > in_max for t in new)

    worst_curve = 0.0
    for ent, t, _, nodes in lines:
        segs = curves.get(ent)
        if not segs:
            continue
        for n in nodes:
            for k in n:
                if k in in_nodes and in_nodes[k] == out_nodes[k]:
                    continue
                p = out_nodes[k]
                d = min(dist_to_line3(p, a, b, m) for a, b, m in segs)
                worst_curve = max(worst_curve, d)
    info["curve_distance"] = worst_curve
    checks["curve_nodes"] = worst_curve <= 1e-9 * size

    checks["physical"] = physical() == in_phys

    if in_quads:
        out_elems = {tag: n for _, _, tags, nodes in surf for tag, n in zip(tags, nodes)}
        kept = 0
        lost = []
        for tag, n in in_quads.items():
            if any(k not in out_nodes or out_nodes[k] != in_nodes[k] for k in n[:4]):
                continue
            m = out_elems.get(tag)
            k = min(len(n), len(m)) if m else 0
            if m is None or m[:8] != n[:8] or (k == 9 and m[8] != n[8]):
                lost.append(tag)
            else:
                kept += 1
        info["input_quad_count"] = len(in_quads)
        info["input_quads_kept"] = kept
        info["input_quads_lost"] = lost[:10]
        checks["input_quads"] = not lost

    if radius is not None:
        samples = [(i / 6, j / 6, 1 - i / 6 - j / 6) for i in range(7) for j in range(7 - i)]
        input_err = max(abs(norm(tri6(x, *l)) - radius) for x in tris for l in samples)
        changed = [t for t in out_nodes
                   if t not in in_nodes or out_nodes[t] != in_nodes[t]]
        new_err = max((abs(norm(out_nodes[t]) - radius) for t in changed), default=0.0)
        flat_err = 0.0
        for _, _, _, nodes in surf:
            for n in nodes:
                for k in range(4):
                    a, b = out_nodes[n[k]], out_nodes[n[(k + 1) % 4]]
                    mid = tuple(0.5 * (a[i] + b[i]) for i in range(3))
                    flat_err = max(flat_err, abs(norm(mid) - radius))
        info["sphere_input_error"] = input_err
        info["sphere_new_error"] = new_err
        info["sphere_flat_error"] = flat_err
        checks["sphere"] = new_err <= 1.5 * input_err

    gmsh.finalize()
    checks = {k: bool(v) for k, v in checks.items()}
    ok = all(checks.values())
    print(json.dumps({"ok": ok, "checks": checks, "info": info}))
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv))
