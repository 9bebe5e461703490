"""Writes v22_fillet_box_own_jacobian.msh: Gmsh's mesh (OpenCASCADE, default sizes, MSH 2.2)
of a 1 x 1.5 x 2 box with five of its edges filleted at radius 0.0843.

Usage: python3 fillet_box.py OUT.msh
"""

import sys

import gmsh


def main(out):
    gmsh.initialize()
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.model.add("fillet_box")
    box = gmsh.model.occ.addBox(0, 0, 0, 1, 1.5, 2)
    gmsh.model.occ.synchronize()
    gmsh.model.occ.fillet([box], [5, 8, 11, 7, 2], [0.08430771355308705])
    gmsh.model.occ.synchronize()
    gmsh.option.setNumber("Mesh.MshFileVersion", 2.2)
    gmsh.model.mesh.generate(2)
    gmsh.write(out)
    gmsh.finalize()


if __name__ == "__main__":
    main(sys.argv[1])
