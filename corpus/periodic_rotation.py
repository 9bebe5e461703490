"""Rotational periodicity in 2D: a quarter annulus with two holes whose two straight cuts are
periodic curves through a 90-degree rotation about the z axis (gmsh.model.mesh.setPeriodic
on curves with a rotation matrix), plus a second piece whose top and bottom faces of a
revolved sector are periodic surfaces through a rotation.

    python3 corpus/periodic_rotation.py SIZE OUTPUT.msh [Option.Name=VALUE ...]
"""

import math

import gmsh

import _model

size, output, tmp = _model.start("periodic_rotation")
occ = gmsh.model.occ
ring = occ.addDisk(0, 0, 0, 2, 2)
hole = occ.addDisk(0, 0, 0, 1, 1)
quarter = occ.addRectangle(0, 0, 0, 3, 3)
occ.cut([(2, ring)], [(2, hole)])
part, _ = occ.intersect([(2, ring)], [(2, quarter)])
h1 = occ.addDisk(1.4 * math.cos(0.5), 1.4 * math.sin(0.5), 0, 0.2, 0.2)
h2 = occ.addDisk(1.6 * math.cos(1.2), 1.6 * math.sin(1.2), 0, 0.12, 0.12)
part, _ = occ.cut(part, [(2, h1), (2, h2)])
occ.synchronize()
gmsh.option.setNumber("Mesh.MeshSizeMax", size)
eps = 1e-6
on_x = [t for _, t in gmsh.model.getEntitiesInBoundingBox(0.9, -eps, -eps, 2.1, eps, eps, 1)]
on_y = [t for _, t in gmsh.model.getEntitiesInBoundingBox(-eps, 0.9, -eps, eps, 2.1, eps, 1)]
c, s = math.cos(math.pi / 2), math.sin(math.pi / 2)
rotation = [c, -s, 0, 0, s, c, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]
gmsh.model.mesh.setPeriodic(1, on_y, on_x, rotation)
gmsh.model.addPhysicalGroup(2, [t for _, t in gmsh.model.getEntities(2)], name="sector")
_model.finish(output, tmp)
