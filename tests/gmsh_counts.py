#!/usr/bin/env python3
"""Print, for each MSH file given, what Gmsh sees in it, as one JSON object per line:
{"file", "nodes", "types": {type: count}, "entities": [n0, n1, n2, n3], "groups": [[dim, tag], ...],
 "error": null or message}. Used by tests/msh/gmsh.rs to compare with blossomquad's reader."""
import sys

import gmsh

from check_mesh import _dumps  # numpy-safe JSON, shared with the checker

gmsh.initialize(interruptible=False)
gmsh.option.setNumber("General.Terminal", 0)
for path in sys.argv[1:]:
    gmsh.clear()
    rec = {"file": path, "error": None}
    try:
        gmsh.open(path)
        tags, _, _ = gmsh.model.mesh.getNodes()
        rec["nodes"] = len(tags)
        types, etags, _ = gmsh.model.mesh.getElements()
        rec["types"] = {str(t): len(e) for t, e in zip(types, etags)}
        rec["entities"] = [len(gmsh.model.getEntities(d)) for d in range(4)]
        rec["groups"] = sorted([list(g) for g in gmsh.model.getPhysicalGroups()])
    except Exception as e:  # noqa: BLE001 - report any Gmsh failure to the test
        rec["error"] = str(e)
    print(_dumps(rec), flush=True)
gmsh.finalize()
