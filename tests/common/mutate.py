#!/usr/bin/env python3
"""Breaks a valid quad mesh on purpose, to show that tests/check_mesh.py notices.

Usage: mutate.py SRC DST WHAT, WHAT one of
  triangle-left   replace the first quad by its two triangles
  flipped-quad    reverse the node order of the first quad
  duplicate-quad  add a second copy of the first quad
  moved-node      move the first node of curve 1 (a boundary node)
  lost-segment    delete the first line element of curve 1
  renamed-group   rename the first physical surface group
  identity        rewrite unchanged (a baseline the checker must accept)
Writes DST as MSH 4.1 ASCII.
"""
import sys

import gmsh


def main(src, dst, what):
    gmsh.initialize(["mutate"], readConfigFiles=False)
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.open(src)
    quads, _ = gmsh.model.mesh.getElementsByType(3)
    q = int(quads[0])
    _, qn, _, qtag = gmsh.model.mesh.getElement(q)
    a, b, c, d = (int(n) for n in qn)
    mesh = gmsh.model.mesh
    if what == "triangle-left":
        mesh.removeElements(2, qtag, [q])
        mesh.addElementsByType(qtag, 2, [], [a, b, c, a, c, d])
    elif what == "flipped-quad":
        mesh.removeElements(2, qtag, [q])
        mesh.addElementsByType(qtag, 3, [], [a, d, c, b])
    elif what == "duplicate-quad":
        mesh.addElementsByType(qtag, 3, [], [a, b, c, d])
    elif what == "moved-node":
        tags, coords, _ = mesh.getNodes(1, 1, False, False)
        mesh.setNode(int(tags[0]), [coords[0] + 1e-3, coords[1] + 2e-3, coords[2]], [])
    elif what == "lost-segment":
        types, etags, _ = mesh.getElements(1, 1)
        mesh.removeElements(1, 1, [int(etags[0][0])])
    elif what == "renamed-group":
        dim, tag = [g for g in gmsh.model.getPhysicalGroups() if g[0] == 2][0]
        gmsh.model.removePhysicalName(gmsh.model.getPhysicalName(dim, tag))
        gmsh.model.setPhysicalName(dim, tag, "renamed")
    elif what != "identity":
        print(f"unknown mutation {what}", file=sys.stderr)
        return 2
    gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
    gmsh.option.setNumber("Mesh.Binary", 0)
    gmsh.write(dst)
    gmsh.finalize()
    return 0


if __name__ == "__main__":
    sys.exit(main(*sys.argv[1:4]))
