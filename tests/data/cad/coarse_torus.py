"""Writes v41_coarse_torus.msh: Gmsh's mesh (OpenCASCADE, MSH 4.1 binary, Frontal-Delaunay,
size 0.3) of a torus of radii 1 and 0.105 fused with a cone of radii 0.763 and 0.149, height
2, through its hole. The torus tube, about 0.66 round, is meshed coarser than its
curvature: at some nodes a triangle turns 90 degrees or more from the others, and no pair
of triangles there makes a valid quad (the fallback splits them into three quads each).

Usage: python3 coarse_torus.py OUT.msh
"""

import sys

import gmsh


def main(out):
    gmsh.initialize()
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.model.add("coarse_torus")
    occ = gmsh.model.occ
    torus = occ.addTorus(0, 0, 0, 1.0, 0.10469908785221183)
    cone = occ.addCone(0, 0, -1, 0, 0, 2, 0.7631243517854458, 0.1487999620841889)
    occ.fuse([(3, torus)], [(3, cone)])
    occ.synchronize()
    gmsh.option.setNumber("Mesh.MeshSizeMax", 0.3)
    gmsh.option.setNumber("Mesh.Algorithm", 6)
    gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
    gmsh.option.setNumber("Mesh.Binary", 1)
    gmsh.model.addPhysicalGroup(2, [t for _, t in gmsh.model.getEntities(2)], name="skin")
    gmsh.model.mesh.generate(2)
    gmsh.write(out)
    gmsh.finalize()


if __name__ == "__main__":
    if len(sys.argv) != 2:
        print(__doc__, file=sys.stderr)
        sys.exit(2)
    main(sys.argv[1])
