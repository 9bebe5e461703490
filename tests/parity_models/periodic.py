"""Periodic test models meshed by Gmsh: python3 periodic.py rve|square SIZE OUT.msh.

rve: unit cube with a spherical inclusion, its 3 pairs of opposite faces periodic
(gmsh.model.mesh.setPeriodic); square: unit square with a hole, left/right and
bottom/top curves periodic."""
import sys

import gmsh


def tr(dx, dy, dz):
    return [1, 0, 0, dx, 0, 1, 0, dy, 0, 0, 1, dz, 0, 0, 0, 1]


def main():
    kind, size, out = sys.argv[1], float(sys.argv[2]), sys.argv[3]
    gmsh.initialize()
    gmsh.option.setNumber("General.Terminal", 0)
    occ = gmsh.model.occ
    e = 1e-6
    if kind == "rve":
        occ.addBox(0, 0, 0, 1, 1, 1)
        occ.addSphere(0.5, 0.5, 0.5, 0.3)
        occ.fragment([(3, 1)], [(3, 2)])
        occ.synchronize()

        def faces(x0, y0, z0, x1, y1, z1):
            box = gmsh.model.getEntitiesInBoundingBox(x0 - e, y0 - e, z0 - e, x1 + e, y1 + e, z1 + e, 2)
            return [t for _, t in box]

        gmsh.model.mesh.setPeriodic(2, faces(1, 0, 0, 1, 1, 1), faces(0, 0, 0, 0, 1, 1), tr(1, 0, 0))
        gmsh.model.mesh.setPeriodic(2, faces(0, 1, 0, 1, 1, 1), faces(0, 0, 0, 1, 0, 1), tr(0, 1, 0))
        gmsh.model.mesh.setPeriodic(2, faces(0, 0, 1, 1, 1, 1), faces(0, 0, 0, 1, 1, 0), tr(0, 0, 1))
    else:
        occ.addRectangle(0, 0, 0, 1, 1)
        occ.addDisk(0.4, 0.6, 0, 0.2, 0.2)
        occ.cut([(2, 1)], [(2, 2)])
        occ.synchronize()

        def curves(x0, y0, x1, y1):
            box = gmsh.model.getEntitiesInBoundingBox(x0 - e, y0 - e, -e, x1 + e, y1 + e, e, 1)
            return [t for _, t in box]

        gmsh.model.mesh.setPeriodic(1, curves(1, 0, 1, 1), curves(0, 0, 0, 1), tr(1, 0, 0))
        gmsh.model.mesh.setPeriodic(1, curves(0, 1, 1, 1), curves(0, 0, 1, 0), tr(0, 1, 0))
    gmsh.option.setNumber("Mesh.MeshSizeMax", size)
    gmsh.model.mesh.generate(2)
    gmsh.write(out)
    gmsh.finalize()


if __name__ == "__main__":
    main()
