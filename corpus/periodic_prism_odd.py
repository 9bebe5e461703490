"""A prism with a periodic pair: a plate with three random polygonal holes extruded by
0.6, its top face periodic with its bottom face (a translation along z, with
gmsh.model.mesh.setPeriodic; `_shapes.periodic_prism`, seed 18). Gmsh meshes the top as
an exact copy of the bottom; the side faces and both ends need parity repair and
fallback splits, which must land on the master and the slave alike. About 1,240
triangles at the coarse size 0.25.

    python3 corpus/periodic_prism_odd.py SIZE OUTPUT.msh [Option.Name=VALUE ...]
"""

import gmsh

import _model
import _shapes

size, output, tmp = _model.start("periodic_prism_odd")
faces = _shapes.periodic_prism(18)
gmsh.option.setNumber("Mesh.MeshSizeMax", size)
gmsh.model.addPhysicalGroup(2, faces, name="skin")
_model.finish(output, tmp)
