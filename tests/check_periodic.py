#!/usr/bin/env python3
"""Checks that a recombined mesh keeps its periodic links, with Gmsh's own reader.

Usage: check_periodic.py OUTPUT.msh

For every periodic surface and curve Gmsh reloads from OUTPUT: every node of the slave
entity (boundary included) has a master node, the slave node is the image of its master
through the affine transform, and (surfaces) every slave element is the image of a master
element through the node pairs, and every element is a quad. Prints one JSON line
{"ok": ..., "links": N, "violations": [...]} and exits 1 when a check fails.
"""
import json
import sys

import gmsh


def main():
    path = sys.argv[1]
    gmsh.initialize()
    gmsh.option.setNumber("General.Terminal", 0)
    bad = []
    links = 0
    try:
        gmsh.open(path)
        for dim in (1, 2):
            for _, tag in gmsh.model.getEntities(dim):
                master, nodes, mnodes, affine = gmsh.model.mesh.getPeriodicNodes(dim, tag)
                if master == tag:
                    continue
                links += 1
                pair = dict(zip(nodes, mnodes))
                tags, _, _ = gmsh.model.mesh.getNodes(dim, tag, includeBoundary=True)
                missing = [int(t) for t in tags if t not in pair]
                if missing:
                    bad.append(f"entity ({dim}, {tag}): {len(missing)} nodes without a master node, e.g. {missing[:5]}")
                if len(affine) == 16:
                    for s, m in pair.items():
                        ps, _, _, _ = gmsh.model.mesh.getNode(s)
                        pm, _, _, _ = gmsh.model.mesh.getNode(m)
                        img = [sum(affine[4 * r + c] * pm[c] for c in range(3)) + affine[4 * r + 3] for r in range(3)]
                        if max(abs(a - b) for a, b in zip(img, ps)) > 1e-7 * max(1.0, max(abs(x) for x in pm)):
                            bad.append(f"entity ({dim}, {tag}): node {s} is not the image of master node {m}")
                            break
                if dim != 2:
                    continue
                def faces(t):
                    out = []
                    types, _, enodes = gmsh.model.mesh.getElements(2, t)
                    for ty, ns in zip(types, enodes):
                        k = {2: 3, 3: 4}.get(ty)
                        if k is None:
                            bad.append(f"surface {t}: element type {ty}")
                            continue
                        if k == 3:
                            bad.append(f"surface {t}: {len(ns) // 3} triangles")
                        out += [tuple(ns[i:i + k]) for i in range(0, len(ns), k)]
                    return out
                mf = {tuple(sorted(f)) for f in faces(master)}
                sf = faces(tag)
                if len(sf) != len(mf):
                    bad.append(f"surface {tag}: {len(sf)} elements, its master {master} has {len(mf)}")
                for f in sf:
                    img = tuple(sorted(pair.get(n, -1) for n in f))
                    if img not in mf:
                        bad.append(f"surface {tag}: element with nodes {list(map(int, f))} is not the image of a master element")
                        break
    finally:
        gmsh.finalize()
    print(json.dumps({"ok": not bad, "links": links, "violations": bad}))
    sys.exit(0 if not bad else 1)


if __name__ == "__main__":
    main()
