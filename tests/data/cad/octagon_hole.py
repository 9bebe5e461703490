"""Writes v41_octagon_hole_near_curve.msh: Gmsh's mesh (OpenCASCADE, MSH 4.1, size 0.3) of
a 4 x 1 strip below a 4 x 2 plate that has a regular octagonal hole (circumradius 0.4) whose
flat bottom edge lies 0.03 above the curve the two faces share. The plate's corners at the
ends of that edge are reflex (225 degrees), and the triangle in the middle of each has its
third side on the shared curve: its only neighbours are the two triangles beside it.

Usage: python3 octagon_hole.py OUT.msh
"""

import math
import sys

import gmsh

GAP = 0.03
SIZE = 0.3
RADIUS = 0.4


def main(out):
    gmsh.initialize()
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.model.add("octagon_hole")
    occ = gmsh.model.occ
    occ.addRectangle(0, 0, 0, 4, 1, 1)
    occ.addRectangle(0, 1, 0, 4, 2, 2)
    apothem = RADIUS * math.cos(math.pi / 8)
    corners = []
    for i in range(8):
        t = -math.pi / 2 - math.pi / 8 + i * math.pi / 4
        corners.append(
            occ.addPoint(2 + RADIUS * math.cos(t), 1 + GAP + apothem + RADIUS * math.sin(t), 0)
        )
    lines = [occ.addLine(corners[i], corners[(i + 1) % 8]) for i in range(8)]
    hole = occ.addPlaneSurface([occ.addCurveLoop(lines)])
    occ.cut([(2, 2)], [(2, hole)])
    occ.fragment(occ.getEntities(2), [])
    occ.synchronize()
    gmsh.option.setNumber("Mesh.MeshSizeMin", SIZE)
    gmsh.option.setNumber("Mesh.MeshSizeMax", SIZE)
    gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
    gmsh.model.mesh.generate(2)
    gmsh.write(out)
    gmsh.finalize()


if __name__ == "__main__":
    main(sys.argv[1])
