"""Writes v41_thin_cylinder_folded.msh: Gmsh's mesh (OpenCASCADE, MSH 4.1) of a box with a
thin cylinder (radius 0.0573) fused on its top, meshed at size 0.142, about 2.5 times the
radius: around the cylinder Gmsh's triangles fold over each other (opposite normals across
an edge).

Usage: python3 thin_cylinder.py OUT.msh
"""

import sys

import gmsh


def main(out):
    gmsh.initialize()
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.model.add("thin_cylinder")
    box = gmsh.model.occ.addBox(0, 0, 0, 1, 1, 0.5)
    cylinder = gmsh.model.occ.addCylinder(
        0.6080531675021457, 0.4303110009161265, 0.5,
        0.03152749081422662, -0.17381010844190856, 0.8520004499706137,
        0.057309426498244095)
    gmsh.model.occ.fuse([(3, box)], [(3, cylinder)])
    gmsh.model.occ.synchronize()
    h = 0.14219911718718403
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
