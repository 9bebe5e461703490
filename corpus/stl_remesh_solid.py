"""STL remeshing: an OCC solid (a box with a cylindrical boss, its edges filleted) is
meshed coarsely and written as STL into a temporary directory; that STL is then merged
into a new model, split into faces by ClassifySurfaces (40-degree feature angle), given
a geometry by CreateGeometry and meshed again at SIZE - as one remeshes a scanned or
exported triangulation.

    python3 corpus/stl_remesh_solid.py SIZE OUTPUT.msh [Option.Name=VALUE ...]
"""

import math
import os

import gmsh

import _model

size, output, tmp = _model.start("stl_remesh_solid")
occ = gmsh.model.occ
box = occ.addBox(0, 0, 0, 2, 1.4, 0.6)
boss = occ.addCylinder(1, 0.7, 0.6, 0, 0, 0.5, 0.35)
solid, _ = occ.fuse([(3, box)], [(3, boss)])
occ.synchronize()
top = [t for _, t in gmsh.model.getEntitiesInBoundingBox(-0.01, -0.01, 0.59, 2.01, 1.41, 0.61, 1)]
occ.fillet([t for _, t in solid], top, [0.1])
occ.synchronize()
gmsh.option.setNumber("Mesh.MeshSizeMax", 0.08)
gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 12)
gmsh.model.mesh.generate(2)
stl = os.path.join(tmp, "part.stl")
gmsh.write(stl)

gmsh.clear()
gmsh.model.add("stl_remesh_solid_import")
gmsh.merge(stl)
gmsh.model.mesh.classifySurfaces(40 * math.pi / 180, True, True, math.pi)
gmsh.model.mesh.createGeometry()
gmsh.model.geo.synchronize()
gmsh.option.setNumber("Mesh.MeshSizeMax", size)
gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)
gmsh.model.addPhysicalGroup(2, [t for _, t in gmsh.model.getEntities(2)], name="skin")
_model.finish(output, tmp)
