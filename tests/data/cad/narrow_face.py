"""A quarter of a thin cylinder (radius 0.04, 3 long) as one face, its arcs two segments
each and its straight sides at size 0.25 (built-in kernel, as `corpus/thin_wires.geo`
makes its wires): the face is one triangle wide, and at each end the arc's middle node
makes three triangles, so every perfect matching pairs triangles across two cells of the
strip (skewed quads) or splits far more triangles than it pairs.

    python3 narrow_face.py OUT.msh
"""

import sys

import gmsh

out = sys.argv[1]
gmsh.initialize()
gmsh.option.setNumber("General.Terminal", 0)
gmsh.model.add("narrow_face")
geo = gmsh.model.geo
r = 0.04
c = geo.addPoint(0, 0, 0)
a = geo.addPoint(r, 0, 0)
b = geo.addPoint(0, r, 0)
arc = geo.addCircleArc(a, c, b)
geo.mesh.setTransfiniteCurve(arc, 3)
top, face, _, _ = geo.extrude([(1, arc)], 0.1, 0.05, 3.0)
geo.mesh.setTransfiniteCurve(top[1], 3)
geo.synchronize()
gmsh.model.addPhysicalGroup(2, [face[1]], name="face")
gmsh.option.setNumber("Mesh.MeshSizeMax", 0.25)
gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)
gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
gmsh.model.mesh.generate(2)
gmsh.write(out)
gmsh.finalize()
