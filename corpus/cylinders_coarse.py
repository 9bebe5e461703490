"""Three OpenCASCADE cylinders of random radius, height and tilt fused with a base slab
(`_shapes.cylinders`, seed 3), meshed coarse: a few segments around each circumference,
strips of long triangles down the lateral faces, seam curves, wall corners near 90 and
270 degrees where the cylinders meet the slab. About 670 triangles at the coarse size
0.45.

    python3 corpus/cylinders_coarse.py SIZE OUTPUT.msh [Option.Name=VALUE ...]
"""

import gmsh

import _model
import _shapes

size, output, tmp = _model.start("cylinders_coarse")
faces = _shapes.cylinders(3)
gmsh.option.setNumber("Mesh.MeshSizeMax", size)
gmsh.model.addPhysicalGroup(2, faces, name="skin")
_model.finish(output, tmp)
