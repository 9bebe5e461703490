"""Writes v41_thin_pin_own_side.msh: Gmsh's mesh (OpenCASCADE, MSH 4.1) of a box with a
tilted cylinder (radius 0.0779) fused on its top, meshed at size 0.218, about 2.8 times
the radius: the cylinder's cap is three triangles, and the lateral surface (surface 7)
wraps round its node 55 so sharply that a face there turns 90 degrees or more from the
node's area-weighted normal.

Usage: python3 thin_pin_own_side.py OUT.msh
"""

import sys

import gmsh


def main(out):
    gmsh.initialize()
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.model.add("thin_pin_own_side")
    box = gmsh.model.occ.addBox(0, 0, 0, 1, 1, 0.5)
    cylinder = gmsh.model.occ.addCylinder(
        0.3561474360305579, 0.3094464588555302, 0.5,
        0.19945226146916578, -0.1262985417188588, 0.5602960316076625,
        0.07791046899086365)
    gmsh.model.occ.fuse([(3, box)], [(3, cylinder)])
    gmsh.model.occ.synchronize()
    h = 0.2183707722112509
    gmsh.option.setNumber("Mesh.MeshSizeMax", h)
    gmsh.option.setNumber("Mesh.MeshSizeMin", h)
    gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)
    gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)
    gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
    gmsh.model.mesh.generate(2)
    gmsh.write(out)
    gmsh.finalize()


if __name__ == "__main__":
    main(sys.argv[1])
