#!/usr/bin/env python3
"""Breaks a valid quad mesh on purpose, to show that tests/check_mesh.py notices.

Usage: mutate.py SRC DST WHAT, WHAT one of
  triangle-left   replace the first quad by its two triangles
  flipped-quad    reverse the node order of the first quad
  duplicate-quad  add a second copy of the first quad
  moved-node      move the first node of curve 1 (a boundary node)
  lost-segment    delete the first line element of curve 1
  renamed-group   rename the first physical surface group
  flat-corner     move an interior node B of a quad (A, B, C, D) to the midpoint of A and
                  C: a 180-degree corner at B
  reflex-corner   move that node B just past the midpoint of A and C, away from B:
                  a corner above 180 degrees at B
  zero-edge       move that node B onto A: a zero-length edge
  periodic-dropped   remove the $Periodic section (the input must have one)
  periodic-unpaired  drop the last node pair of the first periodic link with two or more
  identity        rewrite unchanged (a baseline the checker must accept)
Writes DST as MSH 4.1 ASCII.
"""
import sys

import gmsh


def main(src, dst, what):
    gmsh.initialize(["mutate"], readConfigFiles=False)
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.open(src)
    mesh = gmsh.model.mesh
    if what.startswith("periodic-"):
        return periodic(dst, what)
    quads, _ = gmsh.model.mesh.getElementsByType(3)
    q = int(quads[0])
    _, qn, _, qtag = gmsh.model.mesh.getElement(q)
    a, b, c, d = (int(n) for n in qn)
    if what in ("flat-corner", "reflex-corner", "zero-edge"):
        interior = set()
        for _, s in gmsh.model.getEntities(2):
            interior |= {int(t) for t in mesh.getNodes(2, s, False, False)[0]}
        quads, nodes = mesh.getElementsByType(3)
        nodes = [int(n) for n in nodes]
        for i in range(len(quads)):
            quad = nodes[4 * i:4 * i + 4]
            k = next((k for k in range(4) if quad[k] in interior), None)
            if k is not None:
                a, b, c = quad[k - 1], quad[k], quad[(k + 1) % 4]
                break
        pa, pc = mesh.getNode(a)[0], mesh.getNode(c)[0]
        pb = mesh.getNode(b)[0]
        if what == "flat-corner":
            target = [(pa[j] + pc[j]) / 2 for j in range(3)]
        elif what == "reflex-corner":
            target = [1.3 * (pa[j] + pc[j]) / 2 - 0.3 * pb[j] for j in range(3)]
        else:
            target = list(pa)
        mesh.setNode(b, target, [])
    elif what == "triangle-left":
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
    elif what not in ("identity", "flat-corner", "reflex-corner", "zero-edge"):
        print(f"unknown mutation {what}", file=sys.stderr)
        return 2
    gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
    gmsh.option.setNumber("Mesh.Binary", 0)
    gmsh.write(dst)
    gmsh.finalize()
    return 0


def periodic(dst, what):
    """The periodic mutations (on a mesh with $Periodic links)."""
    mesh = gmsh.model.mesh
    gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
    gmsh.option.setNumber("Mesh.Binary", 0)
    if what == "periodic-unpaired":
        gmsh.write(dst)
        lines = open(dst).read().split("\n")
        i = lines.index("$Periodic") + 2  # past the number of links
        while not lines[i].startswith("$End"):
            # link: "dim tag master", affine line, node count, then that many pairs
            count = int(lines[i + 2])
            if count >= 2:
                lines[i + 2] = str(count - 1)
                del lines[i + 2 + count]
                break
            i += 3 + count
        else:
            print("no periodic link with two node pairs", file=sys.stderr)
            return 2
        with open(dst, "w") as f:
            f.write("\n".join(lines))
    elif what == "periodic-dropped":
        gmsh.write(dst)
        text = open(dst).read()
        start, end = text.find("$Periodic"), text.find("$EndPeriodic")
        if start < 0 or end < 0:
            print("no $Periodic section", file=sys.stderr)
            return 2
        with open(dst, "w") as f:
            f.write(text[:start] + text[end + len("$EndPeriodic\n"):])
    else:
        print(f"unknown mutation {what}", file=sys.stderr)
        return 2
    gmsh.finalize()
    return 0


if __name__ == "__main__":
    sys.exit(main(*sys.argv[1:4]))
