"""Second order: the plate with three polygonal holes fragmented into seven faces of
`plate_holes_7faces.py` (`_shapes.plate_with_holes`, seed 8) meshed with 6-node triangles
(`Mesh.ElementOrder = 2`). Its physical groups are surfaces only, so Gmsh writes no line
element (and no curve's 3-node segments) unless `Mesh.SaveAll = 1`; parity repair and
the fallback split curve segments whose mid-edge nodes are input nodes.

    python3 corpus/second_order_plate.py SIZE OUTPUT.msh [Option.Name=VALUE ...]
"""

import gmsh

import _model
import _shapes

size, output, tmp = _model.start("second_order_plate")
faces = _shapes.plate_with_holes(8)
gmsh.option.setNumber("Mesh.MeshSizeMax", size)
gmsh.option.setNumber("Mesh.ElementOrder", 2)
gmsh.model.addPhysicalGroup(2, faces, name="plate")
_model.finish(output, tmp)
