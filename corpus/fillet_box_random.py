"""A box of random proportions with five random edges filleted (`_shapes.filleted_box`,
seed 2): narrow cylindrical fillet faces a few triangles wide ending on flat faces.
About 1,140 triangles at the coarse size 0.2.

    python3 corpus/fillet_box_random.py SIZE OUTPUT.msh [Option.Name=VALUE ...]
"""

import gmsh

import _model
import _shapes

size, output, tmp = _model.start("fillet_box_random")
faces = _shapes.filleted_box(2)
gmsh.option.setNumber("Mesh.MeshSizeMax", size)
gmsh.model.addPhysicalGroup(2, faces, name="skin")
_model.finish(output, tmp)
