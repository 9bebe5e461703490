"""A unit box (OpenCASCADE) whose mesh size grows from SIZE at its twelve edges to 0.5 at
0.3 from them (a Threshold field on the distance to the edges, sizes from the
field alone): each curve is meshed much finer than the faces beside it, so runs of
boundary nodes have their two triangles at one interior apex (boundary fans) and every
perfect matching pairs two triangles of a fan into a quad flat at a boundary node. About
700 triangles at the coarse size 0.08, 950 at the fine size 0.06.

    python3 corpus/edge_refined_box.py SIZE OUTPUT.msh [Option.Name=VALUE ...]
"""

import gmsh

import _model

size, output, tmp = _model.start("edge_refined_box")
gmsh.model.occ.addBox(0, 0, 0, 1, 1, 1)
gmsh.model.occ.synchronize()
field = gmsh.model.mesh.field
field.add("Distance", 1)
field.setNumbers(1, "CurvesList", [c for _, c in gmsh.model.getEntities(1)])
field.setNumber(1, "Sampling", 200)
field.add("Threshold", 2)
field.setNumber(2, "InField", 1)
field.setNumber(2, "SizeMin", size)
field.setNumber(2, "SizeMax", 0.5)
field.setNumber(2, "DistMin", 0.0)
field.setNumber(2, "DistMax", 0.3)
field.setAsBackgroundMesh(2)
gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)
gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 0)
gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)
gmsh.model.addPhysicalGroup(2, [s for _, s in gmsh.model.getEntities(2)], name="skin")
_model.finish(output, tmp)
