#!/usr/bin/env python3
"""Independent checker for the quality views blossomquad writes (`--quality-view`,
`quality --view`) and for the scaled Jacobian of its quality report.

Usage: check_views.py MESH.msh [QUALITY.json]

MESH.msh is read with Gmsh's own reader (the `gmsh` Python module); nothing here uses
blossomquad's code. Prints `ok QUADS` and exits 0 when every check holds:

  loads      Gmsh opens MESH without an `Error` message.
  eta        an `$ElementData` view "eta" with exactly one value per quadrangle (types
             3, 16, 10), each in (0, 1].
  sj         an `$ElementData` view "scaled jacobian", one value per quadrangle, equal
             (1e-9 relative) to Gmsh's `minSIGE` of that element (the scaled Jacobian
             sampled at the nodes; Gmsh's `minSJ` is another normalization, above or
             below it).
  valence    a `$NodeData` view "valence": for each corner node of a quadrangle, the
             number of quadrangles having it as a corner.
  report     with QUALITY.json (`blossomquad quality MESH --json`): per surface,
             `sj_min` and `sj_mean` equal (1e-9 relative) the minimum and mean of
             Gmsh's `minSIGE` over the surface's quadrangles.
"""

import json
import sys
from collections import Counter

import gmsh

QUADS = {3: 4, 16: 8, 10: 9}


def close(a, b, rel=1e-9):
    return abs(a - b) <= rel * max(abs(a), abs(b), 1e-12)


def main():
    path = sys.argv[1]
    gmsh.initialize()
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.logger.start()
    gmsh.open(path)
    log = gmsh.logger.get()
    assert not any("Error" in line for line in log), log

    quads = {}  # element tag -> surface
    valence = Counter()
    for dim, ent in gmsh.model.getEntities(2):
        types, tags, nodes = gmsh.model.mesh.getElements(dim, ent)
        for ty, tg, nd in zip(types, tags, nodes):
            if ty not in QUADS:
                continue
            k = QUADS[ty]
            for i, t in enumerate(tg):
                quads[int(t)] = ent
                for n in nd[k * i:k * i + 4]:
                    valence[int(n)] += 1
    assert quads, "no quadrangle"

    views = {}
    for v in gmsh.view.getTags():
        kind, tags, data, _, _ = gmsh.view.getModelData(v, 0)
        name = gmsh.view.option.getString(v, "Name")
        views[name] = (kind, [int(t) for t in tags], [float(d[0]) for d in data])

    kind, tags, eta = views["eta"]
    assert kind == "ElementData" and sorted(tags) == sorted(quads), "eta: one value per quad"
    assert all(0 < x <= 1 + 1e-12 for x in eta), ("eta out of (0, 1]", min(eta))

    kind, tags, sj = views["scaled jacobian"]
    assert all(-1 - 1e-12 <= x <= 1 + 1e-12 for x in sj), ("sj out of [-1, 1]", min(sj))
    assert kind == "ElementData" and sorted(tags) == sorted(quads), "sj: one value per quad"
    sige = gmsh.model.mesh.getElementQualities(tags, "minSIGE")
    for t, ours, g in zip(tags, sj, sige):
        assert close(ours, g), ("scaled jacobian vs minSIGE", t, ours, g)

    kind, tags, val = views["valence"]
    assert kind == "NodeData", "valence kind"
    assert dict(zip(tags, (round(v) for v in val))) == dict(valence), "valence values"

    if len(sys.argv) > 2:
        with open(sys.argv[2]) as f:
            report = json.load(f)
        per_surface = {}
        for t, g in zip(views["scaled jacobian"][1], sige):
            per_surface.setdefault(quads[t], []).append(g)
        seen = 0
        for s in report["surfaces"]:
            values = per_surface.get(s["surface"])
            if not values:
                continue
            seen += 1
            assert close(s["sj_min"], min(values)), ("sj_min", s, min(values))
            assert close(s["sj_mean"], sum(values) / len(values)), ("sj_mean", s)
        assert seen == len(per_surface), "a surface missing from the report"
    print("ok", len(quads))
    gmsh.finalize()


if __name__ == "__main__":
    main()
