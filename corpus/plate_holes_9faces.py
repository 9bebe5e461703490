"""A flat plate with three random polygonal holes, fragmented by three rectangles into
nine faces (`_shapes.plate_with_holes`, seed 15). About 1,300 triangles at the coarse
size 0.15.

    python3 corpus/plate_holes_9faces.py SIZE OUTPUT.msh [Option.Name=VALUE ...]
"""

import gmsh

import _model
import _shapes

size, output, tmp = _model.start("plate_holes_9faces")
faces = _shapes.plate_with_holes(15)
gmsh.option.setNumber("Mesh.MeshSizeMax", size)
gmsh.model.addPhysicalGroup(2, faces, name="plate")
_model.finish(output, tmp)
