"""Writes v41_edge_refined_box.msh: Gmsh's mesh (OpenCASCADE, MSH 4.1) of a unit box whose
size grows from 0.07 at its edges to 0.35 at 0.3 from them (a Threshold field on the
distance to the edges, sizes from the field alone). Along each edge, runs of boundary
triangles share an interior apex, and a boundary node with two triangles of one fan gets a
flat corner when they are paired. The variant `steep` (v41_edge_refined_box_steep.msh)
grows from 0.08 to 0.5 over the same 0.3: longer fans, three or more triangles at one apex.
The variant `cylinder` (v41_edge_refined_cylinder.msh) is a cylinder of radius 0.5 and
height 1 with the box's sizes: along its circles a segment turns 8 degrees, so a pair of one
fan's two triangles has a corner near 172 degrees at the fan node, valid but poor. Any other
sizes: FINE at the edges, COARSE at REACH from them.

Usage: python3 edge_refined_box.py [steep | cylinder | FINE COARSE REACH] OUT.msh
"""

import sys

import gmsh

FINE = 0.07
COARSE = 0.35
REACH = 0.3


def main(out, fine=FINE, coarse=COARSE, reach=REACH, cylinder=False):
    gmsh.initialize()
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.model.add("edge_refined_box")
    if cylinder:
        gmsh.model.occ.addCylinder(0, 0, 0, 0, 0, 1, 0.5)
    else:
        gmsh.model.occ.addBox(0, 0, 0, 1, 1, 1)
    gmsh.model.occ.synchronize()
    field = gmsh.model.mesh.field
    field.add("Distance", 1)
    field.setNumbers(1, "CurvesList", [c for _, c in gmsh.model.getEntities(1)])
    field.setNumber(1, "Sampling", 200)
    field.add("Threshold", 2)
    field.setNumber(2, "InField", 1)
    field.setNumber(2, "SizeMin", fine)
    field.setNumber(2, "SizeMax", coarse)
    field.setNumber(2, "DistMin", 0.0)
    field.setNumber(2, "DistMax", reach)
    field.setAsBackgroundMesh(2)
    gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)
    gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 0)
    gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)
    gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
    gmsh.model.mesh.generate(2)
    gmsh.write(out)
    gmsh.finalize()


if __name__ == "__main__":
    if len(sys.argv) == 3 and sys.argv[1] == "steep":
        main(sys.argv[2], fine=0.08, coarse=0.5)
    elif len(sys.argv) == 3 and sys.argv[1] == "cylinder":
        main(sys.argv[2], cylinder=True)
    elif len(sys.argv) == 5:
        fine, coarse, reach = (float(a) for a in sys.argv[1:4])
        main(sys.argv[4], fine, coarse, reach)
    else:
        main(sys.argv[1])
