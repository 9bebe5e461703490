"""A small box with five random edges filleted (`_shapes.filleted_box`, seed 22), coarse:
fillet faces one or two triangles wide. About 370 triangles at the coarse size 0.3.

    python3 corpus/fillet_box_small.py SIZE OUTPUT.msh [Option.Name=VALUE ...]
"""

import gmsh

import _model
import _shapes

size, output, tmp = _model.start("fillet_box_small")
faces = _shapes.filleted_box(22)
gmsh.option.setNumber("Mesh.MeshSizeMax", size)
gmsh.model.addPhysicalGroup(2, faces, name="skin")
_model.finish(output, tmp)
