"""Writes a STEP file with OpenCASCADE (box fused with a cylinder, a sphere, a cone), then
imports it and meshes it with Gmsh: python3 step_import.py SIZE OUT.msh."""
import os
import sys

import gmsh


def main():
    size, out = float(sys.argv[1]), sys.argv[2]
    step = os.path.splitext(out)[0] + ".step"
    gmsh.initialize()
    gmsh.option.setNumber("General.Terminal", 0)
    occ = gmsh.model.occ
    box = occ.addBox(0, 0, 0, 2, 1.5, 1)
    cyl = occ.addCylinder(1, 0.75, -0.5, 0, 0, 2, 0.4)
    occ.fuse([(3, box)], [(3, cyl)])
    occ.addSphere(3, 1, 1, 0.6)
    occ.addCone(5, 0, 0, 0, 0, 1, 0.5, 0.1)
    occ.synchronize()
    gmsh.write(step)
    gmsh.clear()
    occ.importShapes(step)
    occ.synchronize()
    gmsh.option.setNumber("Mesh.MeshSizeMax", size)
    gmsh.model.mesh.generate(2)
    gmsh.write(out)
    gmsh.finalize()


if __name__ == "__main__":
    main()
