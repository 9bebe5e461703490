"""A slab with six thin cylindrical pins (radius 0.02 to 0.08, random height and tilt;
`_shapes.thin_pins`, seed 1) meshed coarser than their radius: Gmsh's mesh of the pins'
lateral faces folds (neighbouring triangles with opposite normals) while every other
face is fine. About 1,200 triangles at the coarse size 0.3.

    python3 corpus/thin_pins_folded.py SIZE OUTPUT.msh [Option.Name=VALUE ...]
"""

import gmsh

import _model
import _shapes

size, output, tmp = _model.start("thin_pins_folded")
faces = _shapes.thin_pins(1)
gmsh.option.setNumber("Mesh.MeshSizeMax", size)
gmsh.model.addPhysicalGroup(2, faces, name="skin")
_model.finish(output, tmp)
