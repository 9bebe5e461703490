"""STL remeshing of an analytic surface: a height field z = f(x, y) (two hills, a valley
and a sharp crease) is written as an ASCII STL by this script into a temporary directory,
merged, split by ClassifySurfaces (the crease becomes a feature curve), given a
geometry by CreateGeometry and remeshed at SIZE. An open surface with a boundary.

    python3 corpus/stl_terrain.py SIZE OUTPUT.msh [Option.Name=VALUE ...]
"""

import math
import os

import gmsh

import _model

size, output, tmp = _model.start("stl_terrain")


def height(x, y):
    hills = 0.4 * math.exp(-((x - 0.7) ** 2 + (y - 0.6) ** 2) / 0.08) + 0.25 * math.exp(-((x - 1.5) ** 2 + (y - 1.2) ** 2) / 0.05)
    valley = -0.15 * math.exp(-((y - 1.0 - 0.3 * math.sin(3 * x)) ** 2) / 0.03)
    crease = 1.5 * max(0.0, x - 1.2)
    return hills + valley + crease


n = 50
pts = [[(2.0 * i / n, 2.0 * j / n, height(2.0 * i / n, 2.0 * j / n)) for j in range(n + 1)] for i in range(n + 1)]
stl = os.path.join(tmp, "terrain.stl")
with open(stl, "w") as f:
    f.write("solid terrain\n")
    for i in range(n):
        for j in range(n):
            a, b, c, d = pts[i][j], pts[i + 1][j], pts[i + 1][j + 1], pts[i][j + 1]
            for tri in ((a, b, c), (a, c, d)):
                f.write("facet normal 0 0 0\nouter loop\n")
                for p in tri:
                    f.write(f"vertex {p[0]:.9g} {p[1]:.9g} {p[2]:.9g}\n")
                f.write("endloop\nendfacet\n")
    f.write("endsolid terrain\n")

gmsh.merge(stl)
gmsh.model.mesh.classifySurfaces(45 * math.pi / 180, True, True, math.pi)
gmsh.model.mesh.createGeometry()
gmsh.model.geo.synchronize()
gmsh.option.setNumber("Mesh.MeshSizeMax", size)
gmsh.model.addPhysicalGroup(2, [t for _, t in gmsh.model.getEntities(2)], name="ground")
_model.finish(output, tmp)
