"""A flat plate with three random polygonal holes, fragmented by three rectangles into
seven faces (`_shapes.plate_with_holes`, seed 8): sharp and reflex wall corners at the
hole vertices, next to fragment curves. About 970 triangles at the coarse size 0.18.

    python3 corpus/plate_holes_7faces.py SIZE OUTPUT.msh [Option.Name=VALUE ...]
"""

import gmsh

import _model
import _shapes

size, output, tmp = _model.start("plate_holes_7faces")
faces = _shapes.plate_with_holes(8)
gmsh.option.setNumber("Mesh.MeshSizeMax", size)
gmsh.model.addPhysicalGroup(2, faces, name="plate")
_model.finish(output, tmp)
