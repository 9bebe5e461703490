"""Writes v41_thin_pin_wrapped.msh: Gmsh's mesh (OpenCASCADE, MSH 4.1) of a box with a
thin tilted cylinder (radius 0.0537) fused on its top, meshed at size 0.110, about twice
the radius: the cylinder is a few triangles round, so the stars of two nodes on opposite
sides of it (108 and 494, joined by an edge of two triangles) share four of their six
neighbours, and a hexagon that an edge swap would cut from one of them to the other lies
across that edge.

Usage: python3 thin_pin_wrapped.py OUT.msh
"""

import sys

import gmsh


def main(out):
    gmsh.initialize()
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.model.add("thin_pin_wrapped")
    box = gmsh.model.occ.addBox(0, 0, 0, 1, 1, 0.5)
    cylinder = gmsh.model.occ.addCylinder(
        0.5629890010629022, 0.5665641884499353, 0.5,
        -0.1429598588298529, -0.19565582276397284, 0.6873772460316823,
        0.053728533934427405)
    gmsh.model.occ.fuse([(3, box)], [(3, cylinder)])
    gmsh.model.occ.synchronize()
    h = 0.11004121042489755
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
